#include <catch2/catch.hpp>
#include <Eigen/SparseCholesky>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/solve/pcg.h"

using namespace gpisvdb;


TEST_CASE("pcg: reaches the tolerance and agrees with a sparse Cholesky solve", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF L = assembleLaplacian(band);
    const std::vector<float> m = massDiagonal(band);
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 3] = float(band.mu[band.size() / 3]);  // a Green's function right-hand side, M δ_y
    std::vector<float> x;
    const PcgResult r = solvePcg(L, b, x, {1e-6, 20000});
    INFO(band.size() << " voxels, " << r.iterations << " iterations, residual " << r.relativeResidual);
    REQUIRE(r.converged);
    CHECK(r.relativeResidual <= 1e-6);
    // The true residual, recomputed in double, is at the tolerance too (float storage costs ~1e-7).
    const Eigen::SparseMatrix<double> Ld = L.cast<double>();
    const Eigen::VectorXd xd = Eigen::Map<const Eigen::VectorXf>(x.data(), long(x.size())).cast<double>();
    const Eigen::VectorXd bd = Eigen::Map<const Eigen::VectorXf>(b.data(), long(b.size())).cast<double>();
    CHECK((bd - Ld * xd).norm() <= 1e-5 * bd.norm());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(Ld);
    const Eigen::VectorXd exact = ldlt.solve(bd);
    CHECK((xd - exact).norm() <= 1e-4 * exact.norm());
}

TEST_CASE("pcg: incomplete Cholesky reaches the same solution in fewer iterations", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF L = assembleLaplacian(band);
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 2] = 1.0f;
    std::vector<float> xj, xi;
    PcgOptions o;
    o.tolerance = 1e-7;
    const PcgResult rj = solvePcg(L, b, xj, o);
    o.preconditioner = Preconditioner::IncompleteCholesky;
    const PcgResult ri = solvePcg(L, b, xi, o);
    REQUIRE(rj.converged);
    REQUIRE(ri.converged);
    CHECK(ri.iterations < rj.iterations);
    double diff = 0, norm = 0;
    for (std::size_t i = 0; i < xj.size(); ++i) diff += double(xj[i] - xi[i]) * (xj[i] - xi[i]), norm += double(xj[i]) * xj[i];
    CHECK(std::sqrt(diff) <= 1e-4 * std::sqrt(norm));
}

TEST_CASE("pcg: identical iterates for 1 and 2 threads", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF L = assembleLaplacian(band);
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

TEST_CASE("pcg: a zero right-hand side gives zero; bad options are refused", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF L = assembleLaplacian(band);
    std::vector<float> x(band.size(), 1.0f);
    const PcgResult r = solvePcg(L, std::vector<float>(band.size(), 0.0f), x);
    CHECK(r.converged);
    CHECK(*std::max_element(x.begin(), x.end()) == 0.0f);
    CHECK_THROWS_AS(solvePcg(L, std::vector<float>(band.size(), 1.0f), x, {0.0, 10}), ParameterError);
}
