#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <tuple>
#include <vector>

#include <Eigen/Eigenvalues>
#include "gpisvdb/input/procedural.h"

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

/// E[‖X‖ sin²θ] for X ~ N(m, s² I₃), θ the angle between X and m. With λ = ‖m‖/s, X = s R ω and
/// ∫₋₁¹ (1 − t²) e^{κt} dt = 4(cosh κ − sinh κ/κ)/κ² (κ = λR), the radial integral is elementary:
///   E[‖X‖ sin²θ] = (4 s/λ²) [ϕ(λ) + ½ erf(λ/√2) (λ − 1/λ)],  ϕ the standard normal density,
/// which tends to (2/3) E‖X‖ = (4/3) s √(2/π) as λ → 0 (isotropy).
double nonCentralChiSin2(double m, double s) {
    const double l = m / s;
    if (l < 1e-3) return s * 4.0 / 3.0 * std::sqrt(2.0 / M_PI);
    const double phi = std::exp(-0.5 * l * l) / std::sqrt(2 * M_PI);
    return s * 4.0 / (l * l) * (phi + 0.5 * std::erf(l / std::sqrt(2.0)) * (l - 1.0 / l));
}

/// μ and T for a conditioned gradient X ~ N(m, s² I) and value density p, in closed form: with n = m/‖m‖,
/// E[‖X‖ I − X Xᵀ/‖X‖] = J n nᵀ + (E‖X‖ − J/2)(I − n nᵀ), J = E[‖X‖ sin²θ] (the component across n averages
/// sin²θ cos²ψ over the azimuth ψ: half of sin²θ).
std::pair<double, Mat3d> isotropicClosedForm(const Vec3d& m, double s, double p) {
    const double chi = nonCentralChiMean(m.norm(), s), J = nonCentralChiSin2(m.norm(), s);
    const Vec3d n = m.norm() > 0 ? Vec3d(m.normalized()) : Vec3d::UnitX();
    const Mat3d P = Mat3d::Identity() - n * n.transpose();
    return {p * chi, p * (J * n * n.transpose() + (chi - J / 2) * P)};
}

/// A Gaussian (φ, ∇φ) ~ N((γ, g), C) whose gradient, conditioned on φ = u, is N(g + c (u − γ)/c₀₀, s² I):
/// cross-covariance c, C_gg = s² I + c cᵀ/c₀₀ (c = 0: φ independent of ∇φ).
ValueGradient isotropicGiven(const Vec3d& g, double s, double gamma, double c00, const Vec3d& c = Vec3d::Zero()) {
    ValueGradient z;
    z.mean << gamma, g;
    z.cov(0, 0) = c00;
    z.cov.block<3, 1>(1, 0) = c;
    z.cov.block<1, 3>(0, 1) = c.transpose();
    z.cov.bottomRightCorner<3, 3>() = s * s * Mat3d::Identity() + c * c.transpose() / c00;
    return z;
}

/// Plain Monte Carlo of μ and T for (φ, ∇φ) = mean + A w, w ~ N(0, I_k), by a route of its own: φ = u fixes
/// a₀ · w (a₀ = A's first row), so w given φ = u is a₀ (u − γ)/‖a₀‖² plus w projected off a₀ (works for any
/// rank). Returns the estimates and their standard errors (μ, then T's xx, yy, zz, xy, xz, yz).
struct MonteCarlo {
    double mu = 0, muError = 0;
    Mat3d T = Mat3d::Zero(), TError = Mat3d::Zero();
};
MonteCarlo monteCarlo(const Vec4d& mean, const Eigen::MatrixXd& A, double u, int n, std::uint64_t seed) {
    const Eigen::VectorXd a0 = A.row(0).transpose();
    const double var = a0.squaredNorm();
    const double p = std::exp(-0.5 * (u - mean[0]) * (u - mean[0]) / var) / std::sqrt(2 * M_PI * var);
    const Eigen::VectorXd w0 = a0 * ((u - mean[0]) / var);
    const Eigen::MatrixXd Ag = A.bottomRows(3);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> N01;
    Eigen::VectorXd w(A.cols());
    double s1 = 0, s2 = 0;
    Mat3d t1 = Mat3d::Zero(), t2 = Mat3d::Zero();
    for (int i = 0; i < n; ++i) {
        for (int k = 0; k < w.size(); ++k) w[k] = N01(rng);
        w += w0 - a0 * (a0.dot(w) / var);
        const Vec3d X = mean.tail<3>() + Ag * w;
        const double r = X.norm();
        const Mat3d t = r * Mat3d::Identity() - X * X.transpose() / r;
        s1 += r, s2 += r * r;
        t1 += t, t2 += t.cwiseProduct(t);
    }
    MonteCarlo mc;
    mc.mu = p * s1 / n;
    mc.muError = p * std::sqrt((s2 / n - (s1 / n) * (s1 / n)) / n);
    mc.T = p * t1 / n;
    mc.TError = p * ((t2 / n - (t1 / n).cwiseProduct(t1 / n)) / n).cwiseSqrt();
    return mc;
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

TEST_CASE("kacrice: mu and T match the chi and non-central chi closed forms for an isotropic conditioned gradient", "[kacrice]") {
    // X = ∇φ | φ = u ~ N(m, s² I): μ = p E‖X‖, T = p [J n nᵀ + (E‖X‖ − J/2)(I − n nᵀ)] (closed forms above).
    // With a cross-covariance c, m = g + c (u − γ)/c₀₀ ≠ g and C_gg = s² I + c cᵀ/c₀₀ is anisotropic: only the
    // conditioned Gaussian is isotropic, so the closed form holds only if the code conditions mean and covariance.
    // QMC error, measured over these cases: ≤ 2.1e-3 μ (μ) and ≤ 2.7e-3 μ (‖T‖_F) at S = 512, ≤ 1.1e-4 μ and
    // ≤ 1.5e-4 μ at S = 8192 (falling as 1/S: the closed forms are right). S = 8192, bound 1e-3 μ.
    const QmcRule rule(8192);
    const double u = 0.5, gamma = 0.4, c00 = 0.04;
    const double p = std::exp(-0.5 * (u - gamma) * (u - gamma) / c00) / std::sqrt(2 * M_PI * c00);
    const Vec3d dir = Vec3d(1, 2, -2) / 3;
    for (const Vec3d& c : {Vec3d(0, 0, 0), Vec3d(0.1, -0.05, 0.15)})
        for (double s : {1.0, 0.4})
            for (double g : {0.0, 0.3, 1.0, 3.0, 10.0}) {
                const ValueGradient z = isotropicGiven(g * dir, s, gamma, c00, c);
                const Vec3d m = g * dir + c * (u - gamma) / c00;
                const auto [mu, T] = isotropicClosedForm(m, s, p);
                const SurfaceDensity d = kacRice(z, u, rule);
                INFO("c = " << c.transpose() << ", s = " << s << ", |g| = " << g << ", mu " << d.mu << " vs " << mu << ", T\n"
                            << d.T << "\nvs\n"
                            << T);
                CHECK(d.density == Approx(p).epsilon(1e-12));
                CHECK((d.meanGradient - m).norm() <= 1e-12 * (1 + m.norm()));
                CHECK(std::abs(d.mu - mu) <= 1e-3 * mu);
                CHECK((d.T - T).norm() <= 1e-3 * mu);
            }
}

TEST_CASE("kacrice: mu and T match a plain Monte Carlo for correlated, anisotropic (phi, grad phi)", "[kacrice]") {
    // (φ, ∇φ) = mean + A w with a full cross-covariance between φ and ∇φ; the code's conditioned Σ is anisotropic
    // (third case: rank 2, ∂xφ a function of φ). 1e6 samples; every estimate within 4 standard errors. The code
    // runs S = 2^16 QMC points so its own error (measured against S = 2^20: ≤ 0.04 standard errors) does not use
    // up the bound; measured deviations ≤ 2 standard errors.
    const QmcRule rule(1 << 16);
    Eigen::MatrixXd A1(4, 4), A2(4, 4), A3(4, 3);
    A1 << 0.20, 0.00, 0.00, 0.00,  //
        0.50, 0.80, 0.00, 0.00,    //
        -0.30, 0.20, 0.30, 0.00,   //
        0.40, -0.10, 0.50, 1.20;
    A2 << 0.15, 0.05, 0.00, -0.10,  //
        1.00, 0.10, 0.05, 0.00,     //
        0.20, 0.00, 0.10, 0.05,     //
        -0.60, 0.30, 0.00, 0.40;
    A3 << 0.30, 0.00, 0.00,  //
        0.90, 0.00, 0.00,    // ∂xφ = 3 (φ − γ) + const: known exactly once φ = u
        0.10, 0.50, 0.20,    //
        0.00, -0.20, 0.70;
    const std::vector<std::tuple<Vec4d, Eigen::MatrixXd, double>> cases = {
        {Vec4d(0.45, 0.3, -0.2, 0.1), A1, 0.5}, {Vec4d(0.6, -2.0, 1.0, 0.5), A2, 0.5}, {Vec4d(0.3, 0.2, 0.0, -0.4), A3, 0.5}};
    std::uint64_t seed = 11;
    for (const auto& [mean, A, u] : cases) {
        ValueGradient z;
        z.mean = mean;
        z.cov = A * A.transpose();
        const SurfaceDensity d = kacRice(z, u, rule);
        const MonteCarlo mc = monteCarlo(mean, A, u, 1000000, seed++);
        INFO("case " << seed - 11 << ": mu " << d.mu << " vs MC " << mc.mu << " +- " << mc.muError << "\nT\n"
                     << d.T << "\nvs MC\n"
                     << mc.T << "\n+-\n"
                     << mc.TError);
        CHECK(std::abs(d.mu - mc.mu) <= 4 * mc.muError);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) CHECK(std::abs(d.T(i, j) - mc.T(i, j)) <= 4 * mc.TError(i, j));
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

TEST_CASE("kacrice: the SIMD sums equal the plain loop over the QMC points", "[kacrice]") {
    // kacRice runs the expectations 8 points at a time with per-lane partial sums; kacRiceReference is the loop
    // the lanes replaced. Random correlated Gaussians, rules whose size is and is not a multiple of 8.
    std::mt19937_64 rng(42);
    std::normal_distribution<double> n;
    for (int S : {1, 7, 64, 100, 512}) {
        const QmcRule rule(S);
        for (int trial = 0; trial < 200; ++trial) {
            Eigen::Matrix4d A;
            for (int i = 0; i < 16; ++i) A.data()[i] = n(rng);
            ValueGradient z;
            z.cov = A * A.transpose() * std::pow(10.0, n(rng));
            z.mean << 0.5 + 0.5 * n(rng), n(rng), n(rng), n(rng);
            const SurfaceDensity a = kacRice(z, 0.5, rule), b = kacRiceReference(z, 0.5, rule);
            INFO("S = " << S << ", trial " << trial);
            REQUIRE(b.mu > 0);
            CHECK(std::abs(a.mu - b.mu) <= 1e-12 * b.mu);
            CHECK((a.T - b.T).norm() <= 1e-12 * b.T.norm());
            CHECK(a.density == b.density);
            CHECK(a.meanGradient == b.meanGradient);
        }
    }
}

TEST_CASE("kacrice: the SIMD sums equal the plain loop at lengths scaled by 1e-6 and 1e6", "[kacrice]") {
    // With AVX-512 the lanes take 1/‖X‖ by Newton's iteration from the exponent bits: it must hold over the whole
    // range of doubles a scaled input reaches. Lengths × k scale ∇φ by 1/k: the gradient's mean by 1/k, its covariance
    // with φ by 1/k and its own by 1/k²; a conditioned gradient that is exactly its mean (Σ = 0) is included.
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n;
    const QmcRule rule(512);
    for (double k : {1e-6, 1e-3, 1.0, 1e3, 1e6}) {
        for (int trial = 0; trial < 50; ++trial) {
            Eigen::Matrix4d A;
            for (int i = 0; i < 16; ++i) A.data()[i] = n(rng);
            ValueGradient z;
            z.cov = A * A.transpose();
            if (trial == 0) z.cov.setZero(), z.cov(0, 0) = 0.1;  // Σ = 0: every point X = m
            z.mean << 0.5 + 0.5 * n(rng), n(rng), n(rng), n(rng);
            Eigen::Vector4d scale(1.0, 1.0 / k, 1.0 / k, 1.0 / k);
            z.mean = z.mean.cwiseProduct(scale);
            z.cov = scale.asDiagonal() * z.cov * scale.asDiagonal();
            const SurfaceDensity a = kacRice(z, 0.5, rule), b = kacRiceReference(z, 0.5, rule);
            INFO("lengths x " << k << ", trial " << trial);
            REQUIRE(b.mu > 0);
            REQUIRE(std::isfinite(a.mu));
            CHECK(std::abs(a.mu - b.mu) <= 1e-12 * b.mu);
            CHECK((a.T - b.T).norm() <= 1e-12 * b.T.norm() + 1e-15 * b.mu);
        }
    }
}
