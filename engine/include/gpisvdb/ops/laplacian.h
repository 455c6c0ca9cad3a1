#pragma once
// The adaptive-stencil Laplacian L and the mass M of a band (paper Eq. 22, 24; docs/math.md#operators).
//   E_h(u) = h^(d−2) Σ_x Σ_k λ_k(x) [(u(x+he_k) − u(x))² + (u(x−he_k) − u(x))²] / 2,   uᵀ L u = E_h(u),
// so each edge (x, x+he) carries h (λ^e(x) + λ^e(x+he))/2 (d = 3), and an edge leaving the band adds to the
// diagonal only (u = 0 outside: homogeneous Dirichlet). M = h³ diag(μ), so uᵀ M v → ∫ u v dμ; Δ_φ = −M⁻¹ L.
// Two forms of L: matrix-free over the band's stencils (LaplacianOperator, the PCG's default) and assembled in
// compressed rows of float values (assembleLaplacian, for factorisations and cross-checks).
#include <cstdint>
#include <memory>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/ops/linear_operator.h"

namespace gpisvdb {

/// L over the band's voxels (linear index order), symmetric by construction. Deterministic for any thread count.
SparseMatrixF assembleLaplacian(const Band& band);

/// The same L with entries summed in double (the eigen solver's: its residuals reach 1e-10, below float's
/// rounding of the entries). Same sparsity and order of sums as assembleLaplacian.
SparseMatrixD assembleLaplacianDouble(const Band& band);

/// M's diagonal, h³ μ (world units², so uᵀ M v → ∫ u v dμ).
std::vector<float> massDiagonal(const Band& band);

/// What assembleLaplacian and assembleLaplacianDouble make and hold, counted from the band's stencils without
/// assembling (one pass of index-tree look-ups, no allocation), so that their memory can be refused beforehand.
struct LaplacianSize {
    std::size_t voxels = 0;         ///< rows of L
    std::size_t entries = 0;        ///< stored entries of L, its diagonal included: exactly L.nonZeros()
    std::size_t contributions = 0;  ///< off-diagonal contributions held before each row is merged: 2 per stencil
                                    ///< neighbour inside the band (an edge met from both ends counts twice)
};
LaplacianSize laplacianSize(const Band& band);

/// Bytes of the assembled L with `scalarBytes` values (4 float, 8 double): value + 4 B column index per entry,
/// 4 B per row start.
double assembledLaplacianBytes(const LaplacianSize& size, std::size_t scalarBytes);

/// Peak bytes the assembly allocates, L included: the larger of its emission phase (12 neighbour indices, a row
/// start and a cursor per voxel, the diagonal, the contributions: a 4 B column and a value each, padded to 8 or 16
/// B) and its last phase (row starts and ends, the diagonal, the contributions and L itself).
double laplacianAssemblyBytes(const LaplacianSize& size, std::size_t scalarBytes);

/// L applied straight from the band's Selling stencils, each edge added to both of its ends. Holds a reference
/// to the band (which must outlive it), the linear indices of each voxel's 2 × 6 stencil neighbours (resolved
/// once through the index tree), a double accumulator per voxel (sums in double, one rounding per output, as
/// accurate as a row of the assembled matrix) and a schedule of a few bytes per leaf: 56 bytes per voxel, against
/// 108–125 for the assembled matrix (measured on the bunny). Scatters run colour by colour (engine/src/ops/scatter_schedule.h), so the
/// result does not depend on the thread count. One object must not be applied from two threads at once.
class LaplacianOperator final : public SymmetricOperator {
public:
    explicit LaplacianOperator(const Band& band);
    ~LaplacianOperator() override;
    std::size_t size() const override { return band_.size(); }
    void apply(const float* u, float* out) const override;
    /// The same sums, accumulated straight into `out` (which therefore must not alias u).
    void apply(const double* u, double* out) const override;
    void diagonal(float* out) const override;
    bool assemblable() const override { return true; }
    /// assembleLaplacian(band): the same matrix as the stencils apply.
    SparseMatrixF assemble() const override;
    using SymmetricOperator::apply;
    /// Bytes held by the operator itself (neighbour indices, accumulator, schedule), beyond the band.
    std::size_t memoryBytes() const;
    const Band& band() const { return band_; }
    /// Each voxel's stencil neighbours: voxel i, term k, sign s (+e_k, −e_k) at [12 i + 2 k + s], the linear index
    /// or −1 outside the band (or beyond the voxel's term count). The edge it names carries h λ_k(i)/2.
    const std::int32_t* neighbours() const;

private:
    struct Schedule;
    const Band& band_;
    std::unique_ptr<Schedule> schedule_;
};

/// Bytes the matrix-free Laplacian (LaplacianOperator) allocates for n band voxels: its neighbour table (12 int32
/// per voxel) and its per-voxel sums in double, 56 B per voxel; the scatter schedule (a few bytes per leaf) is
/// below the measurement's resolution and not counted.
double laplacianOperatorBytes(std::size_t n);

}  // namespace gpisvdb
