#include "gpisvdb/solve/pcg.h"

#include <cmath>
#include <Eigen/IterativeLinearSolvers>
#include <limits>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "deterministic_dot.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/solve/boomer_amg.h"

namespace gpisvdb {

namespace {

constexpr std::size_t kGrain = 4096;
constexpr int kMaxRestarts = 8;  // restarts from the true residual before a solve is reported as stagnating
// Refinement: the inner solves' relative tolerance. Loose enough that float reaches it on every band measured
// (floors 2.6e-7 … 1.6e-6), tight enough that 1e-10 takes two or three outer steps; each step restarts the Krylov
// space, so fewer, longer inner solves cost fewer iterations in all (docs/operators.md#pcg, bench_solve).
constexpr double kInnerTolerance = 1e-5;
// An outer step that does not halve the residual has met double's own floor (or an inner solve that failed).
constexpr double kMinOuterGain = 0.5;
constexpr int kMaxRefinements = 30;

template <class T>
double dot(const T* a, const T* b, std::size_t n) {
    return detail::deterministicDot(a, b, n, kGrain);
}

template <class F>
void forEach(std::size_t n, const F& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
    });
}

using IncompleteFactor = Eigen::IncompleteCholesky<float, Eigen::Lower, Eigen::AMDOrdering<int>>;

}  // namespace

struct PcgSolver::Impl {
    const SymmetricOperator& A;
    PcgOptions options;
    std::size_t n;
    mutable std::vector<float> r, z, p, Ap;
    std::vector<float> invDiag;                         // Jacobi
    std::unique_ptr<IncompleteFactor> ic;               // IC
    std::vector<int> perm;                              // IC: (P r)_k = r[perm[k]]
    std::vector<float> scale;                           // IC: the factor's diagonal scaling S
    std::unique_ptr<BoomerAmg> amg;                     // Multigrid
    std::unique_ptr<AggregationMultigrid> aggregation;  // Aggregation
    // Refinement, allocated at the first refined solve and kept for the next ones
    mutable std::vector<double> residual;       // b − A x in double
    mutable std::vector<float> innerB, innerX;  // the correction's right-hand side r/‖r‖ and its solution
    mutable std::vector<double> wide;           // float API: x in double; double API: x rounded to float, widened

    Impl(const SymmetricOperator& op, const PcgOptions& o) : A(op), options(o), n(op.size()) {
        options.preconditioner = resolvePreconditioner(o.preconditioner, op);
        if (options.preconditioner == Preconditioner::IncompleteCholesky) {
            if (!A.assemblable()) throw ParameterError("the incomplete Cholesky preconditioner needs an operator that can be assembled");
            ic = std::make_unique<IncompleteFactor>();
            ic->compute(Eigen::SparseMatrix<float, Eigen::ColMajor, int>(A.matrix() ? *A.matrix() : A.assemble()));
            if (ic->info() != Eigen::Success) throw Error("the incomplete Cholesky factorisation failed");
            // Eigen's (P r)[P.indices()[i]] = r[i]; an empty P is the identity.
            const auto& P = ic->permutationP();
            perm.resize(n);
            for (std::size_t i = 0; i < n; ++i) perm[P.size() == long(n) ? std::size_t(P.indices()[long(i)]) : i] = int(i);
            scale.assign(ic->scalingS().data(), ic->scalingS().data() + n);
        } else if (options.preconditioner == Preconditioner::Multigrid) {
            if (!A.assemblable()) throw ParameterError("the multigrid preconditioner needs an operator that can be assembled");
            // hypre copies the entries: a matrix assembled here lives only through the set-up.
            amg = A.matrix() ? std::make_unique<BoomerAmg>(*A.matrix(), options.multigrid)
                             : std::make_unique<BoomerAmg>(A.assemble(), options.multigrid);
        } else if (options.preconditioner == Preconditioner::Aggregation) {
            const auto* L = dynamic_cast<const LaplacianOperator*>(&A);
            if (!L) throw ParameterError("the aggregation multigrid preconditioner needs the band's Laplacian (LaplacianOperator)");
            aggregation = std::make_unique<AggregationMultigrid>(*L, options.aggregation);
        } else {
            invDiag.resize(n);
            A.diagonal(invDiag.data());
            for (float& d : invDiag) d = d > 0 ? 1.0f / d : 1.0f;
        }
        // After the preconditioner: its set-up's temporaries and these vectors are not held at once.
        r.resize(n);
        z.resize(n);
        p.resize(n);
        Ap.resize(n);
    }

    /// z = P⁻¹ r. IC applies Eigen's factor by hand (permute, scale, two in-place triangular solves) so that it
    /// allocates nothing; Eigen's own solve() allocates an N-sized mask to permute in place.
    void precondition() const {
        if (amg) {
            amg->apply(r.data(), z.data());
            return;
        }
        if (aggregation) {
            aggregation->apply(r.data(), z.data());
            return;
        }
        if (!ic) {
            forEach(n, [&](std::size_t i) { z[i] = invDiag[i] * r[i]; });
            return;
        }
        for (std::size_t k = 0; k < n; ++k) Ap[k] = scale[k] * r[std::size_t(perm[k])];
        Eigen::Map<Eigen::VectorXf> y(Ap.data(), long(n));
        ic->matrixL().template triangularView<Eigen::Lower>().solveInPlace(y);
        ic->matrixL().adjoint().template triangularView<Eigen::Upper>().solveInPlace(y);
        for (std::size_t k = 0; k < n; ++k) z[std::size_t(perm[k])] = scale[k] * Ap[k];
    }

    /// The float PCG of the header on A x = b from x (‖b‖ = bNorm > 0) to `tolerance`, at most `maxIterations`.
    /// Progress reports log(scale · residual) / log(target): the refinement's inner solves run on r/‖r‖, and
    /// `scale` = ‖r‖/‖b‖ maps their residual to the whole solve's.
    PcgResult pcg(const float* b, float* x, double bNorm, double tolerance, int maxIterations, double scaleToCaller, double target,
                  const Progress& progress) const {
        PcgResult res;
        const bool flexible = aggregation && !aggregation->linear();
        // === r = b − A x, z = P⁻¹ r, p = z (also a restart, from the true residual)
        double rz = 0;
        auto restart = [&] {
            A.apply(x, Ap.data());
            forEach(n, [&](std::size_t i) { r[i] = float(double(b[i]) - double(Ap[i])); });
            precondition();
            std::copy(z.begin(), z.end(), p.begin());
            rz = dot(r.data(), z.data(), n);
            res.relativeResidual = std::sqrt(dot(r.data(), r.data(), n)) / bNorm;
        };
        restart();
        int restarts = 0;
        double lastTrue = std::numeric_limits<double>::infinity();
        for (;;) {
            // === CG iterations on the recursively updated residual
            while (res.relativeResidual > tolerance && res.iterations < maxIterations) {
                progress.checkInterrupt();  // every iteration: one flag load beside an O(n) operator
                if (res.iterations % 16 == 0) {
                    progress.update("solve", std::min(1.0, std::log(scaleToCaller * res.relativeResidual) / std::log(target)));
                }
                A.apply(p.data(), Ap.data());
                const double pAp = dot(p.data(), Ap.data(), n);
                if (!(pAp > 0)) throw Error("PCG: the operator is not positive definite (pᵀAp = " + std::to_string(pAp) + ")");
                const double alpha = rz / pAp;
                forEach(n, [&](std::size_t i) {
                    x[i] = float(double(x[i]) + alpha * double(p[i]));
                    r[i] = float(double(r[i]) - alpha * double(Ap[i]));
                });
                precondition();
                const double rzNext = dot(r.data(), z.data(), n);
                // Flexible CG (Notay 2000; Polak–Ribière) for a preconditioner that is not linear (the aggregation
                // K-cycle): β = z_{k+1}ᵀ(r_{k+1} − r_k) / r_kᵀz_k = −α z_{k+1}ᵀA p_k / r_kᵀz_k keeps p_{k+1}
                // A-orthogonal to p_k; for a fixed SPD preconditioner it equals the usual r_{k+1}ᵀz_{k+1} / r_kᵀz_k.
                // A p_k is still in Ap (the K-cycle does not use it as scratch, unlike IC).
                const double beta = flexible ? -alpha * dot(z.data(), Ap.data(), n) / rz : rzNext / rz;
                rz = rzNext;
                forEach(n, [&](std::size_t i) { p[i] = float(double(z[i]) + beta * double(p[i])); });
                ++res.iterations;
                res.relativeResidual = std::sqrt(dot(r.data(), r.data(), n)) / bNorm;
            }
            // === The true residual: in float the recursive one drifts below it (measured 4–8× on the bunny), so
            // restart from the true one while it misses the tolerance and the restarts still gain.
            restart();
            const bool met = res.relativeResidual <= tolerance;
            if (met || res.iterations >= maxIterations || ++restarts > kMaxRestarts || res.relativeResidual > 0.5 * lastTrue) break;
            lastTrue = res.relativeResidual;
        }
        res.converged = res.relativeResidual <= tolerance;
        res.restarts = restarts;
        res.floatResidual = res.relativeResidual;
        return res;
    }

    /// residual = b − A x in double; returns its norm.
    template <class B>
    double trueResidual(const B* b, const double* x) const {
        residual.resize(n);
        A.apply(x, residual.data());
        forEach(n, [&](std::size_t i) { residual[i] = double(b[i]) - residual[i]; });
        return std::sqrt(dot(residual.data(), residual.data(), n));
    }

    /// Mixed-precision iterative refinement of x (double) on A x = b until ‖b − A x‖ ≤ tolerance ‖b‖, adding to
    /// `res` (which may hold a plain solve's iterations already). Outer step: r = b − A x (double apply), then the
    /// float PCG on A d = r/‖r‖ to kInnerTolerance, then x += ‖r‖ d in double (docs/math.md#pcg).
    template <class B>
    void refine(const B* b, double bNorm, double* x, PcgResult& res, const Progress& progress) const {
        innerB.resize(n);
        innerX.resize(n);
        const double tolerance = options.tolerance;
        double rNorm = trueResidual(b, x);
        res.relativeResidual = rNorm / bNorm;
        while (res.relativeResidual > tolerance && res.iterations < options.maxIterations && res.refinements < kMaxRefinements &&
               rNorm > 0) {
            // The inner solve need not go further than the step that meets the tolerance (with a margin of 2
            // for the float operator's rounding, which the double residual does not share).
            const double innerTolerance = std::max(kInnerTolerance, 0.5 * tolerance / res.relativeResidual);
            forEach(n, [&](std::size_t i) {
                innerB[i] = float(residual[i] / rNorm);
                innerX[i] = 0.0f;
            });
            const double innerNorm = std::sqrt(dot(innerB.data(), innerB.data(), n));
            const PcgResult inner = pcg(innerB.data(), innerX.data(), innerNorm, innerTolerance, options.maxIterations - res.iterations,
                                        res.relativeResidual, tolerance, progress);
            res.iterations += inner.iterations;
            res.innerIterations += inner.iterations;
            res.restarts += inner.restarts;
            ++res.refinements;
            forEach(n, [&](std::size_t i) { x[i] += rNorm * double(innerX[i]); });
            const double last = res.relativeResidual;
            rNorm = trueResidual(b, x);
            res.relativeResidual = rNorm / bNorm;
            if (!(res.relativeResidual <= kMinOuterGain * last)) break;
        }
        res.converged = res.relativeResidual <= tolerance;
    }

    /// ‖b − A x̃‖ / ‖b‖ for x̃ = x rounded to float (x̃ already in `wide`, in double).
    template <class B>
    double floatResidualOf(const B* b, double bNorm) const {
        return trueResidual(b, wide.data()) / bNorm;
    }

    /// What ran, for the caller's report.
    PcgResult& stamp(PcgResult& res) const {
        res.preconditioner = options.preconditioner;
        if (amg) {
            res.multigridLevels = amg->levels();
            res.multigridComplexity = amg->operatorComplexity();
        }
        if (aggregation) {
            res.multigridLevels = aggregation->levels();
            res.multigridComplexity = aggregation->operatorComplexity();
        }
        return res;
    }

    bool refinesFromStart() const {
        return options.refinement == Refinement::Always ||
               (options.refinement == Refinement::Automatic && options.tolerance < kFloatPcgReach);
    }
};

const char* preconditionerName(Preconditioner p) {
    switch (p) {
        case Preconditioner::Automatic: return "automatic";
        case Preconditioner::Jacobi: return "Jacobi";
        case Preconditioner::IncompleteCholesky: return "incomplete Cholesky";
        case Preconditioner::Multigrid: return "multigrid";
        case Preconditioner::Aggregation: return "aggregation";
    }
    return "?";
}

const std::vector<std::pair<std::string, Preconditioner>>& preconditionerChoices() {
    static const std::vector<std::pair<std::string, Preconditioner>> kChoices = {{"auto", Preconditioner::Automatic},
                                                                                 {"aggregation", Preconditioner::Aggregation},
                                                                                 {"multigrid", Preconditioner::Multigrid},
                                                                                 {"jacobi", Preconditioner::Jacobi},
                                                                                 {"ic", Preconditioner::IncompleteCholesky}};
    return kChoices;
}

Preconditioner resolvePreconditioner(Preconditioner requested, std::size_t unknowns, bool assemblable, bool bandLaplacian) {
    if (requested != Preconditioner::Automatic) return requested;
    if (unknowns < kMultigridMinUnknowns) return Preconditioner::Jacobi;
    // On the band Laplacian the aggregation multigrid is both faster and ≈ 9× lighter than hypre's
    // (docs/operators.md#aggregation).
    if (bandLaplacian) return Preconditioner::Aggregation;
    return assemblable ? Preconditioner::Multigrid : Preconditioner::Jacobi;
}

Preconditioner resolvePreconditioner(Preconditioner requested, const SymmetricOperator& A) {
    return resolvePreconditioner(requested, A.size(), A.assemblable(), dynamic_cast<const LaplacianOperator*>(&A) != nullptr);
}

void checkPcgOptions(const PcgOptions& o) {
    if (!(o.tolerance > 0) || !std::isfinite(o.tolerance))
        throw ParameterError("the PCG tolerance (PcgOptions::tolerance) must be finite and > 0 (a relative residual, e.g. 1e-6)",
                             {"PcgOptions::tolerance"});
    if (o.tolerance < kMinPcgTolerance)
        throw ParameterError("the PCG tolerance (PcgOptions::tolerance) must be >= " + numberText(kMinPcgTolerance) +
                                 ", near what double precision resolves of b - A x",
                             {"PcgOptions::tolerance"});
    if (o.maxIterations < 1)
        throw ParameterError("the PCG iteration cap (PcgOptions::maxIterations) must be >= 1", {"PcgOptions::maxIterations"});
}

PcgSolver::PcgSolver(const SymmetricOperator& A, const PcgOptions& o) {
    checkPcgOptions(o);
    impl_ = std::make_unique<Impl>(A, o);
}

PcgSolver::~PcgSolver() = default;

std::size_t PcgSolver::memoryBytes() const {
    const Impl& m = *impl_;
    std::size_t bytes = (m.r.capacity() + m.z.capacity() + m.p.capacity() + m.Ap.capacity() + m.invDiag.capacity() + m.scale.capacity() +
                         m.innerB.capacity() + m.innerX.capacity()) *
                            sizeof(float) +
                        (m.residual.capacity() + m.wide.capacity()) * sizeof(double) + m.perm.capacity() * sizeof(int);
    if (m.ic) bytes += std::size_t(m.ic->matrixL().nonZeros()) * (sizeof(float) + sizeof(int)) + (m.n + 1) * sizeof(int);
    if (m.amg) bytes += m.amg->memoryBytes();
    if (m.aggregation) bytes += m.aggregation->memoryBytes();
    return bytes;
}

Preconditioner PcgSolver::preconditioner() const { return impl_->options.preconditioner; }

const BoomerAmg* PcgSolver::multigrid() const { return impl_->amg.get(); }

const AggregationMultigrid* PcgSolver::aggregation() const { return impl_->aggregation.get(); }

PcgResult PcgSolver::solve(const std::vector<float>& b, std::vector<float>& x, const Progress& progress) const {
    const Impl& m = *impl_;
    const std::size_t n = m.n;
    if (b.size() != n) throw Error("PCG: the right-hand side's length does not match the operator");
    if (x.size() != n) x.assign(n, 0.0f);
    const double bNorm = std::sqrt(dot(b.data(), b.data(), n));
    if (!std::isfinite(bNorm)) throw Error("PCG: the right-hand side is not finite");
    if (bNorm == 0) {
        std::fill(x.begin(), x.end(), 0.0f);
        PcgResult res;
        res.converged = true;
        return m.stamp(res);
    }
    PcgResult res;
    if (!m.refinesFromStart()) {
        // === The float PCG alone: where it reaches the tolerance (or the cap), its result as it always was
        res = m.pcg(b.data(), x.data(), bNorm, m.options.tolerance, m.options.maxIterations, 1.0, m.options.tolerance, progress);
        if (res.converged || m.options.refinement == Refinement::Off || res.iterations >= m.options.maxIterations) {
            progress.update("solve", 1.0);
            return m.stamp(res);
        }
    }
    // === Stalled above the tolerance, or asked below float's reach: refine in double from x
    m.wide.resize(n);
    forEach(n, [&](std::size_t i) { m.wide[i] = double(x[i]); });
    m.refine(b.data(), bNorm, m.wide.data(), res, progress);
    forEach(n, [&](std::size_t i) {
        x[i] = float(m.wide[i]);
        m.wide[i] = double(x[i]);
    });
    res.floatResidual = m.floatResidualOf(b.data(), bNorm);
    progress.update("solve", 1.0);
    return m.stamp(res);
}

PcgResult PcgSolver::solve(const std::vector<double>& b, std::vector<double>& x, const Progress& progress) const {
    const Impl& m = *impl_;
    const std::size_t n = m.n;
    if (b.size() != n) throw Error("PCG: the right-hand side's length does not match the operator");
    if (x.size() != n) x.assign(n, 0.0);
    const double bNorm = std::sqrt(dot(b.data(), b.data(), n));
    if (!std::isfinite(bNorm)) throw Error("PCG: the right-hand side is not finite");
    PcgResult res;
    if (bNorm == 0) {
        std::fill(x.begin(), x.end(), 0.0);
        res.converged = true;
        return m.stamp(res);
    }
    if (m.options.refinement == Refinement::Off) {
        // The float PCG alone, on b and x rounded to float (in the refinement's float buffers)
        m.innerB.resize(n);
        m.innerX.resize(n);
        forEach(n, [&](std::size_t i) {
            m.innerB[i] = float(b[i]);
            m.innerX[i] = float(x[i]);
        });
        const double fNorm = std::sqrt(dot(m.innerB.data(), m.innerB.data(), n));
        res = m.pcg(m.innerB.data(), m.innerX.data(), fNorm, m.options.tolerance, m.options.maxIterations, 1.0, m.options.tolerance,
                    progress);
        forEach(n, [&](std::size_t i) { x[i] = double(m.innerX[i]); });
    } else {
        m.refine(b.data(), bNorm, x.data(), res, progress);
    }
    m.wide.resize(n);
    forEach(n, [&](std::size_t i) { m.wide[i] = double(float(x[i])); });
    res.floatResidual = m.floatResidualOf(b.data(), bNorm);
    if (m.options.refinement == Refinement::Off) {
        // Against the double b: what this solve promises its caller
        res.relativeResidual = res.floatResidual;
        res.converged = res.relativeResidual <= m.options.tolerance;
    }
    progress.update("solve", 1.0);
    return m.stamp(res);
}

PcgResult solvePcg(const SymmetricOperator& A, const std::vector<float>& b, std::vector<float>& x, const PcgOptions& o,
                   const Progress& progress) {
    return PcgSolver(A, o).solve(b, x, progress);
}

PcgResult solvePcg(const SymmetricOperator& A, const std::vector<double>& b, std::vector<double>& x, const PcgOptions& o,
                   const Progress& progress) {
    return PcgSolver(A, o).solve(b, x, progress);
}

PcgResult solvePcg(const SparseMatrixF& A, const std::vector<float>& b, std::vector<float>& x, const PcgOptions& o,
                   const Progress& progress) {
    return solvePcg(AssembledOperator(A), b, x, o, progress);
}

double pcgWorkBytes(std::size_t n, const PcgOptions& options, bool includeFallback) {
    const double floats = 5.0 * 4.0 * double(n);
    const bool refines = options.refinement == Refinement::Always ||
                         (options.refinement == Refinement::Automatic && (options.tolerance < kFloatPcgReach || includeFallback));
    return floats + (refines ? 24.0 * double(n) : 0.0);
}

// Measured: the green stage's peak with --preconditioner ic over its baseline, less the operator, the PCG and the
// right-hand side counted above, 565–572 bytes per voxel on the bunny (σ_rel 2, h 0.25; σ_rel 1, h 0.1 and 0.07:
// 20 k, 167 k and 486 k voxels; docs/memory.md#incomplete-cholesky).
const double kIncompleteCholeskyBytesPerVoxel = 570;

double incompleteCholeskyBytes(std::size_t n) { return kIncompleteCholeskyBytesPerVoxel * double(n); }

}  // namespace gpisvdb
