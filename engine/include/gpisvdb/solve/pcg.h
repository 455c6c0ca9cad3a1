#pragma once
// Preconditioned conjugate gradients for a symmetric positive definite A (DESIGN §3.8): float storage, double
// reductions, in place on the caller's arrays (four work vectors of size N besides x and b, plus the incomplete
// factor when asked for), stopping when
// ‖b − A x‖ ≤ tolerance·‖b‖ or after maxIterations. Deterministic for any thread count.
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/ops/laplacian.h"

namespace gpisvdb {

enum class Preconditioner {
    Jacobi,              ///< diag(A)⁻¹: parallel, no set-up
    IncompleteCholesky,  ///< Eigen's IC(0) with AMD ordering and diagonal shift: fewer iterations, serial solves
};

struct PcgOptions {
    double tolerance = 1e-6;     ///< relative residual ‖b − A x‖ / ‖b‖ to reach (> 0)
    int maxIterations = 10000;   ///< cap (≥ 1)
    Preconditioner preconditioner = Preconditioner::Jacobi;  ///< measured faster to tolerance (docs/operators.md)
};

struct PcgResult {
    int iterations = 0;
    double relativeResidual = 0;  ///< of the recursively updated residual at exit
    bool converged = false;
};

/// Preconditioned CG; x holds the initial guess on entry (resized to N and zeroed if empty).
PcgResult solvePcg(const SparseMatrixF& A, const std::vector<float>& b, std::vector<float>& x,
                   const PcgOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
