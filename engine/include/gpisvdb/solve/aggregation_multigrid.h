#pragma once
// Aggregation multigrid for the band Laplacian (docs/operators.md#aggregation): the default preconditioner of the
// band's Green's function from 1e5 voxels, light enough for 1e8 voxels where hypre's BoomerAMG (≈ 440 B per voxel
// beside the operator) is not. It holds ≈ 35–55 B per band voxel, in float, and its cycles run on every thread.
//
// Each level groups the previous level's nodes in 2×2×2 blocks of its lattice (band voxels, then blocks of 2, 4, …
// voxels): P is piecewise constant on these aggregates and the coarse operator is Galerkin's Pᵀ A P. L is a graph
// Laplacian plus a diagonal (the edges that leave the band, docs/math.md#operators), so every coarse operator is one
// too: an edge between two aggregates carries the sum of the fine edges between them, edges inside an aggregate
// drop out, and nothing needs assembling at the finest level (the matrix-free L is used there). The coarsest level,
// ≤ AggregationOptions::coarsestUnknowns nodes, is solved exactly (dense Cholesky).
//
// Each level's cycle: ν damped-Jacobi sweeps before and after the coarse correction (the same ν and weight: the
// post-smoother is the pre-smoother's adjoint), the correction weighted by α. With AggregationOptions::kCycle (the
// default) each coarse level but the coarsest is solved by two flexible-CG steps preconditioned by its own cycle
// (the K-cycle), which keeps the iterations nearly flat as levels are added; the preconditioner is then not linear
// and the PCG uses the flexible β. Without it, a V-cycle: a fixed symmetric positive definite operator. Sums in
// double, each output rounded once; deterministic for any thread count.
#include <cstddef>
#include <memory>
#include <vector>

#include "gpisvdb/ops/laplacian.h"

namespace gpisvdb {

struct AggregationOptions {
    int smoothingSteps = 2;  ///< damped-Jacobi sweeps before and after each coarse correction (≥ 1)
    /// Jacobi's weight ω (0 < ω < 1): D⁻¹A of a diagonally dominant M-matrix has its eigenvalues in (0, 2], so any
    /// ω < 1 keeps the smoother convergent and the cycle positive definite; 2/3 damps the upper half best.
    double jacobiWeight = 2.0 / 3.0;
    /// α, the coarse correction's weight (1 ≤ α < 2): piecewise-constant interpolation under-corrects smooth errors
    /// (its coarse operator overestimates their energy); α = 1.3 measured best on bunny bands (15–25 % fewer
    /// iterations than 1). Any α < 2 keeps the cycle positive definite: the corrected error's A-norm stays ≤ 1.
    double coarseCorrectionWeight = 1.3;
    /// Each coarse level but the coarsest solved by two flexible-CG steps preconditioned by its own cycle (the
    /// K-cycle of Notay & Vassilevski 2008) instead of one cycle: iterations nearly independent of the levels'
    /// count, for ≈ 2× a V-cycle's coarse work. The preconditioner is then not linear: the PCG uses flexible CG's β
    /// (−z_{k+1}ᵀA p_k / p_kᵀA p_k). false: a plain V-cycle, a fixed symmetric positive definite operator.
    bool kCycle = true;
    std::size_t coarsestUnknowns = 512;  ///< a level with at most this many nodes (≤ 4096) is solved by dense Cholesky
    int maxLevels = 24;                  ///< levels at most, the finest included (≥ 2)
    /// Set-up memory: the first coarse level's transposed edges are formed this many at a time (8 B each; ≥ 1).
    /// The hierarchy does not depend on it.
    std::size_t transposeChunkEntries = std::size_t(1) << 25;
};

/// The hierarchy of one band Laplacian, built at construction (serial parts: a few passes over the band). The
/// operator (and its band) must outlive it. One apply at a time per object.
class AggregationMultigrid {
public:
    /// Throws ParameterError for bad options, Error for an empty band.
    explicit AggregationMultigrid(const LaplacianOperator& L, const AggregationOptions& options = {});
    ~AggregationMultigrid();
    AggregationMultigrid(const AggregationMultigrid&) = delete;
    AggregationMultigrid& operator=(const AggregationMultigrid&) = delete;

    /// z = B r, B ≈ L⁻¹ one cycle from z = 0 (r and z of length N, not aliased).
    void apply(const float* r, float* z) const;
    int levels() const;                           ///< levels, the finest (L itself) included
    bool linear() const;                          ///< false with the K-cycle: the PCG must use the flexible β
    double operatorComplexity() const;            ///< Σ stored entries of the coarse levels / L's stencil entries, plus 1
    std::size_t memoryBytes() const;              ///< bytes held: the coarse operators, aggregates, smoother and cycle vectors
    std::size_t coarseUnknowns(int level) const;  ///< nodes of level ≥ 1 (0 beyond the coarsest)
    /// out = A_level u for level ≥ 1 (u and out of coarseUnknowns(level)): what the tests compare with Pᵀ A P.
    void applyCoarse(int level, const float* u, float* out) const;
    /// The aggregate (a node of `level` ≥ 1) of each node of level − 1: P's columns.
    std::vector<std::int32_t> aggregateOf(int level) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Peak bytes the aggregation multigrid adds for n band voxels while it is set up
/// and kept: aggregates, coarse operators (its set-up holds the first coarse level twice), smoother and cycle
/// vectors; measured per voxel on bunny bands (kAggregationBytesPerVoxel, docs/memory.md).
double aggregationBytes(std::size_t n);

/// The aggregation multigrid's peak per band voxel (above), measured.
extern const double kAggregationBytesPerVoxel;

}  // namespace gpisvdb
