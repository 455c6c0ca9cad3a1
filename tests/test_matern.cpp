// Matérn kernels on the GPIS and Gaussian-process regression with them (tasks/matern.h).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <Eigen/Eigenvalues>
#include <limits>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/matern.h"
#include "gpisvdb/tasks/spectrum.h"

using namespace gpisvdb;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

const EigenResult& sphereSpectrum() {
    static const EigenResult r = [] {
        EigenOptions o;
        o.count = 60;
        return spectrum(test::sphereBand(), o);
    }();
    return r;
}

Vec3d centre(const Band& band, std::size_t i) { return band.voxelSize * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z()); }

/// The band voxel of largest μ on the ray from the origin along `direction` (within half a voxel of it): where
/// the ray meets the mean surface.
std::size_t surfaceVoxelAlong(const Band& band, const Vec3d& direction) {
    const Vec3d d = direction.normalized();
    std::size_t best = band.size();
    for (std::size_t i = 0; i < band.size(); ++i) {
        const Vec3d x = centre(band, i);
        if (x.dot(d) <= 0 || (x - x.dot(d) * d).norm() > 0.5 * band.voxelSize) continue;
        if (best == band.size() || band.mu[i] > band.mu[best]) best = i;
    }
    REQUIRE(best < band.size());
    return best;
}

/// Data at the surface voxels along directions, values f(direction), no noise.
PointData dataAlong(const Band& band, const std::vector<Vec3d>& directions, double (*f)(const Vec3d&)) {
    PointData d;
    for (const Vec3d& dir : directions) {
        d.position.push_back(centre(band, surfaceVoxelAlong(band, dir)));
        d.value.push_back(f(dir));
        d.noise.push_back(0);
    }
    return d;
}

std::vector<Vec3d> equator(int count) {
    std::vector<Vec3d> out;
    for (int i = 0; i < count; ++i) out.emplace_back(std::cos(2 * M_PI * i / count), std::sin(2 * M_PI * i / count), 0.0);
    return out;
}

double heightOf(const Vec3d& d) { return d.x() + 0.5 * d.y(); }

}  // namespace

TEST_CASE("matern: the kernel matrix is symmetric positive semi-definite for every smoothness", "[matern]") {
    const Band& band = test::sphereBand();
    const EigenResult& eig = sphereSpectrum();
    const double area = massVector(band).sum();
    std::vector<Vec3d> points;
    for (std::size_t i = 0; i < band.size(); i += band.size() / 40) points.push_back(centre(band, i) * 1.003);
    const Eigen::MatrixXd F = eigenFeatures(band, eig.vectors, points);
    for (double nu : {0.5, 1.5, 2.5, kInf}) {
        for (double kappa : {0.05, 0.3, 2.0}) {
            INFO("nu " << nu << " kappa " << kappa);
            MaternOptions o;
            o.nu = nu;
            o.kappa = kappa;
            const Eigen::VectorXd w = maternWeights(eig.values, area, o);
            CHECK((w.array() >= 0).all());
            CHECK(w.allFinite());
            // Mean prior variance a = 1: Σ w_i = a A (the u_i are M-orthonormal).
            CHECK(w.sum() == Approx(area).epsilon(1e-12));
            const Eigen::MatrixXd K = maternKernel(F, F, w);
            CHECK((K - K.transpose()).cwiseAbs().maxCoeff() <= 1e-12 * K.cwiseAbs().maxCoeff());
            const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(K);
            CHECK(es.eigenvalues().minCoeff() >= -1e-10 * es.eigenvalues().maxCoeff());
        }
    }
}

TEST_CASE("matern: rho_nu tends to rho_infinity as nu grows, smaller nu weighs high frequencies more", "[matern]") {
    const EigenResult& eig = sphereSpectrum();
    MaternOptions o;
    o.kappa = 0.4;
    o.nu = kInf;
    const Eigen::VectorXd wInf = maternWeights(eig.values, 10.0, o);
    o.nu = 1e7;
    CHECK((maternWeights(eig.values, 10.0, o) - wInf).cwiseAbs().maxCoeff() <= 1e-5 * wInf.maxCoeff());
    // The share of the highest mode falls as ν rises (rougher fields for small ν).
    double previous = 1;
    for (double nu : {0.5, 1.5, 2.5}) {
        o.nu = nu;
        const Eigen::VectorXd w = maternWeights(eig.values, 10.0, o);
        const double share = w(w.size() - 1) / w.sum();
        CHECK(share < previous);
        previous = share;
    }
    CHECK(wInf(wInf.size() - 1) / wInf.sum() < previous);
}

TEST_CASE("matern: weights refuse nu, kappa, amplitude <= 0 and never overflow", "[matern]") {
    const Eigen::VectorXd lambda = Eigen::VectorXd::LinSpaced(50, 1.0, 1e6);
    MaternOptions o;
    o.kappa = 1e3;  // exp(−κ²λ/2) underflows for all but the first: still finite
    o.nu = kInf;
    const Eigen::VectorXd w = maternWeights(lambda, 1.0, o);
    CHECK(w.allFinite());
    CHECK(w(0) == Approx(1.0));
    o.nu = 0;
    CHECK_THROWS_AS(maternWeights(lambda, 1.0, o), ParameterError);
    o.nu = 1.5;
    o.kappa = -1;
    CHECK_THROWS_WITH(maternWeights(lambda, 1.0, o), Catch::Contains("length scale"));
    o.kappa = 1;
    o.amplitude = 0;
    CHECK_THROWS_AS(maternWeights(lambda, 1.0, o), ParameterError);
}

TEST_CASE("matern: with zero noise the posterior mean interpolates the data and the variance vanishes there", "[matern]") {
    const Band& band = test::sphereBand();
    const EigenResult& eig = sphereSpectrum();
    const PointData data = dataAlong(band, equator(8), heightOf);
    for (double nu : {0.5, 1.5, 2.5, kInf}) {
        INFO("nu " << nu);
        RegressionOptions o;
        o.kernel.nu = nu;
        const RegressionResult r = gpRegression(band, eig, data, o);
        const double scale = r.amplitude;
        for (std::size_t j = 0; j < data.value.size(); ++j) {
            CHECK(r.meanAtData(Eigen::Index(j)) == Approx(data.value[j]).margin(1e-6));
            CHECK(r.varianceAtData(Eigen::Index(j)) <= 1e-6 * scale);
        }
        // The data sit at voxel centres: the band fields agree with the values at the data.
        for (std::size_t j = 0; j < data.value.size(); ++j) {
            const std::size_t i = surfaceVoxelAlong(band, equator(8)[j]);
            CHECK(r.mean[i] == Approx(data.value[j]).margin(1e-5));
        }
    }
}

TEST_CASE("matern: the variance is smallest at the data and grows away from it", "[matern]") {
    const Band& band = test::sphereBand();
    const EigenResult& eig = sphereSpectrum();
    const Vec3d at(1, 0, 0);
    const PointData data = dataAlong(band, {at}, heightOf);
    const RegressionResult r = gpRegression(band, eig, data);
    // Along the great circle from the data point, on the mean surface, out to a few length scales κ.
    double previous = -1;
    for (int step = 0; step <= 6; ++step) {
        const double angle = M_PI / 4 * step / 6;
        const std::size_t i = surfaceVoxelAlong(band, Vec3d(std::cos(angle), 0, std::sin(angle)));
        INFO("angle " << angle << " variance " << r.variance[i] << " kappa " << r.kappa);
        CHECK(r.variance[i] > previous);
        previous = r.variance[i];
    }
    // Over the whole surface (voxels of μ above half its peak), the least variance is at the data point.
    const float muPeak = *std::max_element(band.mu.begin(), band.mu.end());
    std::size_t least = band.size();
    for (std::size_t i = 0; i < band.size(); ++i)
        if (band.mu[i] > 0.5f * muPeak && (least == band.size() || r.variance[i] < r.variance[least])) least = i;
    CHECK((centre(band, least) - data.position[0]).norm() <= 1.01 * band.voxelSize);
}

TEST_CASE("matern: at equal distance from the data the variance is larger where mu is small (missing data)", "[matern]") {
    // A sphere with its cap above z = 0.6 missing: μ is small over the hole. Data on the equator; the poles are
    // equally far from it, one in the hole, one well sampled.
    const Band band = test::bandOf(cutAbove(icosphere(2), 0.6), 1.0, 0.08);
    EigenOptions eo;
    eo.count = 60;
    const EigenResult eig = spectrum(band, eo);
    const PointData data = dataAlong(band, equator(12), heightOf);
    const std::size_t hole = surfaceVoxelAlong(band, Vec3d(0, 0, 1)), solid = surfaceVoxelAlong(band, Vec3d(0, 0, -1));
    REQUIRE(band.mu[hole] < 0.7 * band.mu[solid]);
    const RegressionResult r = gpRegression(band, eig, data);
    INFO("mu hole " << band.mu[hole] << " solid " << band.mu[solid] << "; variance hole " << r.variance[hole] << " solid "
                    << r.variance[solid]);
    CHECK(r.variance[hole] > 1.2 * r.variance[solid]);
}

TEST_CASE("matern: weight-space and function-space posteriors agree, the result is thread-count independent", "[matern]") {
    const Band& band = test::sphereBand();
    const EigenResult& eig = sphereSpectrum();
    PointData data = dataAlong(band, equator(16), heightOf);
    for (std::size_t j = 0; j < data.noise.size(); ++j) data.noise[j] = 0.05 + 0.01 * double(j % 3);
    RegressionOptions o;
    const RegressionResult f = gpRegression(band, eig, data, o);
    CHECK_FALSE(f.weightSpace);  // m ≤ k
    o.weightSpace = true;
    RegressionResult w;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        w = gpRegression(band, eig, data, o);
    }
    CHECK(w.weightSpace);
    for (std::size_t i = 0; i < band.size(); ++i) {
        CHECK(w.mean[i] == Approx(f.mean[i]).margin(1e-6));
        CHECK(w.variance[i] == Approx(f.variance[i]).margin(1e-6 * f.amplitude));
    }
    RegressionResult w2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        w2 = gpRegression(band, eig, data, o);
    }
    CHECK(w2.mean == w.mean);
    CHECK(w2.variance == w.variance);
    // Noisy data are not interpolated: the posterior sits between the prior mean and the value.
    CHECK((f.meanAtData - Eigen::Map<const Eigen::VectorXd>(data.value.data(), 16)).cwiseAbs().maxCoeff() > 1e-4);
}

TEST_CASE("matern: regression refuses empty data, points off the band and forced weight space without noise", "[matern]") {
    const Band& band = test::sphereBand();
    const EigenResult& eig = sphereSpectrum();
    PointData data;
    CHECK_THROWS_AS(gpRegression(band, eig, data), ParameterError);
    data.position = {Vec3d(5, 0, 0)};
    data.value = {1};
    data.noise = {0};
    CHECK_THROWS_WITH(gpRegression(band, eig, data), Catch::Contains("outside the band"));
    data.position = {Vec3d(std::nan(""), 0, 0)};
    CHECK_THROWS_AS(gpRegression(band, eig, data), ParameterError);
    data.position = {centre(band, surfaceVoxelAlong(band, Vec3d(1, 0, 0)))};
    RegressionOptions o;
    o.weightSpace = true;
    CHECK_THROWS_WITH(gpRegression(band, eig, data, o), Catch::Contains("noise > 0"));
    // One exact point: a = 1 (no spread to take it from), the mean is the value everywhere it has influence.
    const RegressionResult r = gpRegression(band, eig, data);
    CHECK(r.amplitude == 1.0);
    CHECK(r.meanAtData(0) == Approx(1.0).margin(1e-6));
}
