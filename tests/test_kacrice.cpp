#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "gpisvdb/input/procedural.h"
#include <Eigen/Eigenvalues>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

/// E‖X‖ for X ~ N(m, s² I₃): the mean of the non-central chi distribution with 3 degrees of freedom.
double nonCentralChiMean(double m, double s) {
    const double l = m / s;
    if (l < 1e-8) return s * 2.0 * std::sqrt(2.0 / M_PI);
    return s * (std::sqrt(2.0 / M_PI) * std::exp(-0.5 * l * l) + (l + 1.0 / l) * std::erf(l / std::sqrt(2.0)));
}

/// A Gaussian (φ, ∇φ) with φ independent of ∇φ ~ N(m, s² I): then μ = p(u) E‖X‖ in closed form.
ValueGradient isotropic(const Vec3d& m, double s, double gamma, double c00) {
    ValueGradient z;
    z.mean << gamma, m;
    z.cov(0, 0) = c00;
    z.cov.bottomRightCorner<3, 3>() = s * s * Mat3d::Identity();
    return z;
}

}  // namespace

TEST_CASE("kacrice: QMC points have zero mean and identity covariance", "[kacrice]") {
    const QmcRule rule(4096);
    Vec3d mean = Vec3d::Zero();
    Mat3d cov = Mat3d::Zero();
    for (const Vec3d& z : rule.points()) mean += z / rule.size(), cov += z * z.transpose() / rule.size();
    CHECK(mean.norm() < 1e-3);
    CHECK((cov - Mat3d::Identity()).norm() < 1e-2);
    CHECK(QmcRule(512).points() == QmcRule(512).points());  // deterministic
}

TEST_CASE("kacrice: mu matches the non-central chi closed form in the isotropic case", "[kacrice]") {
    const QmcRule rule(512);
    for (double m : {0.0, 0.3, 1.0, 3.0, 10.0}) {
        const double s = 1.0, gamma = 0.4, c00 = 0.04;
        const SurfaceDensity d = kacRice(isotropic(Vec3d(m, 0, 0), s, gamma, c00), 0.5, rule);
        const double p = std::exp(-0.5 * 0.01 / c00) / std::sqrt(2 * M_PI * c00);
        INFO("|m| = " << m);
        CHECK(d.density == Approx(p).epsilon(1e-12));
        CHECK(d.mu == Approx(p * nonCentralChiMean(m, s)).epsilon(1e-2));
    }
}

TEST_CASE("kacrice: tr T = 2 mu, T symmetric PSD, on a sphere soup's GPIS", "[kacrice]") {
    const Samples samples = soupSamples(icosphere(3), {0.5}).samples;
    const BarnesHutGpis model(samples, 0.4 * samples.lengthScale);
    const QmcRule rule(512);
    std::mt19937_64 rng(2);
    std::uniform_real_distribution<double> U(-1, 1);
    for (int i = 0; i < 300; ++i) {
        const Vec3d x = (1.0 + 2 * samples.lengthScale * U(rng)) * test::randomUnit(rng);
        const SurfaceDensity d = kacRice(model.evaluate(x), 0.5, rule);
        CHECK(d.mu >= 0);
        CHECK(std::abs(d.T.trace() - 2 * d.mu) <= 1e-5 * d.mu + 1e-300);
        CHECK((d.T - d.T.transpose()).norm() == 0);
        CHECK(Eigen::SelfAdjointEigenSolver<Mat3d>(d.T).eigenvalues().minCoeff() >= -1e-12 * d.mu);
    }
}

TEST_CASE("kacrice: S = 512 is within 1% of S = 8192 near the surface", "[kacrice]") {
    const Samples samples = soupSamples(icosphere(3), {0.5}).samples;
    const BarnesHutGpis model(samples, 0.4 * samples.lengthScale);
    const QmcRule coarse(512), fine(8192);
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> U(-1, 1);
    double muMax = 0;
    std::vector<std::pair<SurfaceDensity, SurfaceDensity>> pairs;
    for (int i = 0; i < 200; ++i) {
        const ValueGradient z = model.evaluate((1.0 + samples.lengthScale * U(rng)) * test::randomUnit(rng));
        pairs.emplace_back(kacRice(z, 0.5, coarse), kacRice(z, 0.5, fine));
        muMax = std::max(muMax, pairs.back().second.mu);
    }
    for (const auto& [a, b] : pairs) {
        CHECK(std::abs(a.mu - b.mu) <= 0.01 * b.mu + 1e-6 * muMax);
        CHECK((a.T - b.T).norm() <= 0.01 * b.T.norm() + 1e-6 * muMax);
    }
}

TEST_CASE("kacrice: a point without uncertainty has no density", "[kacrice]") {
    ValueGradient z;
    z.mean << 0.5, 1, 0, 0;
    const SurfaceDensity d = kacRice(z, 0.5, QmcRule(64));
    CHECK(d.mu == 0);
    CHECK(d.T.norm() == 0);
    CHECK_THROWS_AS(QmcRule(0), ParameterError);
}
