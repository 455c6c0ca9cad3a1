#pragma once
// Algebraic multigrid preconditioner: one V-cycle of hypre's BoomerAMG (Henson & Yang 2002) on an assembled symmetric
// M-matrix such as the band's Laplacian (docs/operators.md#multigrid). Used by the PCG (solve/pcg.h,
// Preconditioner::Multigrid): its iteration count stays nearly flat as the band grows, where Jacobi's grows like
// N^(1/3) (the band's diameter in voxels).
//
// The V-cycle is a fixed symmetric positive definite operator — HMIS coarsening, extended+i interpolation,
// symmetric ℓ1-Gauss–Seidel smoothing (forward on the way down, backward on the way up), a direct solve on the
// coarsest level — so the PCG stays a conjugate-gradient method. hypre runs on one core (Debian's build has no
// OpenMP); its result does not depend on the thread count. hypre is an MPI library: the first BoomerAmg of a process
// initialises MPI for this process alone (a singleton, no launcher and no daemon) unless the caller already has.
#include <cstddef>
#include <memory>

#include "gpisvdb/ops/linear_operator.h"

namespace gpisvdb {

struct BoomerAmgOptions {
    /// θ of the classical strength of connection: a_ij is strong when −a_ij ≥ θ max_k(−a_ik). hypre recommends
    /// 0.5–0.6 in 3-D; measured on bunny bands (docs/operators.md#multigrid).
    double strongThreshold = 0.5;
    int maxInterpolationEntries = 4;  ///< entries kept per row of the interpolation (> 0): bounds the coarse operators
    /// Levels coarsened aggressively (≥ 0): on the bunny one level halves the set-up time and the memory (operator
    /// complexity 3.4 → 1.5) for 9 → 13 iterations, sooner in all.
    int aggressiveLevels = 1;
};

/// hypre's BoomerAMG hierarchy of one matrix, built at construction. One apply at a time per process (calls into
/// hypre are serialised by a global lock).
class BoomerAmg {
public:
    /// Builds the hierarchy of A (square, symmetric, positive diagonal). Throws ParameterError on bad options or an
    /// empty matrix, Error when hypre fails.
    explicit BoomerAmg(const SparseMatrixF& A, const BoomerAmgOptions& options = {});
    /// The same, freeing A as soon as hypre holds its copy, before the hierarchy is built (less peak memory).
    explicit BoomerAmg(SparseMatrixF&& A, const BoomerAmgOptions& options = {});
    /// The same from L in double (compressed columns: A symmetric, so they are read as its rows).
    explicit BoomerAmg(const SparseMatrixD& A, const BoomerAmgOptions& options = {});
    ~BoomerAmg();
    BoomerAmg(const BoomerAmg&) = delete;
    BoomerAmg& operator=(const BoomerAmg&) = delete;

    /// z = B r, B ≈ A⁻¹ one V-cycle from z = 0 (r and z of length N, not aliased).
    void apply(const float* r, float* z) const;
    void apply(const double* r, double* z) const;

    int levels() const;                 ///< levels of the hierarchy, the finest included
    double operatorComplexity() const;  ///< Σ nonzeros of all levels' operators / nonzeros of A
    /// Bytes held by hypre for the hierarchy (operators, interpolations, work vectors), counted from its matrices.
    std::size_t memoryBytes() const;

private:
    template <class Matrix>
    void setUp(const Matrix& A, Matrix* release, const BoomerAmgOptions& options);
    struct Impl;
    template <class T>
    static void applyAs(Impl& m, const T* r, T* z);
    std::unique_ptr<Impl> impl_;
};

/// Peak bytes the multigrid preconditioner adds for n unknowns of the band Laplacian while it is
/// set up and kept: the assembled L (float), hypre's copy of it and the hierarchy; measured per voxel on bunny bands
/// (kMultigridBytesPerVoxel, docs/memory.md).
double multigridBytes(std::size_t n);

/// The multigrid's peak per unknown (above), measured.
extern const double kMultigridBytesPerVoxel;

}  // namespace gpisvdb
