#include <catch2/catch.hpp>
#include <Eigen/Eigenvalues>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/ops/first_order.h"
#include "gpisvdb/ops/laplacian.h"

using namespace gpisvdb;
using test::dot;
using test::randomField;

namespace {

std::vector<float> times(const SparseMatrixF& A, const std::vector<float>& u) {
    std::vector<float> out;
    multiply(A, u, out);
    return out;
}

void checkClose(const std::vector<float>& got, const std::vector<float>& want, double relative) {
    REQUIRE(got.size() == want.size());
    const double scale = test::maxAbs(want);
    for (std::size_t i = 0; i < got.size(); ++i) CHECK(got[i] == Approx(want[i]).margin(relative * scale));
}

/// Voxels whose six face neighbours are all in the band.
std::vector<bool> interior(const Band& band) {
    auto acc = band.index->getConstAccessor();
    std::vector<bool> in(band.size(), true);
    for (std::size_t i = 0; i < band.size(); ++i)
        for (int c = 0; c < 3; ++c)
            for (int s : {-1, 1}) {
                openvdb::Coord y = band.coord[i];
                y[c] += s;
                if (acc.getValue(y) < 0) in[i] = false;
            }
    return in;
}

}  // namespace

TEST_CASE("first order: G is exact on linear functions inside the band, zero-extended at its edge", "[first_order]") {
    const Band& band = test::torusGapBand();
    const Vec3d a(0.3, -1.2, 2.0);
    std::vector<float> u(band.size()), g;
    for (std::size_t i = 0; i < band.size(); ++i)
        u[i] = float(band.voxelSize * a.dot(Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z())));
    gradient(band, u, g);
    const std::vector<bool> in = interior(band);
    std::size_t inside = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        if (!in[i]) continue;
        ++inside;
        for (int c = 0; c < 3; ++c) CHECK(g[3 * i + std::size_t(c)] == Approx(a[c]).margin(2e-4 * a.norm() / band.voxelSize));
    }
    CHECK(inside > band.size() / 3);
}

TEST_CASE("first order: matrix-free G, G^T, G_phi, D_phi equal their assembled forms", "[first_order]") {
    const Band& band = test::sphereBand();
    const std::vector<float> u = randomField(band.size(), 1), V = randomField(3 * band.size(), 2);
    std::vector<float> out;
    gradient(band, u, out);
    checkClose(out, times(assembleGradient(band), u), 1e-6);
    gradientTranspose(band, V, out);
    checkClose(out, times(SparseMatrixF(assembleGradient(band).transpose()), V), 1e-6);
    gradPhi(band, u, out);
    checkClose(out, times(assembleGradPhi(band), u), 1e-5);
    divPhi(band, V, out);
    checkClose(out, times(assembleDivPhi(band), V), 1e-5);
}

TEST_CASE("first order: with Neumann boundaries G drops the differences leaving the band and kills constants", "[first_order]") {
    const Band& band = test::torusGapBand();
    const std::vector<float> u = randomField(band.size(), 5), V = randomField(3 * band.size(), 6);
    std::vector<float> out;
    const SparseMatrixF G = assembleGradient(band, Boundary::Neumann);
    gradient(band, u, out, Boundary::Neumann);
    checkClose(out, times(G, u), 1e-6);
    gradientTranspose(band, V, out, Boundary::Neumann);
    checkClose(out, times(SparseMatrixF(G.transpose()), V), 1e-6);
    gradient(band, std::vector<float>(band.size(), 2.5f), out, Boundary::Neumann);
    CHECK(test::maxAbs(out) == 0);
    // K = Gᵀ BlockDiag(h³ T) G with the Neumann G: diagonal and product.
    const NaiveLaplacianOperator K(band, Boundary::Neumann);
    std::vector<float> Ku(band.size()), diag(band.size()), GTGu;
    K.apply(u.data(), Ku.data());
    K.diagonal(diag.data());
    std::vector<double> h3T(band.size(), std::pow(band.voxelSize, 3));
    SparseMatrixF B(int(3 * band.size()), int(3 * band.size()));
    std::vector<Eigen::Triplet<float, int>> t;
    for (std::size_t i = 0; i < band.size(); ++i) {
        const auto& T = band.T[i];
        const float m[3][3] = {{T[0], T[3], T[4]}, {T[3], T[1], T[5]}, {T[4], T[5], T[2]}};
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) t.emplace_back(int(3 * i) + a, int(3 * i) + b, float(h3T[i]) * m[a][b]);
    }
    B.setFromTriplets(t.begin(), t.end());
    const SparseMatrixF Kassembled = SparseMatrixF(G.transpose()) * B * G;
    checkClose(Ku, times(Kassembled, u), 1e-5);
    std::vector<float> want(band.size());
    for (int i = 0; i < int(band.size()); ++i) want[std::size_t(i)] = Kassembled.coeff(i, i);
    checkClose(diag, want, 1e-5);
    K.apply(std::vector<float>(band.size(), 1.0f).data(), Ku.data());
    CHECK(test::maxAbs(Ku) < 1e-6 * test::maxAbs(diag));
}

TEST_CASE("first order: G^T is the adjoint of G, and D_phi of G in the mu-weighted products", "[first_order]") {
    const Band& band = test::torusGapBand();
    const Boundary bc = GENERATE(Boundary::Dirichlet, Boundary::Neumann);
    const std::vector<float> u = randomField(band.size(), 3), V = randomField(3 * band.size(), 4);
    std::vector<float> Gu, GtV, DV;
    gradient(band, u, Gu, bc);
    gradientTranspose(band, V, GtV, bc);
    CHECK(dot(Gu, V) == Approx(dot(u, GtV)).epsilon(1e-5));
    // uᵀ M D_φ V = (G u)ᵀ (M ⊗ I) V  (paper Eq. 22).
    divPhi(band, V, DV, bc);
    const std::vector<float> m = massDiagonal(band);
    double lhs = 0, rhs = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        lhs += double(u[i]) * m[i] * DV[i];
        for (int c = 0; c < 3; ++c) rhs += double(Gu[3 * i + std::size_t(c)]) * m[i] * V[3 * i + std::size_t(c)];
    }
    CHECK(lhs == Approx(rhs).epsilon(1e-5));
}

TEST_CASE("first order: T/mu is an average of projectors, G_phi of x tends to the tangential gradient as sigma falls", "[first_order]") {
    // T/μ = E[‖X‖ Π_X⊥] / E‖X‖: eigenvalues in [0, 1] (after the anisotropy cap too); near γ = u it tends to
    // I − n nᵀ as σ → 0, so
    // G_φ x₁ → e₁ − n₁ n (the ambient gradient e₁ would be off by |n₁|, up to 1).
    double previous = 1;
    for (auto [sigma, h] : {std::pair{1.0, 0.05}, std::pair{0.5, 0.03}}) {
        const Band band = test::bandOf(icosphere(3), sigma, h);
        std::vector<float> x(band.size()), g;
        for (std::size_t i = 0; i < band.size(); ++i) x[i] = float(band.voxelSize * band.coord[i].x());
        gradPhi(band, x, g);
        std::size_t near = 0;
        double sum = 0;
        for (std::size_t i = 0; i < band.size(); ++i) {
            const auto& t = band.T[i];
            Mat3d P;
            P << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
            P /= double(band.mu[i]);
            const Vec3d ev = Eigen::SelfAdjointEigenSolver<Mat3d>(P).eigenvalues();
            CHECK(ev.minCoeff() >= -1e-5);
            CHECK(ev.maxCoeff() <= 1 + 1e-5);
            if (std::abs(band.mean[i] - 0.5f) > 0.05f) continue;
            ++near;
            const Vec3d n(band.normal[i].x(), band.normal[i].y(), band.normal[i].z());
            sum += (Vec3d(g[3 * i], g[3 * i + 1], g[3 * i + 2]) - (Vec3d::UnitX() - n.x() * n)).norm();
        }
        const double mean = sum / double(near);
        INFO("sigma_rel " << sigma << ": " << near << " voxels near the mean surface, mean deviation " << mean);
        CHECK(near > 500);
        CHECK(mean < 0.5 * previous);
        previous = mean;
    }
    CHECK(previous < 0.05);
}

TEST_CASE("first order: the naive Laplacian K = M D_phi G_phi is symmetric, matches its assembled form and energy", "[first_order]") {
    const Band& band = test::sphereBand();
    const NaiveLaplacianOperator K(band);
    const std::vector<float> u = randomField(band.size(), 5), v = randomField(band.size(), 6);
    std::vector<float> Ku, Kv;
    K.apply(u, Ku);
    K.apply(v, Kv);
    CHECK(dot(v, Ku) == Approx(dot(u, Kv)).epsilon(1e-5));
    // K = M (D_φ G_φ), assembled.
    const SparseMatrixF naive = assembleNaiveLaplacian(band);
    std::vector<float> Nu = times(naive, u);
    const std::vector<float> m = massDiagonal(band);
    for (std::size_t i = 0; i < Nu.size(); ++i) Nu[i] *= m[i];
    checkClose(Ku, Nu, 1e-5);
    // uᵀ K u = h³ Σ (G u)ᵀ T (G u).
    std::vector<float> Gu;
    gradient(band, u, Gu);
    double e = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        const auto& t = band.T[i];
        Mat3d T;
        T << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
        const Vec3d g(Gu[3 * i], Gu[3 * i + 1], Gu[3 * i + 2]);
        e += g.dot(T * g);
    }
    CHECK(dot(u, Ku) == Approx(e * std::pow(band.voxelSize, 3)).epsilon(1e-5));
    CHECK(dot(u, Ku) > 0);
    // Its diagonal, matrix-free, against the assembled one.
    std::vector<float> d(band.size());
    K.diagonal(d.data());
    for (std::size_t i = 0; i < d.size(); ++i) CHECK(d[i] == Approx(naive.coeff(int(i), int(i)) * m[i]).epsilon(1e-4));
}

TEST_CASE("first order: results do not depend on the thread count", "[first_order]") {
    const Band& band = test::torusGapBand();
    const std::vector<float> u = randomField(band.size(), 7), V = randomField(3 * band.size(), 8);
    std::vector<float> a1, b1, c1, a2, b2, c2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        gradPhi(band, u, a1), divPhi(band, V, b1), NaiveLaplacianOperator(band).apply(u, c1);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        gradPhi(band, u, a2), divPhi(band, V, b2), NaiveLaplacianOperator(band).apply(u, c2);
    }
    CHECK(a1 == a2);
    CHECK(b1 == b2);
    CHECK(c1 == c2);
}
