// Validation cases for the operators (docs/operators.md, docs/math.md#operators): convergence in h (paper Fig. 6 bottom) and the expected
// Dirichlet energy on the unit sphere as σ falls (paper Fig. 6 top).
#include <catch2/catch.hpp>
#include <cmath>
#include <Eigen/IterativeLinearSolvers>
#include <functional>
#include <sstream>

#include "band_fixtures.h"
#include "gpisvdb/model/load_model.h"
#include "gpisvdb/ops/first_order.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/stencil/resolution.h"
#include "gpisvdb/tasks/geodesic.h"
#include "gpisvdb/tasks/spectrum.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

/// A smooth case: μ, T and f analytic on the ball |x| ≤ 1, and the exact −Δ_φ f = −(1/μ) ∇·(T ∇f).
struct SmoothCase {
    std::function<double(const Vec3d&)> mu;
    std::function<Mat3d(const Vec3d&)> T;
    std::function<double(const Vec3d&)> f;
    std::function<Vec3d(const Vec3d&)> gradF;

    /// −(1/μ) ∇·(T∇f), the divergence by central differences of the analytic flux (error ~1e-9).
    double minusLaplacian(const Vec3d& x) const {
        const double d = 1e-4;
        double div = 0;
        for (int c = 0; c < 3; ++c) {
            const Vec3d e = d * Vec3d::Unit(c);
            div += ((T(x + e) * gradF(x + e))[c] - (T(x - e) * gradF(x - e))[c]) / (2 * d);
        }
        return -div / mu(x);
    }

    Band band(double h) const {
        std::vector<BandVoxel> voxels;
        const int r = int(std::lround(1.0 / h));
        for (int i = -r; i <= r; ++i)
            for (int j = -r; j <= r; ++j)
                for (int k = -r; k <= r; ++k) {
                    const Vec3d x = h * Vec3d(i, j, k);
                    if (x.norm() > 1.0) continue;
                    BandVoxel v;
                    v.coord = openvdb::Coord(i, j, k);
                    v.mu = mu(x);
                    v.T = T(x);
                    voxels.push_back(v);
                }
        return bandFromVoxels(std::move(voxels), h, 1000).band;
    }
};

/// μ-weighted RMS of M⁻¹ L f + Δ_φ f over the points of the coarsest grid h₀ within radius 0.5 (further from
/// the ball's edge than any stencil reaches, so the Dirichlet condition does not enter), for h = h₀ / 2^m.
std::vector<double> errors(const SmoothCase& c, double h0, int levels) {
    std::vector<double> out;
    for (int m = 0; m < levels; ++m) {
        const double h = h0 / double(1 << m);
        const Band band = c.band(h);
        // The product in double: float rounding of f (1e-7) over h² (1e-4) would swamp the error at small h.
        const SparseMatrixF A = assembleLaplacian(band);
        std::vector<double> fx(band.size());
        for (std::size_t i = 0; i < band.size(); ++i) fx[i] = c.f(h * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z()));
        const Eigen::VectorXd Lfd = A.cast<double>() * Eigen::Map<const Eigen::VectorXd>(fx.data(), long(fx.size()));
        const double h3 = h * h * h;
        double num = 0, den = 0;
        for (std::size_t i = 0; i < band.size(); ++i) {
            const openvdb::Coord k = band.coord[i];
            if ((k.x() % (1 << m)) || (k.y() % (1 << m)) || (k.z() % (1 << m))) continue;  // not on the h₀ grid
            const Vec3d x = h * Vec3d(k.x(), k.y(), k.z());
            if (x.norm() > 0.5) continue;
            const double mu = c.mu(x);
            const double got = Lfd[long(i)] / (h3 * double(band.mu[i]));
            const double want = c.minusLaplacian(x);
            num += mu * (got - want) * (got - want);
            den += mu * want * want;
        }
        out.push_back(std::sqrt(num / den));
    }
    return out;
}

double fTest(const Vec3d& x) { return std::sin(2 * x.x() + 0.5) * std::cos(1.5 * x.y()) + x.z() * x.z() * x.x(); }
Vec3d gradFTest(const Vec3d& x) {
    return Vec3d(2 * std::cos(2 * x.x() + 0.5) * std::cos(1.5 * x.y()) + x.z() * x.z(),
                 -1.5 * std::sin(2 * x.x() + 0.5) * std::sin(1.5 * x.y()), 2 * x.z() * x.x());
}
double muTest(const Vec3d& x) { return 1.0 + 0.5 * std::cos(x.x() + 2 * x.y()) * std::sin(x.z() + 0.3); }

}  // namespace

TEST_CASE("validation: M^-1 L f converges at order 2 in h on smooth fields (one Selling cell)", "[validation]") {
    // T = Σ λ_k(x) e_k e_kᵀ over the six offsets of the canonical superbase with smooth λ_k > 0 (anisotropy up
    // to ≈ 4): the superbase stays obtuse everywhere, so every voxel's stencil is the same six offsets.
    static const Vec3d offsets[6] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, -1, 0}, {0, 1, -1}, {1, 0, -1}};
    SmoothCase c;
    c.mu = muTest;
    c.T = [](const Vec3d& x) -> Mat3d {
        Mat3d T = Mat3d::Zero();
        for (int k = 0; k < 6; ++k) {
            const double lambda = (k < 3 ? 1.0 : 0.2) * (1.0 + 0.5 * std::sin((k + 1) * x.x() - k * x.y() + 0.7 * x.z() + k));
            T += lambda * offsets[k] * offsets[k].transpose();
        }
        return muTest(x) * T;
    };
    c.f = fTest;
    c.gradF = gradFTest;
    const std::vector<double> e = errors(c, 0.1, 3);
    const double order1 = std::log2(e[0] / e[1]), order2 = std::log2(e[1] / e[2]);
    INFO("relative L2(mu) errors " << e[0] << ", " << e[1] << ", " << e[2] << ": orders " << order1 << ", " << order2);
    CHECK(e[2] < e[1]);
    CHECK(order1 > 1.8);
    CHECK(order2 > 1.8);
    CHECK(order2 < 2.3);
}

/// μ-weighted relative L2 error of the solution of L u = M g, g = −Δ_φ u* (u* smooth, zero beyond radius 0.8, so
/// the homogeneous Dirichlet condition holds), solved with Eigen's CG in double to 1e-12, for h = h₀ / 2^m.
std::vector<double> poissonErrors(const SmoothCase& c, double h0, int levels) {
    std::vector<double> out;
    for (int m = 0; m < levels; ++m) {
        const double h = h0 / double(1 << m), h3 = h * h * h;
        const Band band = c.band(h);
        Eigen::VectorXd rhs(long(band.size())), exact(long(band.size()));
        for (std::size_t i = 0; i < band.size(); ++i) {
            const Vec3d x = h * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z());
            exact[long(i)] = c.f(x);
            rhs[long(i)] = h3 * c.mu(x) * c.minusLaplacian(x);
        }
        const Eigen::SparseMatrix<double> A = assembleLaplacian(band).cast<double>();
        Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg(A);
        cg.setTolerance(1e-12);
        cg.setMaxIterations(100000);
        const Eigen::VectorXd u = cg.solve(rhs);
        double num = 0, den = 0;
        for (std::size_t i = 0; i < band.size(); ++i) {
            const double mu = band.mu[i];
            num += mu * (u[long(i)] - exact[long(i)]) * (u[long(i)] - exact[long(i)]);
            den += mu * exact[long(i)] * exact[long(i)];
        }
        out.push_back(std::sqrt(num / den));
    }
    return out;
}

TEST_CASE("validation: where T's stencils change across the domain, the Poisson solution still converges at order 2", "[validation]") {
    // A tensor of anisotropy 4 whose axes rotate with x: Selling's superbase changes between voxels, and its
    // weights are Lipschitz but not smooth there, so Eq. 24 is consistent only in the weak (energy) sense: the
    // pointwise error of M⁻¹ L f converges slowly (measured: relative errors 0.151, 0.057, 0.030, orders 1.4 and
    // 0.95), while the solution of L u = M g converges at order 2 (measured 2.05, 2.02): the scheme converges
    // (Fehrenbach–Mirebeau 2014) although it is not pointwise consistent where stencils change.
    SmoothCase c;
    c.mu = muTest;
    c.T = [](const Vec3d& x) -> Mat3d {
        const Mat3d R = Eigen::AngleAxisd(1.2 * x.x() + 0.8 * x.y(), Vec3d(1, 2, 2).normalized()).toRotationMatrix();
        return muTest(x) * R * Vec3d(1.0, 1.0 / 16.0, 0.25).asDiagonal() * R.transpose();
    };
    // u* = B f with B = (1 − |x|²/R²)⁴ inside R = 0.8: three continuous derivatives, zero near the band's edge.
    constexpr double R2 = 0.64;
    c.f = [](const Vec3d& x) {
        const double q = 1 - x.squaredNorm() / R2;
        return q > 0 ? std::pow(q, 4) * fTest(x) : 0.0;
    };
    c.gradF = [](const Vec3d& x) -> Vec3d {
        const double q = 1 - x.squaredNorm() / R2;
        if (q <= 0) return Vec3d::Zero();
        return std::pow(q, 4) * gradFTest(x) - (8 * std::pow(q, 3) / R2) * fTest(x) * x;
    };
    const std::vector<double> pointwise = errors(c, 0.1, 3);
    const std::vector<double> e = poissonErrors(c, 0.1, 3);
    const double order1 = std::log2(e[0] / e[1]), order2 = std::log2(e[1] / e[2]);
    INFO("pointwise M^-1 L f errors " << pointwise[0] << ", " << pointwise[1] << ", " << pointwise[2]);
    INFO("solution errors " << e[0] << ", " << e[1] << ", " << e[2] << ": orders " << order1 << ", " << order2);
    CHECK(e[2] < e[1]);
    CHECK(order2 > 1.7);
}

TEST_CASE("validation: the expected Dirichlet energy of x on the unit sphere tends to 8 pi / 3 as sigma falls, and the naive form does not",
          "[validation]") {
    // 1280-triangle sphere at the paper's resolution h = h* (Eq. 25) and η = 1e-6: u = 0 outside the band adds
    // Σ_boundary h λ u², which grows like η/h for a u that is not small at the band's edge (docs/operators.md).
    // Measured (bench/results/energy.json): L +13.1%, +1.37%, −0.72%, −0.67%; the naive D_φ G_φ reaches +330% at
    // σ_rel = 0.1, where T is most anisotropic and forward differences along the axes leave the thin band.
    const TriangleSoup soup = icosphere(3);
    double previous = 1e300, lastL = 0, lastNaive = 0;
    for (double sigma : {1.0, 0.5, 0.25, 0.1}) {
        const SoupSamples ss = soupSamples(soup, {sigma});
        const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
        BandOptions o;
        o.voxelSize = chooseResolution(model, ss.samples).hStar;
        o.etaRelative = 1e-6;
        const Band band = buildBand(model, ss.samples, o).band;
        std::vector<float> f(band.size()), Lf, Kf;
        for (std::size_t i = 0; i < band.size(); ++i) f[i] = float(band.voxelSize * band.coord[i].x());
        LaplacianOperator(band).apply(f, Lf);
        NaiveLaplacianOperator(band).apply(f, Kf);
        lastL = test::dot(f, Lf) / (8 * M_PI / 3) - 1;
        lastNaive = test::dot(f, Kf) / (8 * M_PI / 3) - 1;
        INFO("sigma_rel " << sigma << ", h " << band.voxelSize << ", " << band.size() << " voxels: L " << lastL << ", naive " << lastNaive);
        CHECK(std::abs(lastL) < previous);
        previous = std::abs(lastL);
    }
    CHECK(std::abs(lastL) < 0.05);
    CHECK(lastNaive > 10 * std::abs(lastL));
}

TEST_CASE("validation: a sphere scanned at 1e3, 1e4 and 1e5 points gives the same area, energy, l = 1 modes and path", "[validation]") {
    // The density independence a scan user relies on (docs/math.md#smoothing): unit-sphere clouds with the same noise
    // in world units (σ = 0.05 per point), 10× and 100× denser, at the same voxel size, with a band wide enough
    // (η = 1e-6) that u = 0 beyond it costs nothing (docs/operators.md). The kernel's s follows the noise (1.2 σ), so
    // the expected surface is the same; what changes is how well the samples average the noise: μ's width falls from
    // 0.020 to 0.013. At 1e4 and 1e5 points s > ℓ, and the model sums the points merged into dipoles at cells of s
    // (docs/math.md#merging). Measured (area, energy of x, l = 1 gap, path): 12.570, 8.403, 1.980, 3.316 at 1e3 points;
    // 12.474, 8.330, 1.974, 3.333 at 1e4; 12.462, 8.318, 1.972, 3.371 at 1e5 (4π, 8π/3, 2/r², π). The path runs
    // through voxel centres, 6–7 % longer than π at h = 0.04, and feels the band's thickness (27 % more at 1e3 points;
    // unmerged, the 1e3-point path was 3 % shorter than at 1e4), so it is compared from 1e4 on.
    struct Figures {
        double area, energy, gap, path;
    };
    std::vector<Figures> at;
    std::ostringstream log;
    for (int n : {1000, 10000, 100000}) {
        const LoadedModel m = loadModel(test::sphereCloudWithSigma(n, 0.05, 11));
        REQUIRE(m.smoothingSource == SmoothingSource::Noise);
        BandOptions o;
        o.voxelSize = 0.04;
        o.etaRelative = 1e-6;
        const Band band = buildBand(*m.model, m.input.samples, o).band;
        std::vector<float> f(band.size()), Lf;
        for (std::size_t i = 0; i < band.size(); ++i) f[i] = float(band.voxelSize * band.coord[i].x());
        LaplacianOperator(band).apply(f, Lf);
        EigenOptions eo;
        eo.count = 4;
        const EigenResult e = spectrum(band, eo);
        const GeodesicResult path = geodesicDistance(band, {Vec3d(0, 0, 1)}, {Vec3d(0, 0, -1)});
        REQUIRE(path.paths.at(0).reachedSource);
        at.push_back({band.mass(), test::dot(f, Lf), (e.values[1] + e.values[2] + e.values[3]) / 3 - e.values[0], path.paths[0].length});
        log << n << " points: " << band.size() << " voxels, area " << at.back().area << ", energy of x " << at.back().energy << ", lambda "
            << e.values.transpose() << ", l = 1 gap " << at.back().gap << ", path " << at.back().path << "\n";
    }
    INFO(log.str());
    for (std::size_t k = 1; k < at.size(); ++k) {
        CHECK(at[k].area == Approx(at[0].area).epsilon(0.02));
        CHECK(at[k].energy == Approx(at[0].energy).epsilon(0.02));
        CHECK(at[k].gap == Approx(at[0].gap).epsilon(0.02));
    }
    CHECK(at[2].path == Approx(at[1].path).epsilon(0.02));
    // and against the sphere's own figures: 4π, 8π/3, 2/r², π (the path through voxel centres)
    CHECK(at[2].area == Approx(4 * M_PI).epsilon(0.02));
    CHECK(at[2].energy == Approx(8 * M_PI / 3).epsilon(0.02));
    CHECK(at[2].gap == Approx(2.0).epsilon(0.03));
    CHECK(at[2].path == Approx(M_PI).epsilon(0.1));
}
