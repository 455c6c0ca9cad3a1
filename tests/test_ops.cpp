#include <catch2/catch.hpp>
#include <Eigen/SparseCholesky>
#include <random>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/stencil/resolution.h"

using namespace gpisvdb;

namespace {


std::vector<float> randomField(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> U(-1, 1);
    std::vector<float> u(n);
    for (auto& v : u) v = U(rng);
    return u;
}

double dot(const std::vector<float>& a, const std::vector<float>& b) {
    double s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) s += double(a[i]) * double(b[i]);
    return s;
}

/// E_h(u) straight from paper Eq. 24: every voxel's stencil, both directions, u = 0 outside the band.
double energy(const Band& band, const std::vector<float>& u) {
    auto acc = band.index->getConstAccessor();
    double e = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        const VoxelStencil& st = band.stencil[i];
        for (int k = 0; k < st.count; ++k) {
            const openvdb::Coord d(st.offset[k][0], st.offset[k][1], st.offset[k][2]);
            for (const openvdb::Coord& y : {band.coord[i] + d, band.coord[i] - d}) {
                const int j = acc.getValue(y);
                const double uy = j < 0 ? 0.0 : double(u[std::size_t(j)]);
                e += double(st.weight[k]) * (uy - u[i]) * (uy - u[i]) / 2;
            }
        }
    }
    return band.voxelSize * e;
}

}  // namespace

TEST_CASE("ops: u^T L u equals the energy of Eq. 24 computed from the stencils", "[ops]") {
    const Band& band = test::sphereBand();
    const SparseMatrixF L = assembleLaplacian(band);
    for (std::uint64_t seed : {1, 2, 3}) {
        const std::vector<float> u = randomField(band.size(), seed);
        std::vector<float> Lu;
        multiply(L, u, Lu);
        CHECK(dot(u, Lu) == Approx(energy(band, u)).epsilon(1e-5));
    }
}

TEST_CASE("ops: L is symmetric and positive definite", "[ops]") {
    const Band& band = test::sphereBand();
    const SparseMatrixF L = assembleLaplacian(band);
    CHECK((SparseMatrixF(L.transpose()) - L).norm() == 0);
    const std::vector<float> u = randomField(band.size(), 4), v = randomField(band.size(), 5);
    std::vector<float> Lu, Lv;
    multiply(L, u, Lu);
    multiply(L, v, Lv);
    CHECK(dot(v, Lu) == Approx(dot(u, Lv)).epsilon(1e-6));
    CHECK(dot(u, Lu) > 0);
    // Cholesky succeeds only on a positive definite matrix (Dirichlet outside the band makes it definite).
    const Eigen::SparseMatrix<double> Ld = L.cast<double>();
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(Ld);
    REQUIRE(ldlt.info() == Eigen::Success);
    CHECK(ldlt.vectorD().minCoeff() > 0);
}

TEST_CASE("ops: the parallel product equals Eigen's and does not depend on the thread count", "[ops]") {
    const Band& band = test::sphereBand();
    const SparseMatrixF L = assembleLaplacian(band);
    const std::vector<float> u = randomField(band.size(), 6);
    std::vector<float> one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        multiply(L, u, one);
        CHECK(assembleLaplacian(band).isApprox(L, 0.0f));
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        multiply(L, u, two);
    }
    CHECK(one == two);
    const Eigen::VectorXd ref = L.cast<double>() * Eigen::Map<const Eigen::VectorXf>(u.data(), long(u.size())).cast<double>();
    for (std::size_t i = 0; i < u.size(); ++i) CHECK(one[i] == Approx(ref[long(i)]).margin(1e-5 * ref.cwiseAbs().maxCoeff()));
}

TEST_CASE("ops: the mass integrates to the band's expected area", "[ops]") {
    const Band& band = test::sphereBand();
    double total = 0;
    for (float m : massDiagonal(band)) total += m;
    CHECK(total == Approx(band.mass()).epsilon(1e-5));
}

TEST_CASE("ops: expected Dirichlet energy of x on the unit sphere is 8 pi / 3 within 2% at sigma_rel 0.5", "[ops]") {
    // E[E_D(x₁)] → ∫_S |∇_S x₁|² dA = 8π/3 as σ → 0 (paper Fig. 6 top). u = 0 outside the band adds
    // Σ_boundary h λ u², which grows like η/h: the energy needs a small η (measured: η = 0.01 gives +190%,
    // 1e-4 +14% at σ = 1, 1e-6 +13% at σ = 1 — the noise's own extra area — and +1.3% at σ = 0.5).
    const SoupSamples ss = soupSamples(icosphere(3), {0.5});
    const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
    const Resolution res = chooseResolution(model, ss.samples);
    BandOptions o;
    o.voxelSize = 1.5 * res.muWidth;
    o.etaRelative = 1e-6;
    const Band band = buildBand(model, ss.samples, o).band;
    const SparseMatrixF L = assembleLaplacian(band);
    std::vector<float> f(band.size()), Lf;
    for (std::size_t i = 0; i < band.size(); ++i) f[i] = float(band.voxelSize * band.coord[i].x());
    multiply(L, f, Lf);
    const double e = dot(f, Lf);
    INFO("energy " << e << " against " << 8 * M_PI / 3 << " on " << band.size() << " voxels");
    CHECK(std::abs(e / (8 * M_PI / 3) - 1) <= 0.02);
}
