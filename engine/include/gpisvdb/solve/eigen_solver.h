#pragma once
// The k lowest pairs of the generalized eigenproblem L u = λ M u (paper Sec. 10.1; docs/math.md#spectrum), L symmetric
// positive definite (the band Laplacian with homogeneous Dirichlet conditions), M diagonal positive (the mass).
// Method, chosen by measurement (docs/spectrum.md, bench/results/spectrum.json): implicitly restarted Lanczos
// (Spectra) on the shift-invert operator L⁻¹ M, with L factored once by CHOLMOD's supernodal Cholesky. The
// Lanczos basis is M-orthonormal, so the eigenvectors come out with UᵀMU = I. Where the factor would not fit in
// EigenOptions::maxBytes, LOBPCG with the multigrid preconditioner (solve/lobpcg.h) takes over (EigenMethod).
#include <cstddef>
#include <Eigen/Core>
#include <string>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/ops/linear_operator.h"
#include "gpisvdb/solve/lobpcg.h"

namespace gpisvdb {

enum class EigenMethod {
    Automatic,    ///< Lanczos on CHOLMOD's factor when it fits in maxBytes (faster where it fits), else LOBPCG
    ShiftInvert,  ///< Lanczos on L⁻¹M through CHOLMOD's factor (refused beyond maxBytes)
    Lobpcg,       ///< LOBPCG preconditioned by the multigrid (solve/lobpcg.h): no factor
};

struct EigenOptions {
    int count = 20;            ///< k, the number of lowest pairs wanted (1 ≤ k < N)
    int subspace = 0;          ///< Lanczos basis size (k < ncv ≤ N); 0: max(2k, k + 20), capped at N. Memory: 16·N·ncv bytes
    double tolerance = 1e-10;  ///< Spectra's relative tolerance on each Ritz value of L⁻¹M
    int maxRestarts = 1000;    ///< cap on Lanczos restarts before giving up
    double maxBytes = 0;       ///< refuse (MemoryLimitError) when the solve would need more; 0: no cap
    EigenMethod method = EigenMethod::Automatic;  ///< which solver (above)
    LobpcgOptions lobpcg = {};                    ///< the LOBPCG path's tolerance, iteration cap, guard vectors and hierarchy
};

struct EigenResult {
    Eigen::VectorXd values;          ///< λ_0 ≤ λ_1 ≤ … (k of them)
    Eigen::MatrixXd vectors;         ///< N × k, column i = u_i, M-orthonormal, sign fixed (largest |entry| positive)
    Eigen::VectorXd residuals;       ///< ‖L u_i − λ_i M u_i‖ / (|λ_i| ‖M u_i‖)
    double orthonormalityError = 0;  ///< max |UᵀMU − I|
    int subspace = 0;                ///< the Lanczos basis size used
    long restarts = 0;               ///< Lanczos restarts
    long solves = 0;                 ///< applications of L⁻¹ (one CHOLMOD forward/back substitution each)
    double factorSeconds = 0, lanczosSeconds = 0;
    std::size_t factorBytes = 0;                    ///< CHOLMOD's peak memory during the factorisation
    double factorNonzeros = 0;                      ///< entries of the Cholesky factor (the fill: 8 bytes each)
    std::string ordering;                           ///< the fill-reducing ordering CHOLMOD chose (AMD, METIS, NESDIS, ...)
    double estimatedBytes = 0;                      ///< eigenBytes as estimated before the numeric factorisation (what maxBytes bounds)
    double matrixNonzeros = 0;                      ///< stored entries of L (the caller's matrix; 12 bytes each in double)
    EigenMethod method = EigenMethod::ShiftInvert;  ///< the solver that ran (Automatic resolved)
    long iterations = 0;                            ///< LOBPCG: iterations
    int multigridLevels = 0;                        ///< LOBPCG: levels of the preconditioner's hierarchy
    double multigridComplexity = 0;                 ///< LOBPCG: its operator complexity
    double lobpcgSeconds = 0;                       ///< LOBPCG: the whole solve, the multigrid's set-up included
};

/// Bytes the solve needs beyond L and M, estimated before the numeric factorisation: 12 per entry of the
/// Cholesky factor (its 8, and CHOLMOD's workspace: measured 1.4–1.5× the factor on bunny bands) plus
/// 8 N (2 ncv + k) for the Lanczos basis, its copy at each restart, and the vectors (within 6 % of the peaks
/// measured on bunny bands of 81 k – 321 k voxels, k = 20 and 200).
double eigenBytes(double factorNonzeros, double n, double subspace, double count);

/// The k lowest eigenpairs of L u = λ M u, M = diag(mass).
/// \param L         the Laplacian, N × N, symmetric positive definite (double CSR)
/// \param mass      M's diagonal, N entries (> 0)
/// \param options   k, the subspace, tolerance, restarts, method and the memory limit maxBytes
/// \param progress  reports the solver's progress; its interrupt stops it (Cancelled)
/// \return λ ascending, the M-orthonormal vectors (N × k) and the solve's figures
/// \throws ParameterError for k out of range, a mass that is not positive or a solve that would exceed
///         options.maxBytes (checked after CHOLMOD's symbolic analysis, before any large allocation); Error when L is
///         not positive definite or the solver does not converge within its restarts or iterations; Cancelled when
///         interrupted
/// \par Complexity
///   Shift-invert Lanczos: one sparse Cholesky factorisation (its fill sets time and memory, eigenBytes), then one
///   pair of triangular solves per Lanczos step. LOBPCG: O(k² N + k nnz(L)) per iteration and a multigrid cycle per
///   vector.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Deterministic (sequential CHOLMOD, a fixed start vector):
///   identical for any thread count.
EigenResult lowestEigenpairs(const SparseMatrixD& L, const Eigen::VectorXd& mass, const EigenOptions& options = {},
                             const Progress& progress = {});

}  // namespace gpisvdb
