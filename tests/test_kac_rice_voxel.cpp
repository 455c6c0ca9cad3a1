#include <catch2/catch.hpp>
#include <cmath>
#include <Eigen/Eigenvalues>
#include <random>
#include <vector>

#include "gpisvdb/kacrice/box_gaussian.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/kac_rice_voxel.h"

using namespace gpisvdb;

namespace {

/// A Gaussian (φ, ∇φ) for a plane of unit normal n at signed distance d from the point, gradient k n:
/// φ's std k·w (w: μ's width in world units), an isotropic gradient noise of std g·k, their correlation rho.
ValueGradient planeGaussian(const Vec3d& n, double d, double k, double w, double g, double rho) {
    ValueGradient z;
    z.mean << 0.5 - k * d, k * n;
    z.cov(0, 0) = k * k * w * w;
    z.cov.block<3, 3>(1, 1) = g * g * k * k * Mat3d::Identity();
    z.cov(0, 1) = z.cov(1, 0) = rho * (k * w) * (g * k);
    return z;
}

/// The Gaussian of the field linearised at offset y from where z was evaluated: (φ₀ + g·y, g).
ValueGradient shifted(const ValueGradient& z, const Vec3d& y) {
    Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
    A.block<1, 3>(0, 1) = y.transpose();
    ValueGradient s;
    s.mean = A * z.mean;
    s.cov = A * z.cov * A.transpose();
    return s;
}

}  // namespace

TEST_CASE("box gaussian: equals the midpoint sum over its uniforms, whichever widths vanish", "[kacrice]") {
    struct Case {
        double x, a, b, c, s;
    };
    for (const Case& k : {Case{0.1, 1, 0.5, 0.2, 0.3}, Case{0.4, 1, 0.5, 0.2, 0.05}, Case{0.3, 1, 1e-7, 0, 0.2},
                          Case{-0.7, 0.8, 0.8, 0.8, 0.1}, Case{0.2, 0, 0, 0, 0.1}, Case{1.1, 1, 0.5, 0.2, 0.2}}) {
        INFO("x " << k.x << " widths " << k.a << " " << k.b << " " << k.c << " s " << k.s);
        CHECK(boxGaussianDensity(k.x, k.a, k.b, k.c, k.s) ==
              Approx(boxGaussianDensityReference(k.x, k.a, k.b, k.c, k.s, 120)).epsilon(2e-3).margin(1e-9));
    }
    // s = 0: the box spline itself, exactly (a single uniform: 1/a inside, 0 outside)
    CHECK(boxGaussianDensity(0.3, 1, 0, 0, 0) == Approx(1.0));
    CHECK(boxGaussianDensity(0.6, 1, 0, 0, 0) == 0);
    // two equal uniforms: the triangle 1/a − |x|/a²
    CHECK(boxGaussianDensity(0.25, 1, 1, 0, 0) == Approx(0.75));
}

TEST_CASE("box gaussian: a density with mean 0 and variance s^2 + sum w^2 / 12, at scales 1e-6 and 1e6", "[kacrice]") {
    for (double scale : {1e-6, 1.0, 1e6}) {
        const double a = 0.9 * scale, b = 0.4 * scale, c = 0.25 * scale, s = 0.07 * scale;
        double m0 = 0, m2 = 0;
        const int n = 20000;
        const double lo = -1.5 * scale, dx = 3 * scale / n;
        for (int i = 0; i < n; ++i) {
            const double x = lo + (i + 0.5) * dx, p = boxGaussianDensity(x, a, b, c, s);
            m0 += p * dx, m2 += p * x * x * dx;
        }
        INFO("scale " << scale);
        CHECK(m0 == Approx(1).epsilon(1e-6));
        CHECK(m2 == Approx(s * s + (a * a + b * b + c * c) / 12).epsilon(1e-5));
    }
}

TEST_CASE("box gaussian: the batched densities equal the scalar ones", "[kacrice]") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<double> x, a, b, c, out(5000);
    for (int i = 0; i < 5000; ++i) {
        x.push_back(1.5 * u(rng)), a.push_back(u(rng)), b.push_back(i % 3 ? u(rng) : 1e-9), c.push_back(i % 5 ? u(rng) : 0);
    }
    for (double s : {0.0, 1e-3, 0.2}) {
        boxGaussianDensities(x.size(), x.data(), a.data(), b.data(), c.data(), s, out.data());
        for (std::size_t i = 0; i < x.size(); ++i) {
            const double ref = boxGaussianDensity(x[i], a[i], b[i], c[i], s);
            INFO("s " << s << " i " << i);
            REQUIRE(out[i] == Approx(ref).epsilon(1e-6).margin(1e-9));
        }
    }
}

TEST_CASE("voxel kac-rice: tends to the point value as h shrinks, and tr T = 2 mu with T symmetric PSD", "[kacrice]") {
    const QmcRule rule(4096);
    const Vec3d n = Vec3d(0.3, 0.5, 0.81).normalized();
    for (double rho : {0.0, 0.5, 0.9})
        for (double d : {0.0, 0.01, -0.02}) {
            const ValueGradient z = planeGaussian(n, d, 3.0, 0.01, 0.25, rho);
            const SurfaceDensity p = kacRice(z, 0.5, rule);
            const SurfaceDensity v = kacRiceVoxel(z, 0.5, 1e-5, rule);
            INFO("rho " << rho << " d " << d);
            CHECK(v.mu == Approx(p.mu).epsilon(2e-3));
            CHECK((v.T - p.T).norm() <= 2e-3 * p.T.norm());
            CHECK(v.density == p.density);
            CHECK(v.meanGradient == p.meanGradient);
            for (double h : {0.005, 0.02, 0.1}) {
                const SurfaceDensity c = kacRiceVoxel(z, 0.5, h, rule);
                CHECK(c.T.trace() == Approx(2 * c.mu).epsilon(1e-12));
                CHECK((c.T - c.T.transpose()).norm() == 0);
                CHECK(Eigen::SelfAdjointEigenSolver<Mat3d>(c.T).eigenvalues().minCoeff() >= -1e-12 * c.mu);
            }
        }
}

TEST_CASE("voxel kac-rice: is the mean over the cube of the linearised field's point values", "[kacrice]") {
    // An independent route: Kac–Rice at the points of a 24³ midpoint grid of the cube, each for the Gaussian of
    // (φ₀ + g·y, g), averaged. Errors: the grid's (μ's width is ≥ 4 cells across) and the two QMC rules'.
    const QmcRule rule(1024);
    const Vec3d n = Vec3d(0.2, -0.6, 0.77).normalized();
    for (double hw : {0.5, 2.0, 6.0}) {
        const double w = 0.01, h = hw * w;
        const ValueGradient z = planeGaussian(n, 0.3 * h, 3.0, w, 0.3, 0.6);
        const int m = 24;
        double mu = 0;
        Mat3d T = Mat3d::Zero();
        for (int i = 0; i < m; ++i)
            for (int j = 0; j < m; ++j)
                for (int l = 0; l < m; ++l) {
                    const Vec3d y = h * (Vec3d(i, j, l).array() + 0.5).matrix() / m - Vec3d::Constant(0.5 * h);
                    const SurfaceDensity p = kacRice(shifted(z, y), 0.5, rule);
                    mu += p.mu, T += p.T;
                }
        mu /= m * m * m, T /= m * m * m;
        const SurfaceDensity v = kacRiceVoxel(z, 0.5, h, rule);
        INFO("h / w " << hw << ": voxel " << v.mu << ", cube mean " << mu);
        CHECK(v.mu == Approx(mu).epsilon(5e-3));
        CHECK((v.T - T).norm() <= 5e-3 * T.norm());
    }
}

TEST_CASE("voxel kac-rice: the voxels a plane crosses sum to its expected area at any h, where point values do not", "[kacrice]") {
    // A column of 4 × 4 lattice lines across the plane (every voxel the band could hold): the cubes' cross-sections
    // tile the plane, so Σ μ_h h³ is the column's expected area whatever h. The reference: point values at h = w/4.
    const QmcRule rule(256);
    const Vec3d n = Vec3d(0.3, 0.5, 0.81).normalized();
    const double w = 0.01, k = 3.0;
    const auto columnArea = [&](double h, bool voxel) {
        const int M = 4, K = int(std::ceil((8 * w + 2 * M * h) / (h * n.z()))) + 4;
        double sum = 0;
        for (int i = 0; i < M; ++i)
            for (int j = 0; j < M; ++j)
                for (int l = -K; l <= K; ++l) {
                    const Vec3d x(h * i, h * j, h * l);
                    const ValueGradient z = planeGaussian(n, n.dot(x) - 0.0123, k, w, 0.2, 0.3);
                    sum += (voxel ? kacRiceVoxel(z, 0.5, h, rule).mu : kacRice(z, 0.5, rule).mu) * h * h * h;
                }
        return sum / (M * M * h * h / n.z());  // per unit of the plane's area
    };
    const double reference = columnArea(0.25 * w, false);
    CHECK(reference == Approx(1.04).epsilon(0.01));  // E‖g‖/‖E g‖ for a 20 % gradient noise
    double worstPoint = 0;
    for (double hw : {0.5, 2.0, 4.0, 8.0, 16.0}) {
        const double voxel = columnArea(hw * w, true), point = columnArea(hw * w, false);
        INFO("h / w " << hw << ": voxel " << voxel << ", point " << point << ", reference " << reference);
        CHECK(voxel == Approx(reference).epsilon(2e-3));
        worstPoint = std::max(worstPoint, std::abs(point / reference - 1));
    }
    CHECK(worstPoint > 0.01);  // the point values' sum misses by more than 1 % somewhere: what voxel values fix
}

TEST_CASE("voxel kac-rice: a point without uncertainty has no density", "[kacrice]") {
    ValueGradient z;
    z.mean << 0.5, 1, 0, 0;
    const SurfaceDensity v = kacRiceVoxel(z, 0.5, 0.1, QmcRule(64));
    CHECK(v.mu == 0);
    CHECK(v.T.norm() == 0);
}
