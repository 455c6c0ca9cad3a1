#pragma once
// Hodge decomposition of a vector field on the band (paper Eq. 29, App. E; docs/math.md#hodge):
//   V = G_φ ψ + V_free,   K ψ = Gᵀ (M ⊗ I) V,   K = M D_φ G_φ = Gᵀ BlockDiag(h³ T) G (NaiveLaplacianOperator),
// so that M D_φ V_free = Gᵀ (M ⊗ I) V − K ψ is the PCG's residual: D_φ V_free = 0 to the solver's tolerance (in the
// M-weighted norm). The projection I − G_φ (D_φ G_φ)⁻¹ D_φ is orthogonal in the inner product ⟨a, b⟩_S =
// Σ h³ aᵢᵀ Sᵢ bᵢ with S = μ² T⁻¹ (App. E); since S G_φ ψ = μ G ψ, that inner product of the two parts needs no T⁻¹.
// Vector fields are interleaved, 3 floats per voxel, world units.
// Boundary: G, G_φ, D_φ and K all take the same condition. Neumann (the default) leaves ψ free at the band's
// boundary, so gradients of potentials that do not vanish there are recovered and V_free carries no μ-flux out of
// the band; Dirichlet (ψ = 0 outside, paper Eq. 20) forces ψ to 0 across the thin band and moves part of any such
// gradient into V_free (measured in docs/hodge.md).
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/ops/first_order.h"
#include "gpisvdb/solve/pcg.h"

namespace gpisvdb {

struct HodgeOptions {
    /// PCG on K (Jacobi). 1e-5 by default: the right-hand side is a divergence, a difference of much larger terms,
    /// and the float PCG alone stalls near 1e-6 on real bands (measured on the bunny; 1.6e-6 on a unit sphere at
    /// σ_rel 0.25, h 0.03). Where it stalls above the tolerance, or the tolerance is below kFloatPcgReach, the
    /// solve continues by iterative refinement in double (solve/pcg.h), with the right-hand side and ψ in double.
    PcgOptions solver = [] {
        PcgOptions o;
        o.tolerance = 1e-5;
        return o;
    }();
    Boundary boundary = Boundary::Neumann;  ///< condition on ψ at the band's boundary (see above)
};

struct HodgeResult {
    std::vector<float> potential;  ///< ψ (N), world units × the field's (rounded to float when refined)
    std::vector<float> gradient;   ///< V_grad = G_φ ψ (3N)
    std::vector<float> free;       ///< V_free = V − V_grad (3N)
    /// The solve; when refined, solver.relativeResidual is that of ψ in double and solver.floatResidual that of
    /// the float ψ stored above.
    PcgResult solver;
    /// ‖M D_φ V_free‖ / ‖M D_φ V‖, evaluated from the stored float parts (0 when D_φ V = 0): float's rounding of
    /// V_grad and V_free bounds it whatever the solver's tolerance (measured ≈ 4e-8 on unit-sphere bands refined to
    /// 1e-8 … 1e-12).
    double divergenceResidual = 0;
    /// ⟨V_grad, V_free⟩_S / (‖V_grad‖_S ‖V_free‖_S), S = μ² T⁻¹ (T⁻¹ with eigenvalues floored at 1e-6 λmax);
    /// 0 when either part vanishes.
    double sInnerProduct = 0;
};

/// Splits V (3N) on the band. Throws Error when V has the wrong length or is not finite.
/// Bytes hodgeDecomposition allocates beside the band and V (docs/memory.md), per voxel: D_φ V, the right-hand side,
/// ψ, the operator's flux (4 + 4 + 4 + 12), the face labels with Neumann (4), then the larger of the float PCG's
/// work vectors (20) and the parts and their check (G_φ ψ, V_free, D_φ V_free: 28). When the solve refines (a
/// tolerance below kFloatPcgReach, Refinement::Always, or `includeFallback` for a float solve that stalls) the
/// refinement's phase adds the operator's double flux (24), the right-hand side and ψ in double (16) and the
/// double solve's vectors (44 in all) instead.
double hodgeBytes(std::size_t n, const HodgeOptions& options, bool includeFallback = false);

/// V = G_φ ψ + V_free with D_φ V_free = 0 (paper App. E): ψ from (G_φᵀ BlockDiag(h³ T) G_φ) ψ = G_φᵀ (M ⊗ I) V by
/// the PCG.
/// \param band      the band (its μ and T), N voxels
/// \param V         the vector field, 3N floats (x, y, z per voxel, by linear index), world units
/// \param options   the solver's tolerance, iteration cap and refinement
/// \param progress  reports the PCG's iterations; its interrupt stops the solve (Cancelled)
/// \return ψ, the gradient and free parts (3N each) and the checks of the split (divergence residual, S-orthogonality)
/// \throws Error when V does not have 3N entries; InputError when it holds NaN or ∞; ParameterError for bad options;
///         Cancelled when interrupted (a solve short of its tolerance is returned with solver.converged false)
/// \par Complexity
///   O(N) per PCG iteration on the face-flux operator; memory hodgeBytes(N, options) beside the band and V.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel inside (TBB); the result is the same for any thread
///   count.
HodgeResult hodgeDecomposition(const Band& band, const std::vector<float>& V, const HodgeOptions& options = {},
                               const Progress& progress = {});

/// ⟨a, b⟩_S over the band (a, b of length 3N); T⁻¹ as in HodgeResult::sInnerProduct.
double sInnerProduct(const Band& band, const std::vector<float>& a, const std::vector<float>& b);

/// Built-in test fields, about the μ-weighted centroid c of the band and the z axis (world units):
///   Rotation: e_z × (x − c), tangent to any surface of revolution about that axis, so μ-divergence-free there;
///   Gradient: grad_φ z = (T/μ) e_z, the GPIS gradient of the height;
///   Mixed:    the sum of the two.
enum class HodgePreset { Rotation, Gradient, Mixed };
std::vector<float> hodgePreset(const Band& band, HodgePreset preset);

}  // namespace gpisvdb
