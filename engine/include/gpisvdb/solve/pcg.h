#pragma once
// Preconditioned conjugate gradients for a symmetric positive definite operator (docs/math.md#pcg): float storage,
// double reductions, working in place on the caller's arrays. The solver allocates its work vectors once
// (r, z, p, A p and the preconditioner: 5 floats per unknown for Jacobi, plus the incomplete factor for IC), so
// repeated solves — and every iteration — allocate nothing of size N. Iterates until the recursively updated
// residual satisfies ‖r‖ ≤ tolerance·‖b‖, then checks the true residual b − A x: in float storage the two drift
// apart, so while the true one misses the tolerance the iteration restarts from it (at most 8 times, and only while
// each restart halves it). Stops there or after maxIterations. Deterministic for any thread count.
#include <memory>
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/ops/linear_operator.h"

namespace gpisvdb {

enum class Preconditioner {
    Jacobi,              ///< diag(A)⁻¹: parallel, no set-up, works matrix-free
    IncompleteCholesky,  ///< Eigen's IC(0) with AMD ordering and diagonal shift on the assembled matrix: fewer
                         ///< iterations, serial set-up and triangular solves
};

struct PcgOptions {
    double tolerance = 1e-6;     ///< relative residual ‖b − A x‖ / ‖b‖ to reach (> 0)
    int maxIterations = 10000;   ///< cap (≥ 1)
    Preconditioner preconditioner = Preconditioner::Jacobi;  ///< measured faster to tolerance (docs/operators.md)
};

struct PcgResult {
    int iterations = 0;
    double relativeResidual = 0;  ///< true relative residual ‖b − A x‖ / ‖b‖ at exit (reductions in double)
    int restarts = 0;             ///< restarts from the true residual
    bool converged = false;       ///< relativeResidual ≤ tolerance
};

/// A PCG bound to one operator: the preconditioner is set up and the work vectors allocated at construction.
/// The operator must outlive the solver. One solve at a time per object.
class PcgSolver {
public:
    /// Throws ParameterError for bad options, or for IC on an operator that holds no matrix.
    explicit PcgSolver(const SymmetricOperator& A, const PcgOptions& options = {});
    ~PcgSolver();
    /// Solves A x = b; x holds the initial guess on entry (resized to N and zeroed if it has another length).
    PcgResult solve(const std::vector<float>& b, std::vector<float>& x, const Progress& progress = {}) const;
    /// Bytes held by the work vectors and the preconditioner.
    std::size_t memoryBytes() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// One solve: PcgSolver(A, options).solve(b, x, progress).
PcgResult solvePcg(const SymmetricOperator& A, const std::vector<float>& b, std::vector<float>& x,
                   const PcgOptions& options = {}, const Progress& progress = {});
/// Same, on an assembled matrix.
PcgResult solvePcg(const SparseMatrixF& A, const std::vector<float>& b, std::vector<float>& x,
                   const PcgOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
