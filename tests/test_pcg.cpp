#include <catch2/catch.hpp>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <tbb/global_control.h>

#include "allocation_counter.h"
#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/solve/pcg.h"

using namespace gpisvdb;

namespace {

Eigen::VectorXd asDouble(const std::vector<float>& v) {
    return Eigen::Map<const Eigen::VectorXf>(v.data(), long(v.size())).cast<double>();
}

/// L⁻¹ b by a sparse LDLᵀ of L assembled in double (the operator the matrix-free L applies), factorised once per
/// band (≈ 3 s on the torus band) and shared by the test cases that compare against it.
Eigen::VectorXd directSolve(const Band& band, const std::vector<float>& b) {
    static const Band* factored = nullptr;
    static Eigen::SimplicialLDLT<SparseMatrixD> ldlt;
    if (factored != &band) {
        ldlt.compute(assembleLaplacianDouble(band));
        REQUIRE(ldlt.info() == Eigen::Success);
        factored = &band;
    }
    return ldlt.solve(asDouble(b));
}

/// ‖b − L x‖ / ‖b‖ with L straight from the stencils (paper Eq. 24), all in double: the operator the matrix-free
/// L applies (the assembled one rounds its entries to float, which moves this residual by ~1e-6 here).
double stencilResidual(const Band& band, const std::vector<float>& x, const std::vector<float>& b) {
    std::vector<double> r(b.begin(), b.end());
    auto acc = band.index->getConstAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) {
        const VoxelStencil& st = band.stencil[i];
        for (int k = 0; k < st.count; ++k) {
            const double w = 0.5 * band.voxelSize * double(st.weight[k]);
            const openvdb::Coord e(st.offset[k][0], st.offset[k][1], st.offset[k][2]);
            for (const openvdb::Coord& y : {band.coord[i] + e, band.coord[i] - e}) {
                const int j = acc.getValue(y);
                const double d = w * ((j < 0 ? 0.0 : double(x[std::size_t(j)])) - double(x[i]));
                r[i] += d;  // r = b − L x: L x gains −d at i and +d at j
                if (j >= 0) r[std::size_t(j)] -= d;
            }
        }
    }
    double num = 0, den = 0;
    for (std::size_t i = 0; i < r.size(); ++i) num += r[i] * r[i], den += double(b[i]) * b[i];
    return std::sqrt(num / den);
}

}  // namespace

TEST_CASE("pcg: reaches the tolerance and agrees with a sparse Cholesky solve, matrix-free and assembled", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF A = assembleLaplacian(band);
    const LaplacianOperator L(band);
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 3] = float(band.mu[band.size() / 3]);
    const Eigen::SparseMatrix<double> Ad = A.cast<double>();
    const Eigen::VectorXd bd = asDouble(b);
    const Eigen::VectorXd exact = directSolve(band, b);
    // L is an M-matrix (positive stencil weights, rows leaving the band strictly dominant) and the torus band is
    // connected, so L⁻¹ > 0 entrywise: this Green's function is positive everywhere (its minimum is 1.4e-3 of its
    // maximum here).
    REQUIRE(exact.minCoeff() > 1e-4 * exact.maxCoeff());
    const AssembledOperator assembled(A);
    for (const SymmetricOperator* op : {static_cast<const SymmetricOperator*>(&L), static_cast<const SymmetricOperator*>(&assembled)}) {
        std::vector<float> x;
        const PcgResult r = solvePcg(*op, b, x, {1e-6, 20000});
        INFO(band.size() << " voxels, " << r.iterations << " iterations, residual " << r.relativeResidual);
        REQUIRE(r.converged);
        CHECK(r.relativeResidual <= 1e-6);
        // The true residual, recomputed in double, is at the tolerance too (float storage costs ~1e-7).
        const Eigen::VectorXd xd = asDouble(x);
        CHECK((bd - Ad * xd).norm() <= 1e-5 * bd.norm());
        // Against the direct solve: the residual's tolerance 1e-6, times twenty (measured 1.0e-6 matrix-free,
        // 1.2e-6 assembled).
        CHECK((xd - exact).norm() <= 2e-5 * exact.norm());
        // Positive at every voxel, like L⁻¹ (a PCG stopped early leaves zeros far from the source).
        CHECK(xd.minCoeff() > 0);
    }
}

TEST_CASE("pcg: incomplete Cholesky reaches the same solution in fewer iterations", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF A = assembleLaplacian(band);
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 2] = 1.0f;
    std::vector<float> xj, xi;
    PcgOptions o;
    const PcgResult rj = solvePcg(LaplacianOperator(band), b, xj, o);
    o.preconditioner = Preconditioner::IncompleteCholesky;
    const PcgResult ri = solvePcg(A, b, xi, o);
    REQUIRE(rj.converged);
    REQUIRE(ri.converged);
    CHECK(ri.iterations < rj.iterations);
    // Both against the direct solve, to the residual's tolerance 1e-6 times twenty (measured 1.3e-6 Jacobi,
    // 2.1e-6 IC), and positive at every voxel like L⁻¹ (see the first test case).
    const Eigen::VectorXd exact = directSolve(band, b);
    for (const std::vector<float>* x : {&xj, &xi}) {
        INFO((x == &xj ? "Jacobi" : "incomplete Cholesky"));
        const Eigen::VectorXd xd = asDouble(*x);
        CHECK((xd - exact).norm() <= 2e-5 * exact.norm());
        CHECK(xd.minCoeff() > 0);
    }
}

TEST_CASE("pcg: a solve allocates nothing of size N beyond the solver's work vectors", "[pcg]") {
    const Band& band = test::torusGapBand();
    const std::size_t n = band.size();
    const SparseMatrixF A = assembleLaplacian(band);
    const LaplacianOperator L(band);
    const AssembledOperator assembled(A);
    std::vector<float> b(n, 0.0f), x(n, 0.0f);
    b[n / 4] = 1.0f;
    struct Case {
        const char* name;
        const SymmetricOperator* op;
        Preconditioner pc;
    };
    for (const Case& c : {Case{"matrix-free, Jacobi", &L, Preconditioner::Jacobi},
                          Case{"assembled, Jacobi", &assembled, Preconditioner::Jacobi},
                          Case{"assembled, incomplete Cholesky", &assembled, Preconditioner::IncompleteCholesky}}) {
        INFO(c.name);
        PcgOptions o;
        o.preconditioner = c.pc;
        const PcgSolver solver(*c.op, o);  // work vectors and preconditioner: allocated here
        std::fill(x.begin(), x.end(), 0.0f);
        PcgResult r;
        std::size_t large = 0;
        {
            const test::CountLargeAllocations counter(n * sizeof(float) / 4);  // anything of a quarter of N floats
            r = solver.solve(b, x);
            large = counter.count();
        }
        CHECK(r.converged);
        CHECK(r.iterations > 10);
        CHECK(large == 0);
        // The work vectors themselves: four of N floats plus the preconditioner.
        CHECK(solver.memoryBytes() >= 4 * n * sizeof(float));
    }
}

TEST_CASE("pcg: identical iterates for 1 and 2 threads", "[pcg]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    std::vector<float> b(band.size(), 0.0f);
    for (std::size_t i = 0; i < b.size(); i += 97) b[i] = 1.0f;
    std::vector<float> x1, x2;
    PcgResult r1, r2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        r1 = solvePcg(L, b, x1);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        r2 = solvePcg(L, b, x2);
    }
    CHECK(r1.iterations == r2.iterations);
    CHECK(x1 == x2);
}

TEST_CASE("pcg: reports an unconverged solve at the iteration cap", "[pcg]") {
    const Band& band = test::torusGapBand();
    std::vector<float> b(band.size(), 1.0f), x;
    const PcgResult r = solvePcg(LaplacianOperator(band), b, x, {1e-6, 5});
    CHECK(!r.converged);
    CHECK(r.iterations == 5);
    // The reported residual is the true one, recomputed from the stencils: far from the tolerance after 5 iterations.
    const double truth = stencilResidual(band, x, b);
    CHECK(r.relativeResidual == Approx(truth).epsilon(0.05));
    CHECK(truth > 1e-2);
}

TEST_CASE("pcg: the reported residual is the true one, below float's reach the solve says it did not converge", "[pcg]") {
    // The recursively updated residual drifts below the true one in float storage; restarts from the true one
    // recover the tolerance where float can reach it (measured floor ≈ 4e-7 on this band).
    const Band& band = test::torusGapBand();
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 2] = 1.0f;
    for (double tol : {1e-5, 1e-6, 1e-9}) {
        std::vector<float> x;
        const PcgResult r = solvePcg(LaplacianOperator(band), b, x, {tol, 50000});
        const double truth = stencilResidual(band, x, b);
        INFO("tolerance " << tol << ": " << r.iterations << " iterations, " << r.restarts << " restarts, residual " << r.relativeResidual);
        CHECK(r.relativeResidual == Approx(truth).epsilon(0.05));
        CHECK(r.converged == (tol >= 1e-6));
        CHECK(r.converged == (r.relativeResidual <= tol));
        CHECK(r.iterations < 50000);  // stagnation ends the solve, not the cap
    }
}

TEST_CASE("pcg: a zero right-hand side gives zero, bad options and inputs are refused", "[pcg]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    std::vector<float> x(band.size(), 1.0f);
    const PcgResult r = solvePcg(L, std::vector<float>(band.size(), 0.0f), x);
    CHECK(r.converged);
    CHECK(std::all_of(x.begin(), x.end(), [](float v) { return v == 0.0f; }));  // every entry, not only the largest
    const std::vector<float> ones(band.size(), 1.0f);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {0.0, 10}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {-1.0, 10}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {std::nan(""), 10}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {1e-6, 0}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {1e-6, 10, Preconditioner::IncompleteCholesky}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, std::vector<float>(3, 1.0f), x), Error);
    std::vector<float> bad = ones;
    bad[7] = std::nanf("");
    CHECK_THROWS_AS(solvePcg(L, bad, x), Error);
}
