#pragma once
// First-order operators on a band (paper Eq. 19, 22; docs/math.md#operators). Vector fields are stored interleaved,
// 3 floats per voxel (x, y, z of voxel i at 3i … 3i+2), world units per the field's own units.
//   G    forward differences, (G u)_i = ((u(x_i + h e_c) − u(x_i)) / h)_c, u = 0 outside the band (3N × N)
//   G_φ  = BlockDiag(T/μ) G: the GPIS gradient of Eq. 19 (T/μ averages tangent-plane projectors: eigenvalues in [0, 1])
//   D_φ  = M⁻¹ Gᵀ (M ⊗ I₃) (N × 3N). As in the paper, D_φ is the adjoint of G in the μ-weighted inner products,
//        i.e. minus the μ-divergence of Eq. 18: D_φ G_φ ≈ −Δ_φ, matching M⁻¹ L.
//   D_φ G_φ = M⁻¹ Gᵀ BlockDiag(h³ T) G: the naive Laplacian of Sec. 8.1, kept for comparison with L and for
//        exact Hodge projections. Its symmetric form K = M D_φ G_φ is NaiveLaplacianOperator.
// T here is the band's T channel as computed (not the anisotropy-regularised tensor the Selling stencils use).
// Matrix-free forms gather from the band's index tree (deterministic for any thread count); assembled forms are
// for factorisations and cross-checks.
// Boundary: Dirichlet (paper Eq. 20, the default) takes u = 0 outside the band; Neumann drops the differences
// that leave the band (zero normal derivative, hence D_φ with zero μ-flux through the band's boundary), which is
// what a Hodge decomposition needs to recover gradients of potentials that do not vanish there.
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/ops/linear_operator.h"

namespace gpisvdb {

enum class Boundary { Dirichlet, Neumann };

/// out (3N) = G u.
void gradient(const Band& band, const std::vector<float>& u, std::vector<float>& out, Boundary bc = Boundary::Dirichlet);
/// out (N) = Gᵀ v, v of length 3N.
void gradientTranspose(const Band& band, const std::vector<float>& v, std::vector<float>& out, Boundary bc = Boundary::Dirichlet);
/// out (3N) = G_φ u = (T/μ) G u per voxel.
void gradPhi(const Band& band, const std::vector<float>& u, std::vector<float>& out, Boundary bc = Boundary::Dirichlet);
/// The same from a potential held in double (a refined PCG solution, solve/pcg.h), rounded to float once, at the end.
void gradPhi(const Band& band, const std::vector<double>& u, std::vector<float>& out, Boundary bc = Boundary::Dirichlet);
/// out (N) = D_φ V = M⁻¹ Gᵀ (M ⊗ I) V, V of length 3N.
void divPhi(const Band& band, const std::vector<float>& V, std::vector<float>& out, Boundary bc = Boundary::Dirichlet);

SparseMatrixF assembleGradient(const Band& band, Boundary bc = Boundary::Dirichlet);  ///< G, 3N × N
SparseMatrixF assembleGradPhi(const Band& band);                                      ///< G_φ, 3N × N
SparseMatrixF assembleDivPhi(const Band& band);                                       ///< D_φ, N × 3N
SparseMatrixF assembleNaiveLaplacian(const Band& band);                               ///< D_φ G_φ, N × N (M-self-adjoint, not symmetric)

/// K = M D_φ G_φ = Gᵀ BlockDiag(h³ T) G, symmetric positive semi-definite, uᵀ K u = h³ Σ_x (Gu)ᵀ T (Gu)
/// (the naive discretisation of E[E_D(u)]). Holds a 3N work vector, so one object must not be applied from two
/// threads at once; the double apply keeps its own (3N doubles, allocated at its first call). With Neumann
/// boundaries K is only semi-definite (constants per connected component are in its kernel); the PCG still solves
/// K ψ = b for b = Gᵀ w, which is orthogonal to that kernel.
class NaiveLaplacianOperator final : public SymmetricOperator {
public:
    explicit NaiveLaplacianOperator(const Band& band, Boundary bc = Boundary::Dirichlet);
    std::size_t size() const override { return band_.size(); }
    void apply(const float* u, float* out) const override;
    void apply(const double* u, double* out) const override;
    void diagonal(float* out) const override;
    using SymmetricOperator::apply;

private:
    const Band& band_;
    Boundary bc_;
    mutable std::vector<float> flux_;         // h³ T G u, 3N
    mutable std::vector<double> fluxDouble_;  // the same for the double apply (empty until its first call)
};

}  // namespace gpisvdb
