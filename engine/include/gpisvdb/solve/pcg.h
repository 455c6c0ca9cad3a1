#pragma once
// Preconditioned conjugate gradients for a symmetric positive definite A (DESIGN §3.8): float storage, double
// reductions, in place on the caller's arrays (four work vectors of size N besides x and b), stopping when
// ‖b − A x‖ ≤ tolerance·‖b‖ or after maxIterations. Deterministic for any thread count.
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/ops/laplacian.h"

namespace gpisvdb {

struct PcgOptions {
    double tolerance = 1e-6;     ///< relative residual ‖b − A x‖ / ‖b‖ to reach (> 0)
    int maxIterations = 10000;   ///< cap (≥ 1)
};

struct PcgResult {
    int iterations = 0;
    double relativeResidual = 0;  ///< of the recursively updated residual at exit
    bool converged = false;
};

/// Jacobi-preconditioned CG; x holds the initial guess on entry (resized to N and zeroed if empty).
PcgResult solvePcg(const SparseMatrixF& A, const std::vector<float>& b, std::vector<float>& x,
                   const PcgOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
