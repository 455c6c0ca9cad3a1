#include <catch2/catch.hpp>
#include <cmath>
#include <Eigen/Eigenvalues>
#include <vector>

#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/kac_rice_column.h"

using namespace gpisvdb;

namespace {

double Phi(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }
double pdf(double x) { return std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI); }

/// The winding number's profile across a plane of unit normal n: γ = Φ(−d/s) at signed distance d, with φ's std v and
/// an isotropic gradient noise of std g (uncorrelated): what a closed surface's mean looks like near it.
ValueGradient probitPlane(const Vec3d& n, double d, double s, double v, double g) {
    ValueGradient z;
    z.mean << Phi(-d / s), -pdf(-d / s) / s * n;
    z.cov(0, 0) = v * v;
    z.cov.block<3, 3>(1, 1) = g * g * Mat3d::Identity();
    return z;
}

/// μ summed down a column of voxels along z (centres k h, k = −K…K) by column values, × h: the expected area per unit
/// cross-section, for the plane z = z0.
double columnSum(double z0, double h, double s, double v, double g, const QmcRule& rule, MeanScale scale) {
    const int K = int(std::ceil(6 * s / h)) + 2;
    std::vector<ValueGradient> z;
    for (int k = -K - 1; k <= K + 1; ++k) z.push_back(probitPlane(Vec3d::UnitZ(), k * h - z0, s, v, g));
    double sum = 0;
    for (int k = -K; k <= K; ++k) {
        const std::size_t i = std::size_t(k + K + 1);
        ColumnGaussians c;
        c.centre = &z[i];
        // the plane does not change along x and y: the neighbours there are the centre itself
        c.neighbour = {&z[i], &z[i], &z[i], &z[i], &z[i - 1], &z[i + 1]};
        sum += h * kacRiceColumn(c, 0.5, scale, rule).mu;
    }
    return sum;
}

/// ∫ μ dz across the same plane by the centres' values on a fine lattice: the reference.
double fineIntegral(double s, double v, double g, const QmcRule& rule) {
    const double dz = s / 200;
    double sum = 0;
    for (double z = -8 * s; z <= 8 * s; z += dz) sum += dz * kacRice(probitPlane(Vec3d::UnitZ(), z, s, v, g), 0.5, rule).mu;
    return sum;
}

}  // namespace

TEST_CASE("kac_rice_column: the probit interpolation reproduces the winding number's profile between two centres", "[kacrice]") {
    const Vec3d n = Vec3d(1, 2, 2) / 3;
    for (double s : {1e-6, 1.0, 1e6}) {
        const ValueGradient a = probitPlane(n, -1.7 * s, s, 0.1, 0.2 / s), b = probitPlane(n, 2.4 * s, s, 0.3, 0.1 / s);
        for (double lambda : {0.0, 0.2, 0.5, 0.9, 1.0}) {
            const double d = (1 - lambda) * -1.7 * s + lambda * 2.4 * s;
            const ValueGradient exact = probitPlane(n, d, s, 0.1, 0.2 / s);
            const ValueGradient z = interpolateGaussian(a, b, lambda, MeanScale::Probit);
            INFO("s " << s << ", lambda " << lambda);
            CHECK(z.mean[0] == Approx(exact.mean[0]).epsilon(1e-10));
            CHECK((z.mean.tail<3>() - exact.mean.tail<3>()).norm() <= 1e-9 * exact.mean.tail<3>().norm());
            CHECK(z.cov(0, 0) == Approx((1 - lambda) * 0.01 + lambda * 0.09).epsilon(1e-12));
            // the linear scale blends the means, which misplaces the crossing of a steep profile
            if (lambda == 0.5) CHECK(std::abs(interpolateGaussian(a, b, lambda, MeanScale::Linear).mean[0] - exact.mean[0]) > 0.01);
        }
    }
}

TEST_CASE("kac_rice_column: a column of voxels much coarser than mu's width sums to the plane's expected area wherever it falls",
          "[kacrice]") {
    // μ's width w_μ = √c₀₀ / ‖∇γ‖ (stencil/resolution.h) is 2.5 v s at the crossing: 0.125 s. At voxels of 4 and 8
    // w_μ the centres' values depend on where the plane falls, the columns' do not.
    const QmcRule rule(512);
    const double s = 1.0, v = 0.05, g = 0.1, width = 2.5 * v * s;
    const double exact = fineIntegral(s, v, g, rule);
    for (double ratio : {4.0, 8.0}) {
        const double h = ratio * width;
        double worstPoint = 0;
        for (double offset : {0.0, 0.13, 0.31, 0.5}) {
            const double z0 = offset * h;
            const double column = columnSum(z0, h, s, v, g, rule, MeanScale::Probit);
            double point = 0;
            for (int k = -40; k <= 40; ++k) point += h * kacRice(probitPlane(Vec3d::UnitZ(), k * h - z0, s, v, g), 0.5, rule).mu;
            worstPoint = std::max(worstPoint, std::abs(point / exact - 1));
            INFO("h = " << ratio << " w_mu, plane at " << offset << " h: columns " << column << ", centres " << point << ", fine "
                        << exact);
            CHECK(column == Approx(exact).epsilon(0.005));
        }
        CHECK(worstPoint > 0.1);  // the centres miss the shell
    }
}

TEST_CASE("kac_rice_column: equals the centre's value where the voxel is small against mu's width, with tr T = 2 mu", "[kacrice]") {
    const QmcRule rule(512);
    const Vec3d n = Vec3d(2, -1, 2) / 3;
    const double s = 1.0, h = 0.02;
    const auto at = [&](const Vec3d& x) { return probitPlane(n, x.dot(n) - 0.05, s, 0.2, 0.3); };
    const ValueGradient centre = at(Vec3d::Zero());
    std::vector<ValueGradient> nb;
    for (int a = 0; a < 3; ++a)
        for (int side : {-1, 1}) nb.push_back(at(side * h * Vec3d::Unit(a)));
    ColumnGaussians c;
    c.centre = &centre;
    for (std::size_t k = 0; k < 6; ++k) c.neighbour[k] = &nb[k];
    const SurfaceDensity col = kacRiceColumn(c, 0.5, MeanScale::Probit, rule), point = kacRice(centre, 0.5, rule);
    CHECK(col.mu == Approx(point.mu).epsilon(1e-3));
    CHECK((col.T - point.T).norm() <= 1e-3 * point.T.norm());
    CHECK(col.T.trace() == Approx(2 * col.mu).epsilon(1e-12));
    CHECK((col.T - col.T.transpose()).norm() <= 1e-15 * col.T.norm());
    CHECK(Eigen::SelfAdjointEigenSolver<Mat3d>(col.T).eigenvalues().minCoeff() >= -1e-12 * col.mu);
    CHECK(col.density == Approx(point.density).epsilon(1e-14));
    CHECK((col.meanGradient - point.meanGradient).norm() <= 1e-14 * point.meanGradient.norm());
}
