#include "gpisvdb/solve/pcg.h"

#include <Eigen/IterativeLinearSolvers>
#include <cmath>
#include <memory>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr std::size_t kGrain = 4096;

/// Σ a_i b_i in double; the deterministic reduction splits the same way for any thread count.
double dot(const std::vector<float>& a, const std::vector<float>& b) {
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, a.size(), kGrain), 0.0,
        [&](const tbb::blocked_range<std::size_t>& r, double s) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) s += double(a[i]) * double(b[i]);
            return s;
        },
        [](double x, double y) { return x + y; }, tbb::simple_partitioner());
}

template <class F>
void forEach(std::size_t n, const F& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
    });
}

}  // namespace

PcgResult solvePcg(const SparseMatrixF& A, const std::vector<float>& b, std::vector<float>& x, const PcgOptions& o,
                   const Progress& progress) {
    if (!(o.tolerance > 0)) throw ParameterError("--tolerance must be > 0");
    if (o.maxIterations < 1) throw ParameterError("the iteration cap must be >= 1");
    const std::size_t n = std::size_t(A.rows());
    if (b.size() != n) throw Error("solvePcg: right-hand side size does not match the matrix");
    if (x.size() != n) x.assign(n, 0.0f);
    // === Preconditioner: z = P⁻¹ r
    std::vector<float> invDiag(n);
    for (std::size_t i = 0; i < n; ++i) {
        const float d = A.coeff(int(i), int(i));
        invDiag[i] = d > 0 ? 1.0f / d : 1.0f;
    }
    using IC = Eigen::IncompleteCholesky<float, Eigen::Lower, Eigen::AMDOrdering<int>>;
    std::unique_ptr<IC> ic;
    if (o.preconditioner == Preconditioner::IncompleteCholesky) {
        ic = std::make_unique<IC>();
        ic->compute(Eigen::SparseMatrix<float, Eigen::ColMajor, int>(A));
        if (ic->info() != Eigen::Success) throw Error("the incomplete Cholesky factorisation failed");
    }
    std::vector<float> r(n), z(n), p(n), Ap(n);
    auto precondition = [&] {
        if (ic) {
            Eigen::Map<Eigen::VectorXf>(z.data(), long(n)) = ic->solve(Eigen::Map<const Eigen::VectorXf>(r.data(), long(n)));
        } else {
            forEach(n, [&](std::size_t i) { z[i] = invDiag[i] * r[i]; });
        }
    };
    multiply(A, x, Ap);
    forEach(n, [&](std::size_t i) { r[i] = b[i] - Ap[i]; });
    const double bNorm = std::sqrt(dot(b, b));
    PcgResult res;
    if (bNorm == 0) {
        x.assign(n, 0.0f);
        res.converged = true;
        return res;
    }
    precondition();
    p = z;
    double rz = dot(r, z);
    res.relativeResidual = std::sqrt(dot(r, r)) / bNorm;
    // === CG iterations
    while (res.relativeResidual > o.tolerance && res.iterations < o.maxIterations) {
        if (res.iterations % 16 == 0) progress.checkInterrupt();
        multiply(A, p, Ap);
        const double pAp = dot(p, Ap);
        if (!(pAp > 0)) throw Error("the operator is not positive definite (pᵀAp = " + std::to_string(pAp) + ")");
        const double alpha = rz / pAp;
        forEach(n, [&](std::size_t i) {
            x[i] = float(double(x[i]) + alpha * double(p[i]));
            r[i] = float(double(r[i]) - alpha * double(Ap[i]));
        });
        precondition();
        const double rzNext = dot(r, z);
        const double beta = rzNext / rz;
        rz = rzNext;
        forEach(n, [&](std::size_t i) { p[i] = float(double(z[i]) + beta * double(p[i])); });
        ++res.iterations;
        res.relativeResidual = std::sqrt(dot(r, r)) / bNorm;
    }
    res.converged = res.relativeResidual <= o.tolerance;
    return res;
}

}  // namespace gpisvdb
