// The generalized eigen solver L u = λ M u (solve/eigen_solver.h).
#include <catch2/catch.hpp>
#include <Eigen/Eigenvalues>
#include <random>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/tasks/spectrum.h"

using namespace gpisvdb;

namespace {

/// A 3D grid Laplacian (Dirichlet) with random positive edge weights, and a random positive mass.
std::pair<SparseMatrixD, Eigen::VectorXd> randomProblem(int side, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(0.5, 2.0);
    const int n = side * side * side;
    auto id = [&](int x, int y, int z) { return (z * side + y) * side + x; };
    std::vector<Eigen::Triplet<double>> t;
    for (int z = 0; z < side; ++z)
        for (int y = 0; y < side; ++y)
            for (int x = 0; x < side; ++x) {
                const int i = id(x, y, z);
                for (int a = 0; a < 3; ++a) {
                    int q[3] = {x, y, z};
                    if (q[a] == 0) t.emplace_back(i, i, U(rng));  // the edge out of the grid's low face
                    q[a] += 1;
                    const double w = U(rng);
                    t.emplace_back(i, i, w);
                    if (q[a] == side) continue;  // out of the high face: u = 0 there
                    const int j = id(q[0], q[1], q[2]);
                    t.emplace_back(j, j, w);
                    t.emplace_back(i, j, -w);
                    t.emplace_back(j, i, -w);
                }
            }
    SparseMatrixD L(n, n);
    L.setFromTriplets(t.begin(), t.end());
    Eigen::VectorXd m(n);
    for (int i = 0; i < n; ++i) m(i) = U(rng);
    return {L, m};
}

}  // namespace

TEST_CASE("eigen solver: the lowest pairs match a dense generalized solve", "[eigen]") {
    const auto [L, m] = randomProblem(7, 3);  // 343 unknowns
    EigenOptions o;
    o.count = 12;
    const EigenResult r = lowestEigenpairs(L, m, o);
    const Eigen::MatrixXd Ld(L);
    const Eigen::MatrixXd Md = m.asDiagonal();
    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> dense(Ld, Md);
    for (int i = 0; i < o.count; ++i) {
        CHECK(r.values(i) == Approx(dense.eigenvalues()(i)).epsilon(1e-10));
        // Same vector up to sign (the lowest spectrum of this random problem is simple).
        CHECK(std::abs(r.vectors.col(i).dot(Md * dense.eigenvectors().col(i))) == Approx(1.0).epsilon(1e-8));
    }
}

TEST_CASE("eigen solver: residuals <= 1e-6, U^T M U = I within 1e-8, eigenvalues ascending and positive", "[eigen]") {
    const Band& band = test::sphereBand();
    for (int k : {1, 20, 60}) {
        INFO("k = " << k);
        EigenOptions o;
        o.count = k;
        const EigenResult r = spectrum(band, o);
        REQUIRE(r.values.size() == k);
        REQUIRE(r.vectors.rows() == Eigen::Index(band.size()));
        CHECK(r.values(0) > 0);
        for (int i = 1; i < k; ++i) CHECK(r.values(i) >= r.values(i - 1));
        CHECK(r.residuals.maxCoeff() <= 1e-6);
        CHECK(r.orthonormalityError <= 1e-8);
        // Recomputed here, independently of the solver's own check.
        const Eigen::MatrixXd gram = r.vectors.transpose() * massVector(band).asDiagonal() * r.vectors;
        CHECK((gram - Eigen::MatrixXd::Identity(k, k)).cwiseAbs().maxCoeff() <= 1e-8);
        // Each sign is fixed: the largest |entry| is positive.
        for (int i = 0; i < k; ++i) CHECK(r.vectors.col(i).maxCoeff() >= -r.vectors.col(i).minCoeff());
    }
}

TEST_CASE("eigen solver: identical for 1 and 2 threads", "[eigen]") {
    const Band& band = test::torusGapBand();
    EigenOptions o;
    o.count = 10;
    EigenResult one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = spectrum(band, o);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = spectrum(band, o);
    }
    CHECK(one.values == two.values);
    CHECK(one.vectors == two.vectors);
}

TEST_CASE("eigen solver: eigenvalues scale by 1/a^2 when the scene is scaled by a = 1e-3 … 1e6", "[eigen]") {
    // L is scale invariant and M scales by a² (see the ops test of the same name): λ → λ / a².
    const Band ref = test::anisotropicBall(6, 0.1, 5.0);
    EigenOptions o;
    o.count = 6;
    const EigenResult r0 = spectrum(ref, o);
    for (double a : {1e-3, 1e3, 1e6}) {
        INFO("scale " << a);
        const Band scaled = bandFromVoxels(test::scaledVoxels(ref, a), a * ref.voxelSize, 100).band;
        const EigenResult r = spectrum(scaled, o);
        for (int i = 0; i < o.count; ++i) CHECK(a * a * r.values(i) == Approx(r0.values(i)).epsilon(1e-5));
        CHECK(r.residuals.maxCoeff() <= 1e-6);
    }
}

TEST_CASE("eigen solver: refuses k out of range, a non-positive mass and an indefinite L", "[eigen]") {
    const auto [L, m] = randomProblem(4, 5);  // 64 unknowns
    EigenOptions o;
    o.count = 0;
    CHECK_THROWS_AS(lowestEigenpairs(L, m, o), ParameterError);
    o.count = 64;
    CHECK_THROWS_WITH(lowestEigenpairs(L, m, o), Catch::Contains("between 1 and 63"));
    o.count = 4;
    Eigen::VectorXd bad = m;
    bad(3) = 0;
    CHECK_THROWS_AS(lowestEigenpairs(L, bad, o), ParameterError);
    bad(3) = std::nan("");
    CHECK_THROWS_AS(lowestEigenpairs(L, bad, o), ParameterError);
    const SparseMatrixD negative = -L;
    CHECK_THROWS_WITH(lowestEigenpairs(negative, m, o), Catch::Contains("not positive definite"));
    o.subspace = 4;
    CHECK_THROWS_AS(lowestEigenpairs(L, m, o), ParameterError);
    // A memory cap below the factor's size is refused before the numeric factorisation.
    o.subspace = 0;
    o.maxBytes = 1000;
    CHECK_THROWS_WITH(lowestEigenpairs(L, m, o), Catch::Contains("more than the"));
    o.maxBytes = 1e9;
    CHECK_NOTHROW(lowestEigenpairs(L, m, o));
}

// === LOBPCG with the multigrid (solve/lobpcg.h): the path without a factor

namespace {

EigenOptions lobpcgOptions(int count) {
    EigenOptions o;
    o.count = count;
    o.method = EigenMethod::Lobpcg;
    return o;
}

/// Largest principal angle's sine between the column spans of A and B (both M-orthonormal): ‖(I − B Bᵀ M) A‖₂.
double subspaceSine(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& m) {
    const Eigen::MatrixXd R = A - B * (B.transpose() * m.asDiagonal() * A);
    const Eigen::MatrixXd G = R.transpose() * m.asDiagonal() * R;
    return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(G).eigenvalues().maxCoeff()));
}

}  // namespace

TEST_CASE("eigen solver: LOBPCG with the multigrid equals CHOLMOD's Lanczos within 1e-6 in values and subspace", "[eigen][multigrid]") {
    // The unit sphere's band: λ − λ₀ ≈ l(l+1) with multiplicities 1, 3, 5, so k = 9 ends at a complete cluster and the
    // spans compare; and the random grid problem, whose spectrum is simple.
    const Band& sphere = test::sphereBand();
    const auto [Lr, mr] = randomProblem(12, 5);
    const SparseMatrixD Ls = assembleLaplacianDouble(sphere);
    const Eigen::VectorXd ms = massVector(sphere);
    for (auto [L, m, k] : {std::tuple<const SparseMatrixD*, const Eigen::VectorXd*, int>{&Ls, &ms, 9},
                           std::tuple<const SparseMatrixD*, const Eigen::VectorXd*, int>{&Lr, &mr, 12}}) {
        EigenOptions lanczos;
        lanczos.count = k;
        lanczos.method = EigenMethod::ShiftInvert;
        const EigenResult a = lowestEigenpairs(*L, *m, lanczos);
        const EigenResult b = lowestEigenpairs(*L, *m, lobpcgOptions(k));
        INFO(L->rows() << " unknowns, k = " << k << ": LOBPCG " << b.iterations << " iterations, block " << b.subspace << ", multigrid "
                       << b.multigridLevels << " levels");
        REQUIRE(a.method == EigenMethod::ShiftInvert);
        REQUIRE(b.method == EigenMethod::Lobpcg);
        CHECK(b.iterations > 0);
        CHECK(b.multigridLevels >= 2);
        for (int i = 0; i < k; ++i) CHECK(b.values(i) == Approx(a.values(i)).epsilon(1e-6));
        CHECK(b.residuals.maxCoeff() <= 1e-8);
        CHECK(b.orthonormalityError <= 1e-8);
        CHECK(subspaceSine(b.vectors, a.vectors, *m) <= 1e-5);
    }
}

TEST_CASE("eigen solver: the automatic method takes LOBPCG where CHOLMOD's factor exceeds the memory limit", "[eigen][multigrid]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixD L = assembleLaplacianDouble(band);
    const Eigen::VectorXd m = massVector(band);
    EigenOptions o;
    o.count = 6;
    const EigenResult unlimited = lowestEigenpairs(L, m, o);
    CHECK(unlimited.method == EigenMethod::ShiftInvert);
    const double lobpcgNeeds = lobpcgBytes(double(L.rows()), o.count, o.lobpcg);
    INFO("Lanczos needs " << unlimited.estimatedBytes << " bytes, LOBPCG " << lobpcgNeeds);
    REQUIRE(lobpcgNeeds < unlimited.estimatedBytes);
    // A limit between the two: the factor is refused, LOBPCG runs; below both: refused with both named.
    o.maxBytes = 0.5 * (lobpcgNeeds + unlimited.estimatedBytes);
    const EigenResult limited = lowestEigenpairs(L, m, o);
    CHECK(limited.method == EigenMethod::Lobpcg);
    CHECK(limited.estimatedBytes == Approx(lobpcgNeeds));
    for (int i = 0; i < o.count; ++i) CHECK(limited.values(i) == Approx(unlimited.values(i)).epsilon(1e-6));
    o.method = EigenMethod::ShiftInvert;
    CHECK_THROWS_AS(lowestEigenpairs(L, m, o), MemoryLimitError);
    o.method = EigenMethod::Automatic;
    o.maxBytes = 0.5 * lobpcgNeeds;
    CHECK_THROWS_WITH(lowestEigenpairs(L, m, o), Catch::Contains("LOBPCG"));
    CHECK_THROWS_AS(lowestEigenpairs(L, m, o), MemoryLimitError);
}

TEST_CASE("eigen solver: LOBPCG is identical for 1 and 2 threads, its sums swept by chunks of rows, and refuses bad options",
          "[eigen][multigrid]") {
    const Band& band = test::sphereBand();
    const SparseMatrixD L = assembleLaplacianDouble(band);
    const Eigen::VectorXd m = massVector(band);
    REQUIRE(L.rows() > 4 * 2048);  // several of LOBPCG's row chunks (kChunkRows), so their sums' order is tested
    EigenResult r1, r2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        r1 = lowestEigenpairs(L, m, lobpcgOptions(4));
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        r2 = lowestEigenpairs(L, m, lobpcgOptions(4));
    }
    CHECK(r1.iterations == r2.iterations);
    CHECK(r1.values == r2.values);
    CHECK(r1.vectors == r2.vectors);
    EigenOptions bad = lobpcgOptions(4);
    bad.lobpcg.tolerance = 0;
    CHECK_THROWS_AS(lowestEigenpairs(L, m, bad), ParameterError);
    bad = lobpcgOptions(4);
    bad.lobpcg.maxIterations = 0;
    CHECK_THROWS_AS(lowestEigenpairs(L, m, bad), ParameterError);
    bad = lobpcgOptions(4);
    bad.lobpcg.maxIterations = 2;
    CHECK_THROWS_AS(lowestEigenpairs(L, m, bad), Error);  // not converged in 2 iterations
}
