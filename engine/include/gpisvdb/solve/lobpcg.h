#pragma once
// The k lowest pairs of L u = λ M u without factoring L: LOBPCG (Knyazev 2001), the locally optimal block
// preconditioned conjugate gradient, preconditioned by one V-cycle of the multigrid (solve/boomer_amg.h) per
// residual (docs/spectrum.md#lobpcg). The eigen solver (solve/eigen_solver.h) takes this path where CHOLMOD's factor
// would not fit in memory: its memory is three blocks of N × m doubles (X, the preconditioned residuals W and the
// search directions P; m = k + guard vectors) and the hierarchy, against the factor's fill. The products L S and M S
// of the blocks are never stored whole: they are formed a chunk of rows at a time and reduced at once to the Gram
// matrices and residual norms they feed, and the Ritz update is row by row (docs/spectrum.md#lobpcg).
//
// Each iteration: the residuals R = L X − M X Λ, W = B R (B the V-cycle) for the pairs not yet converged, then a
// Rayleigh–Ritz step on span[X, W, P] in the M inner product, made robust by dropping the directions whose M-Gram
// eigenvalue falls below 1e-13 of the largest (a basis that lost rank when pairs converged). Deterministic: fixed
// start vectors, chunks of a fixed size summed in a fixed pattern, hypre's serial cycle; identical for any thread
// count.
#include <Eigen/Core>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/ops/linear_operator.h"
#include "gpisvdb/solve/boomer_amg.h"

namespace gpisvdb {

struct EigenResult;

struct LobpcgOptions {
    int guard = 0;                    ///< block vectors beyond k (≥ 0), which speed the k-th pair's convergence; 0: max(4, k/4)
    double tolerance = 1e-8;          ///< ‖L u − λ M u‖ / (|λ| ‖M u‖) each of the k pairs must reach (> 0)
    int maxIterations = 2000;         ///< cap on iterations before giving up (≥ 1)
    BoomerAmgOptions multigrid = {};  ///< the preconditioner's hierarchy
};

/// Block size m for k pairs: k plus the guard vectors, at most N.
int lobpcgBlockSize(int count, const LobpcgOptions& options, double n);

/// Bytes LOBPCG needs beyond L and M for k pairs on N unknowns: its three N × m blocks in double, the V-cycle's output
/// (N doubles), each thread's chunk of products (5 m columns of 2048 rows, two partial sums) and the multigrid's hierarchy
/// (kMultigridBytesPerVoxel, solve/boomer_amg.h, measured).
double lobpcgBytes(double n, int count, const LobpcgOptions& options);

/// Fills values, vectors (M-orthonormal, ascending), iterations and the multigrid fields of `result`; the caller
/// checks and reports as for the Lanczos path. Throws ParameterError for bad options, Error when the k pairs have
/// not converged within maxIterations, Cancelled when `progress` asks.
void lobpcg(const SparseMatrixD& L, const Eigen::VectorXd& mass, int count, const LobpcgOptions& options, EigenResult& result,
            const Progress& progress = {});

}  // namespace gpisvdb
