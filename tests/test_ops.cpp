#include <catch2/catch.hpp>
#include <Eigen/SparseCholesky>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/laplacian.h"

using namespace gpisvdb;
using test::dot;
using test::randomField;

namespace {

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

/// The bands every property is checked on: GPIS bands (thin stencils) and an analytic one with wide stencils.
std::vector<std::pair<const char*, const Band*>> bands() {
    static const Band wide = test::anisotropicBall(12, 0.1, 15.0);
    return {{"sphere", &test::sphereBand()}, {"torus with a gap", &test::torusGapBand()}, {"anisotropic ball", &wide}};
}

/// L by the triplet list the assembly used before (every voxel's 4 entries per stencil direction, summed by Eigen's
/// setFromTriplets in list order): the reference the direct assembly must equal to the last bit.
template <class Matrix>
Matrix tripletLaplacian(const Band& band) {
    using Scalar = typename Matrix::Scalar;
    std::vector<Eigen::Triplet<Scalar, int>> t;
    auto acc = band.index->getConstAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) {
        const VoxelStencil& st = band.stencil[i];
        for (int k = 0; k < st.count; ++k) {
            const Scalar w = Scalar(0.5 * band.voxelSize * double(st.weight[k]));
            const openvdb::Coord d(st.offset[k][0], st.offset[k][1], st.offset[k][2]);
            for (const openvdb::Coord& y : {band.coord[i] + d, band.coord[i] - d}) {
                const int j = acc.getValue(y);
                t.emplace_back(int(i), int(i), w);
                if (j < 0) continue;
                t.emplace_back(j, j, w);
                t.emplace_back(int(i), j, -w);
                t.emplace_back(j, int(i), -w);
            }
        }
    }
    Matrix L(int(band.size()), int(band.size()));
    L.setFromTriplets(t.begin(), t.end());
    L.makeCompressed();
    return L;
}

template <class Matrix>
bool identical(const Matrix& a, const Matrix& b) {
    return a.rows() == b.rows() && a.nonZeros() == b.nonZeros() &&
           std::equal(a.outerIndexPtr(), a.outerIndexPtr() + a.outerSize() + 1, b.outerIndexPtr()) &&
           std::equal(a.innerIndexPtr(), a.innerIndexPtr() + a.nonZeros(), b.innerIndexPtr()) &&
           std::equal(a.valuePtr(), a.valuePtr() + a.nonZeros(), b.valuePtr());
}

}  // namespace

TEST_CASE("ops: the assembled L equals the triplet-list assembly to the last bit, float and double, for 1 and 2 threads", "[ops]") {
    for (const Band* band : {&test::sphereBand(), &test::torusGapBand()}) {
        const Band ball = test::anisotropicBall(6, 0.1, 8.0);
        for (const Band* b : {band, &ball}) {
            for (int threads : {1, 2}) {
                tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
                INFO(b->size() << " voxels, " << threads << " threads");
                CHECK(identical(assembleLaplacian(*b), tripletLaplacian<SparseMatrixF>(*b)));
                CHECK(identical(assembleLaplacianDouble(*b), tripletLaplacian<SparseMatrixD>(*b)));
            }
        }
    }
}

TEST_CASE("ops: the Laplacian's entries counted from the stencils are exactly those the assembly stores", "[ops]") {
    // The count refuses the spectrum's assembled L before it is made (docs/memory.md): it must not be a bound
    const Band ball = test::anisotropicBall(6, 0.1, 8.0);
    for (const Band* b : {&test::sphereBand(), &test::torusGapBand(), &ball}) {
        const LaplacianSize size = laplacianSize(*b);
        const SparseMatrixD L = assembleLaplacianDouble(*b);
        INFO(b->size() << " voxels");
        CHECK(size.voxels == b->size());
        CHECK(size.entries == std::size_t(L.nonZeros()));
        // Every contribution is an off-diagonal entry, some met from both ends of their edge
        CHECK(size.contributions >= size.entries - size.voxels);
        CHECK(size.contributions <= 2 * (size.entries - size.voxels));
        CHECK(assembledLaplacianBytes(size, sizeof(double)) == Approx(12.0 * double(L.nonZeros()) + 4.0 * double(b->size() + 1)));
    }
}

TEST_CASE("ops: u^T L u equals the energy of Eq. 24 computed from the stencils", "[ops]") {
    for (auto [name, band] : bands()) {
        INFO(name);
        const LaplacianOperator L(*band);
        for (std::uint64_t seed : {1, 2, 3}) {
            const std::vector<float> u = randomField(band->size(), seed);
            std::vector<float> Lu;
            L.apply(u, Lu);
            CHECK(dot(u, Lu) == Approx(energy(*band, u)).epsilon(1e-5));
        }
    }
}

TEST_CASE("ops: L is symmetric and positive definite", "[ops]") {
    for (auto [name, band] : bands()) {
        INFO(name);
        const SparseMatrixF A = assembleLaplacian(*band);
        CHECK((SparseMatrixF(A.transpose()) - A).norm() == 0);
        const LaplacianOperator L(*band);
        const std::vector<float> u = randomField(band->size(), 4), v = randomField(band->size(), 5);
        std::vector<float> Lu, Lv;
        L.apply(u, Lu);
        L.apply(v, Lv);
        CHECK(dot(v, Lu) == Approx(dot(u, Lv)).epsilon(1e-5));
        CHECK(dot(u, Lu) > 0);
        // Cholesky succeeds only on a positive definite matrix (Dirichlet outside the band makes it definite).
        Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A.cast<double>());
        REQUIRE(ldlt.info() == Eigen::Success);
        CHECK(ldlt.vectorD().minCoeff() > 0);
    }
}

TEST_CASE("ops: matrix-free L equals the assembled matrix, diagonal included", "[ops]") {
    for (auto [name, band] : bands()) {
        INFO(name);
        const SparseMatrixF A = assembleLaplacian(*band);
        const LaplacianOperator L(*band);
        const std::vector<float> u = randomField(band->size(), 6);
        std::vector<float> free, assembled;
        L.apply(u, free);
        multiply(A, u, assembled);
        const double scale = test::maxAbs(assembled);
        for (std::size_t i = 0; i < u.size(); ++i) CHECK(free[i] == Approx(assembled[i]).margin(1e-5 * scale));
        std::vector<float> d1(band->size()), d2(band->size());
        L.diagonal(d1.data());
        AssembledOperator(A).diagonal(d2.data());
        for (std::size_t i = 0; i < d1.size(); ++i) CHECK(d1[i] == Approx(d2[i]).epsilon(1e-5));
    }
}

TEST_CASE("ops: matrix-free and assembled products do not depend on the thread count", "[ops]") {
    for (auto [name, band] : bands()) {
        INFO(name);
        const std::vector<float> u = randomField(band->size(), 7);
        std::vector<float> free1, free2, asm1, asm2;
        SparseMatrixF A1;
        {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
            A1 = assembleLaplacian(*band);
            LaplacianOperator(*band).apply(u, free1);
            multiply(A1, u, asm1);
        }
        {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
            CHECK(assembleLaplacian(*band).isApprox(A1, 0.0f));
            LaplacianOperator(*band).apply(u, free2);
            multiply(A1, u, asm2);
        }
        CHECK(free1 == free2);
        CHECK(asm1 == asm2);
    }
}

TEST_CASE("ops: L is unchanged and M scales by a^2 when the scene is scaled by a = 1e-3 … 1e6", "[ops]") {
    // h → a h, μ → μ/a, T → T/a (T and μ are densities per unit length): edge weights h λ are invariant.
    const Band ref = test::anisotropicBall(6, 0.1, 5.0);
    const std::vector<float> u = randomField(ref.size(), 8);
    std::vector<float> Lu;
    LaplacianOperator(ref).apply(u, Lu);
    const std::vector<float> m = massDiagonal(ref);
    for (double a : {1e-3, 1e3, 1e6}) {
        INFO("scale " << a);
        const Band scaled = bandFromVoxels(test::scaledVoxels(ref, a), a * ref.voxelSize, 100).band;
        REQUIRE(scaled.size() == ref.size());
        std::vector<float> Lu2;
        LaplacianOperator(scaled).apply(u, Lu2);
        const std::vector<float> m2 = massDiagonal(scaled);
        for (std::size_t i = 0; i < u.size(); ++i) {
            CHECK(Lu2[i] == Approx(Lu[i]).margin(1e-5 * test::maxAbs(Lu)));
            CHECK(m2[i] == Approx(a * a * m[i]).epsilon(1e-5));
        }
    }
    // Voxels of 1e-7 world units: OpenVDB cannot hold the transform, and says so as a parameter error.
    CHECK_THROWS_AS(bandFromVoxels(test::scaledVoxels(ref, 1e-6), 1e-6 * ref.voxelSize, 100), ParameterError);
}

TEST_CASE("ops: the mass diagonal integrates a random sphere's mu to its expected area 4 pi (r^2 + w^2)", "[ops]") {
    // φ = u + r − |x| + ε, ε ~ N(0, w²), ∇φ = −x/|x| exactly: the surface φ = u is the sphere of radius r + ε, of
    // expected area E[4π(r + ε)²] = 4π(r² + w²), and Kac–Rice gives μ(x) = p_φ(x)(u) ‖∇φ‖ = g_w(|x| − r) (g_w the
    // N(0, w²) density), T = μ (I − n nᵀ). Voxels out to |x| − r = ±7w (tail mass 3e-12). Summing at spacing
    // h = w errs by < 2 exp(−2π² w²/h²) ≈ 5e-9 (a Gaussian profile, docs/benchmarks.md); float channels ≈ 1e-7.
    // Measured: 3e-9 at h = w, 2e-7 at 1.25 w, 2e-5 at 1.5 w. Bound 1e-6 (one voxel dropped: ~1e-4).
    const double r = 1.0, w = 0.1, h = w;
    const int reach = int(std::ceil((r + 7 * w) / h));
    std::vector<BandVoxel> voxels;
    for (int x = -reach; x <= reach; ++x)
        for (int y = -reach; y <= reach; ++y)
            for (int z = -reach; z <= reach; ++z) {
                const Vec3d p = h * Vec3d(x, y, z);
                const double d = p.norm() - r;
                if (std::abs(d) > 7 * w) continue;
                BandVoxel v;
                v.coord = openvdb::Coord(x, y, z);
                v.mu = std::exp(-0.5 * d * d / (w * w)) / (std::sqrt(2 * M_PI) * w);
                v.normal = p.normalized();
                v.T = v.mu * (Mat3d::Identity() - v.normal * v.normal.transpose());
                v.mean = 0.5 + r - p.norm();
                v.stddev = w;
                voxels.push_back(v);
            }
    const Band band = bandFromVoxels(std::move(voxels), h, 20).band;
    const std::vector<float> M = massDiagonal(band);
    REQUIRE(M.size() == band.size());
    double total = 0;
    for (float m : M) total += m;
    const double expected = 4 * M_PI * (r * r + w * w);
    INFO(band.size() << " voxels, sum of M " << total << ", 4 pi (r^2 + w^2) = " << expected);
    CHECK(std::abs(total / expected - 1) <= 1e-6);
}
