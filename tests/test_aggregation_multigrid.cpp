#include <catch2/catch.hpp>
#include <cmath>
#include <Eigen/SparseCholesky>
#include <random>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/solve/aggregation_multigrid.h"
#include "gpisvdb/solve/pcg.h"

using namespace gpisvdb;

namespace {

std::vector<float> randomVector(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<float> v(n);
    for (float& x : v) x = u(rng);
    return v;
}

double dot(const std::vector<float>& a, const std::vector<float>& b) {
    double s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) s += double(a[i]) * double(b[i]);
    return s;
}

/// A unit source at a voxel a third of the way through the band (a Green's function right-hand side).
std::vector<float> unitSource(const Band& band) {
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 3] = 1.0f;
    return b;
}

PcgOptions aggregationOptions(double tolerance) {
    PcgOptions o;
    o.tolerance = tolerance;
    o.maxIterations = 50000;
    o.preconditioner = Preconditioner::Aggregation;
    return o;
}

}  // namespace

TEST_CASE("aggregation multigrid: every coarse operator is Galerkin's Pᵀ A P", "[aggregation]") {
    // Independent of the set-up's edge sums: Pᵀ A P u_c formed by prolonging u_c (copies over each aggregate),
    // applying the finer operator and restricting (sums over each aggregate).
    for (const Band* band : {&test::torusGapBand(), &test::sphereBand()}) {
        const LaplacianOperator L(*band);
        const AggregationMultigrid mg(L);
        REQUIRE(mg.levels() >= 3);
        for (int level = 1; level < mg.levels(); ++level) {
            const std::size_t m = mg.coarseUnknowns(level);
            const std::vector<std::int32_t> parent = mg.aggregateOf(level);
            const std::vector<float> uc = randomVector(m, 7u + unsigned(level));
            std::vector<float> u(parent.size()), Au(parent.size());
            for (std::size_t i = 0; i < u.size(); ++i) u[i] = uc[std::size_t(parent[i])];
            if (level == 1) L.apply(u.data(), Au.data());
            else mg.applyCoarse(level - 1, u.data(), Au.data());
            std::vector<double> galerkin(m, 0.0);
            for (std::size_t i = 0; i < u.size(); ++i) galerkin[std::size_t(parent[i])] += double(Au[i]);
            std::vector<float> Ac(m);
            mg.applyCoarse(level, uc.data(), Ac.data());
            double err = 0, norm = 0;
            for (std::size_t k = 0; k < m; ++k) {
                err = std::max(err, std::abs(double(Ac[k]) - galerkin[k]));
                norm = std::max(norm, std::abs(galerkin[k]));
            }
            INFO("level " << level << " of " << mg.levels() << ", " << m << " nodes");
            CHECK(m < parent.size());
            CHECK(err <= 2e-5 * norm);
        }
    }
}

TEST_CASE("aggregation multigrid: the V-cycle is a symmetric positive definite operator, the K-cycle positive", "[aggregation]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    AggregationOptions vCycle;
    vCycle.kCycle = false;
    const AggregationMultigrid mg(L, vCycle);
    CHECK(mg.linear());
    const std::vector<float> r1 = randomVector(band.size(), 1), r2 = randomVector(band.size(), 2);
    std::vector<float> z1(band.size()), z2(band.size());
    mg.apply(r1.data(), z1.data());
    mg.apply(r2.data(), z2.data());
    // r2ᵀ B r1 = r1ᵀ B r2 up to float rounding of the cycle, and rᵀ B r > 0
    CHECK(dot(r2, z1) == Approx(dot(r1, z2)).epsilon(1e-4));
    CHECK(dot(r1, z1) > 0);
    CHECK(dot(r2, z2) > 0);
    // The K-cycle's coarse levels take flexible-CG steps: not linear (the PCG switches to the flexible β), but
    // still a descent direction for any residual.
    const AggregationMultigrid k(L);
    CHECK_FALSE(k.linear());
    k.apply(r1.data(), z1.data());
    CHECK(dot(r1, z1) > 0);
}

TEST_CASE("aggregation multigrid: PCG reaches the direct solution with a fraction of Jacobi's iterations", "[aggregation]") {
    const Band& band = test::torusGapBand();
    const std::vector<float> b = unitSource(band);
    Eigen::SimplicialLDLT<SparseMatrixD> ldlt(assembleLaplacianDouble(band));
    REQUIRE(ldlt.info() == Eigen::Success);
    const Eigen::VectorXd exact = ldlt.solve(Eigen::Map<const Eigen::VectorXf>(b.data(), long(b.size())).cast<double>());
    const LaplacianOperator L(band);
    std::vector<float> x, xj;
    const PcgSolver solver(L, aggregationOptions(1e-6));
    REQUIRE(solver.preconditioner() == Preconditioner::Aggregation);
    const PcgResult r = solver.solve(b, x);
    PcgOptions jacobi = aggregationOptions(1e-6);
    jacobi.preconditioner = Preconditioner::Jacobi;
    const PcgResult rj = solvePcg(L, b, xj, jacobi);
    INFO(band.size() << " voxels: aggregation " << r.iterations << " iterations (" << r.multigridLevels << " levels), Jacobi "
                     << rj.iterations);
    REQUIRE(r.converged);
    REQUIRE(rj.converged);
    CHECK(8 * r.iterations <= rj.iterations);
    const Eigen::VectorXd xd = Eigen::Map<const Eigen::VectorXf>(x.data(), long(x.size())).cast<double>();
    CHECK((xd - exact).norm() <= 2e-5 * exact.norm());
    CHECK(r.multigridLevels >= 3);
    CHECK(r.multigridComplexity > 1.0);
    CHECK(r.multigridComplexity < 2.0);
    // Beyond the PCG's four work vectors: the finest level's inverse diagonal and residual, and the coarse levels.
    CHECK(solver.memoryBytes() >= 6 * 4 * band.size());
}

TEST_CASE("aggregation multigrid: the K-cycle with flexible CG needs no more iterations than the V-cycle", "[aggregation]") {
    // The K-cycle is not linear: with the plain CG β its directions lose A-orthogonality and it would need more
    // iterations than the V-cycle it refines, not fewer (flexible CG's β keeps p_{k+1} A-orthogonal to p_k).
    for (const Band* band : {&test::torusGapBand(), &test::sphereBand()}) {
        const LaplacianOperator L(*band);
        const std::vector<float> b = unitSource(*band);
        PcgOptions v = aggregationOptions(1e-6), k = aggregationOptions(1e-6);
        v.aggregation.kCycle = false;
        std::vector<float> xv, xk;
        const PcgResult rv = solvePcg(L, b, xv, v), rk = solvePcg(L, b, xk, k);
        INFO(band->size() << " voxels: V-cycle " << rv.iterations << " iterations, K-cycle " << rk.iterations << " (" << rk.restarts
                          << " restarts)");
        REQUIRE(rv.converged);
        REQUIRE(rk.converged);
        CHECK(rk.iterations <= rv.iterations);
        CHECK(rk.restarts <= 1);
    }
}

TEST_CASE("aggregation multigrid: iterations stay nearly flat on nested bands", "[aggregation]") {
    // A torus band at h, h/2 and h/4 (each about 4× the voxels of the last). Issue 18 asks for ≤ 1.5× iterations
    // per 8× voxels; the growth per 8× is (iterations ratio)^(log 8 / log(voxel ratio)).
    const TriangleSoup ring = torus(48, 16);
    std::vector<std::size_t> voxels;
    std::vector<int> iterations;
    for (const double h : {0.12, 0.06, 0.03}) {
        const Band band = test::bandOf(ring, 1.0, h);
        std::vector<float> x;
        const PcgResult r = solvePcg(LaplacianOperator(band), unitSource(band), x, aggregationOptions(1e-6));
        REQUIRE(r.converged);
        voxels.push_back(band.size());
        iterations.push_back(r.iterations);
        UNSCOPED_INFO("h " << h << ": " << band.size() << " voxels, " << r.iterations << " iterations, " << r.multigridLevels << " levels");
    }
    for (std::size_t k = 1; k < voxels.size(); ++k) {
        const double exponent = std::log(8.0) / std::log(double(voxels[k]) / double(voxels[k - 1]));
        CHECK(double(voxels[k]) > 2.5 * double(voxels[k - 1]));
        CHECK(std::pow(double(iterations[k]) / double(iterations[k - 1]), exponent) <= 1.5);
    }
}

TEST_CASE("aggregation multigrid: solves are identical for 1 and 2 threads, and reach 1e-10 by refinement", "[aggregation]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    const std::vector<float> b = unitSource(band);
    std::vector<float> x1, x2;
    PcgResult r1, r2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        r1 = solvePcg(L, b, x1, aggregationOptions(1e-6));
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        r2 = solvePcg(L, b, x2, aggregationOptions(1e-6));
    }
    CHECK(r1.iterations == r2.iterations);
    CHECK(x1 == x2);
    std::vector<double> bd(b.begin(), b.end()), x;
    const PcgResult r = solvePcg(L, bd, x, aggregationOptions(1e-10));
    INFO(r.iterations << " iterations in " << r.refinements << " refinements, residual " << r.relativeResidual);
    CHECK(r.converged);
    CHECK(r.relativeResidual <= 1e-10);
}

TEST_CASE("aggregation multigrid: the set-up's transposition in ranges gives the same hierarchy", "[aggregation]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    AggregationOptions ranges;
    ranges.transposeChunkEntries = 1000;  // about a hundred ranges on this band
    const AggregationMultigrid whole(L), chunked(L, ranges);
    REQUIRE(whole.levels() == chunked.levels());
    CHECK(whole.operatorComplexity() == chunked.operatorComplexity());
    const std::vector<float> r = randomVector(band.size(), 5);
    std::vector<float> z1(band.size()), z2(band.size());
    whole.apply(r.data(), z1.data());
    chunked.apply(r.data(), z2.data());
    CHECK(z1 == z2);
}

TEST_CASE("aggregation multigrid: a band smaller than the coarsest level is solved exactly", "[aggregation]") {
    const Band band = test::anisotropicBall(4, 0.1, 4.0);
    REQUIRE(band.size() <= AggregationOptions{}.coarsestUnknowns);
    const LaplacianOperator L(band);
    const AggregationMultigrid mg(L);
    CHECK(mg.levels() == 1);
    const std::vector<float> b = randomVector(band.size(), 3);
    std::vector<float> z(band.size()), Lz(band.size());
    mg.apply(b.data(), z.data());
    L.apply(z.data(), Lz.data());
    double err = 0, norm = 0;
    for (std::size_t i = 0; i < b.size(); ++i) err += std::pow(double(Lz[i]) - double(b[i]), 2), norm += double(b[i]) * double(b[i]);
    CHECK(std::sqrt(err / norm) <= 1e-5);
}

TEST_CASE("aggregation multigrid: bad options and operators are refused", "[aggregation]") {
    const Band& band = test::sphereBand();
    const LaplacianOperator L(band);
    AggregationOptions o;
    o.smoothingSteps = 0;
    CHECK_THROWS_AS(AggregationMultigrid(L, o), ParameterError);
    o = {};
    o.jacobiWeight = 1.0;
    CHECK_THROWS_AS(AggregationMultigrid(L, o), ParameterError);
    o = {};
    o.coarseCorrectionWeight = 2.0;
    CHECK_THROWS_AS(AggregationMultigrid(L, o), ParameterError);
    o = {};
    o.coarsestUnknowns = 5000;  // beyond the dense coarsest solve's 4096
    CHECK_THROWS_AS(AggregationMultigrid(L, o), ParameterError);
    o = {};
    o.transposeChunkEntries = 0;
    CHECK_THROWS_AS(AggregationMultigrid(L, o), ParameterError);
    o = {};
    o.maxLevels = 1;
    CHECK_THROWS_AS(AggregationMultigrid(L, o), ParameterError);
    // Only the band Laplacian knows its lattice: an assembled matrix is refused with a ParameterError.
    const SparseMatrixF A = assembleLaplacian(band);
    CHECK_THROWS_AS(PcgSolver(AssembledOperator(A), aggregationOptions(1e-6)), ParameterError);
}
