#pragma once
// Preconditioned conjugate gradients for a symmetric positive definite operator (docs/math.md#pcg): float storage,
// double reductions, working in place on the caller's arrays. The solver allocates its work vectors once
// (r, z, p, A p and the preconditioner: 5 floats per unknown for Jacobi, plus the incomplete factor for IC or the
// multigrid hierarchy; their set-ups do not poll for cancellation: the CLI's watchdog covers them), so
// repeated solves — and every iteration — allocate nothing of size N. Iterates until the recursively updated
// residual satisfies ‖r‖ ≤ tolerance·‖b‖, then checks the true residual b − A x: in float storage the two drift
// apart, so while the true one misses the tolerance the iteration restarts from it (at most 8 times, and only while
// each restart halves it). Stops there or after maxIterations. Deterministic for any thread count.
//
// Below what float storage reaches (2.6e-7 … 1.6e-6 relative, measured: docs/operators.md#pcg) the solver switches to
// mixed-precision iterative refinement (docs/math.md#pcg): the solution x and the residual r = b − A x are held and
// computed in double (the operator's double apply: the same float weights, nothing rounded), and each outer step
// solves the correction A d = r by the float PCG above to a loose relative tolerance (1e-5), then x += d in double.
// Each step shrinks the residual by about that factor, so 1e-10 takes 2–3 steps: ×1.8–1.9 the iterations of a float
// solve to 1e-6 on the bunny (docs/benchmarks.md#pcg-tolerances). Extra memory, allocated at the first refined solve and kept: 16 bytes per
// unknown (r in double, the correction's right-hand side and solution in float), plus 8 for x in double when the caller hands it in float.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/ops/linear_operator.h"
#include "gpisvdb/solve/aggregation_multigrid.h"
#include "gpisvdb/solve/boomer_amg.h"

namespace gpisvdb {

enum class Preconditioner {
    Automatic,           ///< from kMultigridMinUnknowns unknowns: Aggregation for the band Laplacian, Multigrid
                         ///< for another assemblable operator; Jacobi below or otherwise
    Jacobi,              ///< diag(A)⁻¹: parallel, no set-up, works matrix-free
    IncompleteCholesky,  ///< Eigen's IC(0) with AMD ordering and diagonal shift on the assembled matrix: fewer
                         ///< iterations, serial set-up and triangular solves
    Multigrid,           ///< one V-cycle of hypre's BoomerAMG (solve/boomer_amg.h) on the operator's matrix
                         ///< (assembled for the set-up and then freed): iterations nearly flat in N; serial
                         ///< set-up and cycles; ≈ 300 B per unknown more than Jacobi
    Aggregation,         ///< one K-cycle of the aggregation multigrid (solve/aggregation_multigrid.h) on the band
                         ///< Laplacian (LaplacianOperator only): float, parallel, ≈ 35–55 B per unknown; the PCG
                         ///< then uses the flexible β (the K-cycle is not linear)
};

/// Below this many unknowns Jacobi reaches 1e-6 sooner than hypre's set-up and cycles (measured on bunny bands:
/// docs/operators.md#multigrid). The aggregation multigrid is sooner from ≈ 4e4 voxels; the switch was kept where
/// it was, where both multigrids win.
constexpr std::size_t kMultigridMinUnknowns = 100000;

/// The preconditioner Automatic resolves to for an operator of `unknowns` unknowns that can or cannot be assembled
/// and is or is not the band's LaplacianOperator (the others resolve to themselves): known before the operator is
/// built, for memory estimates.
Preconditioner resolvePreconditioner(Preconditioner requested, std::size_t unknowns, bool assemblable, bool bandLaplacian = false);
/// The same for this operator.
Preconditioner resolvePreconditioner(Preconditioner requested, const SymmetricOperator& A);

/// Smallest tolerance accepted: met on every band measured (4.8e-13 on the bunny bands); below it double's own
/// rounding of b − A x (≈ 1e-16 · ‖A‖ ‖x‖ / ‖b‖) comes within reach of the tolerance.
constexpr double kMinPcgTolerance = 1e-12;
/// Tolerances from here up are first tried by the float PCG alone (its floor was measured at 2.6e-7 … 1.6e-6 on
/// real bands; a stall above the tolerance still falls back to refinement); tighter ones are refined from the start.
constexpr double kFloatPcgReach = 1e-6;

enum class Refinement {
    Automatic,  ///< float PCG when tolerance ≥ kFloatPcgReach, refinement below it or when the float PCG stalls
    Off,        ///< float PCG only: stops near float's floor (converged = false below it)
    Always,     ///< refinement from the first step
};

struct PcgOptions {
    double tolerance = 1e-6;    ///< relative residual ‖b − A x‖ / ‖b‖ to reach (≥ kMinPcgTolerance = 1e-12)
    int maxIterations = 10000;  ///< cap on all PCG iterations of a solve, the refinement's inner ones included (≥ 1)
    Preconditioner preconditioner = Preconditioner::Automatic;  ///< measured choice (docs/operators.md#multigrid)
    Refinement refinement = Refinement::Automatic;              ///< when to refine in double (above)
    BoomerAmgOptions multigrid = {};                            ///< the hierarchy, when preconditioner is Multigrid
    AggregationOptions aggregation = {};                        ///< the hierarchy, when preconditioner is Aggregation
};

struct PcgResult {
    int iterations = 0;  ///< all PCG iterations (float), the refinement's inner ones included
    /// True relative residual ‖b − A x‖ / ‖b‖ at exit (reductions in double). Plain float PCG: of the float x, with
    /// the float apply. Refined: of the solution in double, with the double apply.
    double relativeResidual = 0;
    int restarts = 0;         ///< restarts from the true residual (the inner solves' included)
    int refinements = 0;      ///< outer steps of iterative refinement (0: the float PCG alone)
    int innerIterations = 0;  ///< PCG iterations spent in the refinement's inner solves (≤ iterations)
    /// ‖b − A x̃‖ / ‖b‖ in double for x̃ the solution rounded to float (what a float grid holds): float's rounding
    /// of x alone leaves ≈ 1e-8 … 1e-6 here when refined. Equal to relativeResidual on the plain float path.
    double floatResidual = 0;
    bool converged = false;                                  ///< relativeResidual ≤ tolerance
    Preconditioner preconditioner = Preconditioner::Jacobi;  ///< the one used (Automatic resolved)
    int multigridLevels = 0;                                 ///< Multigrid, Aggregation: levels of the hierarchy (0 otherwise)
    double multigridComplexity = 0;  ///< Multigrid, Aggregation: Σ entries of all levels / entries of A (0 otherwise)
};

/// "Jacobi", "incomplete Cholesky", "multigrid", "aggregation" or "automatic" (for reports and messages).
const char* preconditionerName(Preconditioner p);
/// The preconditioners by the names users choose them with (the command line's --preconditioner, Python's
/// `preconditioner`): auto, aggregation, multigrid, jacobi, ic.
const std::vector<std::pair<std::string, Preconditioner>>& preconditionerChoices();

/// Throws ParameterError (naming PcgOptions::tolerance or ::maxIterations) for a tolerance outside
/// [kMinPcgTolerance, ∞) or an iteration cap < 1: PcgSolver's own check, for front ends to make before the band.
void checkPcgOptions(const PcgOptions& options);

/// A PCG bound to one operator: the preconditioner is set up and the work vectors allocated at construction.
/// The operator must outlive the solver. One solve at a time per object.
class PcgSolver {
public:
    /// Throws ParameterError for bad options, or for IC or Multigrid on an operator that cannot be assembled.
    explicit PcgSolver(const SymmetricOperator& A, const PcgOptions& options = {});
    ~PcgSolver();
    /// Solves A x = b; x holds the initial guess on entry (resized to N and zeroed if it has another length).
    /// Refines in double when the options ask for it (PcgOptions::refinement) and rounds the result to float.
    PcgResult solve(const std::vector<float>& b, std::vector<float>& x, const Progress& progress = {}) const;
    /// The same with b and x in double: the solution of a refined solve as computed, not rounded to float. Refines
    /// unless PcgOptions::refinement is Off (then b and x are rounded to float for a plain solve and widened back).
    PcgResult solve(const std::vector<double>& b, std::vector<double>& x, const Progress& progress = {}) const;
    /// Bytes held by the work vectors and the preconditioner (and the refinement's, once a solve has refined).
    std::size_t memoryBytes() const;
    /// The preconditioner in use (Automatic resolved).
    Preconditioner preconditioner() const;
    /// The multigrid hierarchy (levels, complexity) when the preconditioner is Multigrid, else nullptr.
    const BoomerAmg* multigrid() const;
    /// The aggregation hierarchy when the preconditioner is Aggregation, else nullptr.
    const AggregationMultigrid* aggregation() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// One solve of A x = b: PcgSolver(A, options).solve(b, x, progress).
/// \param A         a symmetric positive definite operator of n unknowns (a LaplacianOperator, an AssembledOperator, …)
/// \param b         the right-hand side, n entries
/// \param x         the initial guess on entry (resized to n and zeroed if it has another length), the solution on
///                  return
/// \param options   tolerance, iteration cap, preconditioner (Automatic: the measured choice by n), refinement
/// \param progress  reports the iterations; its interrupt stops the solve (Cancelled)
/// \return the iterations, the true relative residual at exit and whether it met the tolerance (a solve short of
///         it is returned, not thrown: the caller decides)
/// \throws ParameterError for bad options (checkPcgOptions) or a preconditioner the operator cannot take; Error for
///         a b of another length or not finite, an operator not positive definite on b's Krylov space, or a failed
///         incomplete Cholesky; Cancelled when interrupted
/// \par Complexity
///   One product with A (O(nnz(A))) and one preconditioner application per iteration; memory pcgWorkBytes(n, options)
///   and the preconditioner's own.
/// \par Thread safety
///   Reads A and b only: concurrent calls are safe. Parallel inside (TBB, reductions in a fixed order); the result is
///   the same for any thread count.
PcgResult solvePcg(const SymmetricOperator& A, const std::vector<float>& b, std::vector<float>& x, const PcgOptions& options = {},
                   const Progress& progress = {});
/// One solve in double: PcgSolver(A, options).solve(b, x, progress).
/// \param A         a symmetric positive definite operator of n unknowns
/// \param b         the right-hand side, n entries
/// \param x         the initial guess on entry (resized to n and zeroed if it has another length), the solution on
///                  return
/// \param options   tolerance, iteration cap, preconditioner (Automatic: the measured choice by n), refinement
/// \param progress  reports the iterations; its interrupt stops the solve (Cancelled)
/// \return the iterations, the true relative residual at exit and whether it met the tolerance (a solve short of
///         it is returned, not thrown: the caller decides)
/// \throws ParameterError for bad options (checkPcgOptions) or a preconditioner the operator cannot take; Error for
///         a b of another length or not finite, an operator not positive definite on b's Krylov space, or a failed
///         incomplete Cholesky; Cancelled when interrupted
/// \par Complexity
///   One product with A (O(nnz(A))) and one preconditioner application per iteration; memory pcgWorkBytes(n, options)
///   and the preconditioner's own.
/// \par Thread safety
///   Reads A and b only: concurrent calls are safe. Parallel inside (TBB, reductions in a fixed order); the result is
///   the same for any thread count.
PcgResult solvePcg(const SymmetricOperator& A, const std::vector<double>& b, std::vector<double>& x, const PcgOptions& options = {},
                   const Progress& progress = {});
/// Same, on an assembled matrix.
/// \param A         a symmetric positive definite matrix, n × n (float CSR)
/// \param b         the right-hand side, n entries
/// \param x         the initial guess on entry (resized to n and zeroed if it has another length), the solution on
///                  return
/// \param options   tolerance, iteration cap, preconditioner (Automatic: the measured choice by n), refinement
/// \param progress  reports the iterations; its interrupt stops the solve (Cancelled)
/// \return the iterations, the true relative residual at exit and whether it met the tolerance (a solve short of
///         it is returned, not thrown: the caller decides)
/// \throws ParameterError for bad options (checkPcgOptions) or a preconditioner the operator cannot take; Error for
///         a b of another length or not finite, an operator not positive definite on b's Krylov space, or a failed
///         incomplete Cholesky; Cancelled when interrupted
/// \par Complexity
///   One product with A (O(nnz(A))) and one preconditioner application per iteration; memory pcgWorkBytes(n, options)
///   and the preconditioner's own.
/// \par Thread safety
///   Reads A and b only: concurrent calls are safe. Parallel inside (TBB, reductions in a fixed order); the result is
///   the same for any thread count.
PcgResult solvePcg(const SparseMatrixF& A, const std::vector<float>& b, std::vector<float>& x, const PcgOptions& options = {},
                   const Progress& progress = {});

/// Bytes a PcgSolver allocates for n unknowns with these options, Jacobi preconditioned: r, z, p,
/// A p and the inverse diagonal in float (20 B per unknown), plus the refinement's residual in double, its inner
/// right-hand side and solution in float and the solution in double (24 B) when the tolerance is below what
/// float reaches (kFloatPcgReach) or refinement is Always. With Refinement::Automatic above kFloatPcgReach a float
/// solve that stalls refines too, and then allocates those 24 B after all: not counted, since it is the exception
/// (`includeFallback` counts it). Other preconditioners' own memory (IC's factor, a multigrid hierarchy) is not
/// counted here.
double pcgWorkBytes(std::size_t n, const PcgOptions& options, bool includeFallback = false);

/// Peak bytes the incomplete Cholesky preconditioner adds for n unknowns of the band Laplacian while
/// it is set up and kept: the assembled L (float CSR), Eigen's column-major copy, its permuted lower triangle,
/// AMD ordering and column lists, and the factor; measured per voxel on bunny bands
/// (kIncompleteCholeskyBytesPerVoxel, docs/memory.md#incomplete-cholesky).
double incompleteCholeskyBytes(std::size_t n);

/// The incomplete Cholesky's peak per unknown (above), measured.
extern const double kIncompleteCholeskyBytesPerVoxel;

}  // namespace gpisvdb
