#include <catch2/catch.hpp>
#include <Eigen/Eigenvalues>
#include <tbb/global_control.h>

#include <cmath>
#include <fstream>
#include <random>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/model/regression_gpis.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/tasks/geodesic.h"
#include "gpisvdb/tasks/green.h"
#include "gpisvdb/tasks/spectrum.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

struct SphereModel {
    Samples samples;
    double spacing = 0;
    std::unique_ptr<RegressionGpis> model;
};

/// The unit icosphere(3) learned from `points` surface points (3 labels each).
SphereModel sphereModel(std::size_t points, double labelNoise = 0.05) {
    SphereModel s;
    s.samples = soupSamples(icosphere(3), {0.5}).samples;
    TrainingOptions to;
    to.surfacePoints = points;
    LabelledPoints t = trainingFromSamples(s.samples, to, &s.spacing);
    RegressionGpisOptions ro;
    ro.smoothing = 0.4 * s.spacing;
    ro.labelNoise = labelNoise;
    s.model = std::make_unique<RegressionGpis>(std::move(t), ro);
    return s;
}

Band regressionBand(const SphereModel& s, double h) {
    BandOptions o;
    o.voxelSize = h;
    o.iso = s.model->naturalIso();
    return buildBand(*s.model, s.samples, o).band;
}

std::vector<Vec3d> directions(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> N;
    std::vector<Vec3d> d(n);
    for (auto& v : d) v = Vec3d(N(rng), N(rng), N(rng)).normalized();
    return d;
}

}  // namespace

TEST_CASE("regression gpis: from a few hundred labels the mean crosses 0 at the sphere, +1 inside, -1 outside", "[regression_gpis]") {
    const SphereModel s = sphereModel(200);
    REQUIRE(s.model->trainingSize() == 600);
    CHECK(s.model->naturalIso() == 0.0);
    for (const Vec3d& u : directions(200, 1)) {
        CHECK(s.model->evaluate(0.9 * u).mean[0] > 0.3);
        CHECK(s.model->evaluate(1.1 * u).mean[0] < -0.3);
        CHECK(std::abs(s.model->evaluate(u).mean[0]) < 0.15);
        // The mean gradient points inwards (towards larger φ), as the winding number's does.
        CHECK(s.model->evaluate(u).mean.tail<3>().dot(u) < 0);
    }
    CHECK(s.model->evaluate(Vec3d(0, 0, 0)).mean[0] > 0.5);
    CHECK(s.model->evaluate(Vec3d(30, 0, 0)).mean[0] == Approx(-1).margin(0.05));
    // The band's μ-weighted radius is the sphere's.
    const Band band = regressionBand(s, 0.05);
    double r = 0, w = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        const openvdb::Coord& k = band.coord[i];
        r += band.mu[i] * band.voxelSize * Vec3d(k.x(), k.y(), k.z()).norm();
        w += band.mu[i];
    }
    CHECK(r / w == Approx(1.0).epsilon(0.02));
    CHECK(band.mass() == Approx(4 * M_PI).epsilon(0.1));
}

TEST_CASE("regression gpis: the covariance is PSD and shrinks at the labels, exact labels are interpolated", "[regression_gpis]") {
    const SphereModel s = sphereModel(60, 1e-4);
    const Samples& in = s.samples;
    for (const Vec3d& u : directions(50, 2)) {
        const ValueGradient z = s.model->evaluate(1.3 * u);
        CHECK(Eigen::SelfAdjointEigenSolver<Mat4d>(z.cov).eigenvalues().minCoeff() > -1e-9);
    }
    TrainingOptions to;
    to.surfacePoints = 60;
    const LabelledPoints t = trainingFromSamples(in, to);
    for (std::size_t i = 0; i < t.size(); i += 7) {
        const ValueGradient z = s.model->evaluate(t.position[i]);
        CHECK(z.mean[0] == Approx(t.label[i]).margin(1e-3));
        CHECK(z.cov(0, 0) < 1e-6);
    }
}

TEST_CASE("regression gpis: batched evaluation equals single points for any thread count", "[regression_gpis]") {
    const SphereModel s = sphereModel(100);
    std::vector<Vec3d> xs;
    for (const Vec3d& u : directions(77, 3)) xs.push_back(1.05 * u);
    std::vector<ValueGradient> one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = s.model->evaluate(xs);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = s.model->evaluate(xs);
    }
    for (std::size_t i = 0; i < xs.size(); ++i) {
        CHECK(one[i].mean == two[i].mean);
        CHECK(one[i].cov == two[i].cov);
        const ValueGradient z = s.model->evaluate(xs[i]);
        CHECK((z.mean - one[i].mean).norm() < 1e-9 * (1 + z.mean.norm()));
        CHECK((z.cov - one[i].cov).norm() < 1e-9 * (1 + z.cov.norm()));
    }
}

TEST_CASE("regression gpis: Green, geodesic and spectrum run on it unchanged", "[regression_gpis]") {
    const SphereModel s = sphereModel(150);
    const Band band = regressionBand(s, 0.06);
    REQUIRE(band.size() > 1000);
    const LaplacianOperator L(band);
    const GreenResult g = greensFunction(band, L, Vec3d(0, 0, 1));
    CHECK(g.solver.converged);
    const GeodesicResult geo = geodesicDistance(band, {Vec3d(0, 0, 1)}, {Vec3d(0, 0, -1)});
    REQUIRE(geo.paths.size() == 1);
    CHECK(geo.paths[0].reachedSource);
    CHECK(geo.paths[0].length == Approx(M_PI).epsilon(0.15));
    EigenOptions eo;
    eo.count = 4;
    const EigenResult e = spectrum(band, eo);
    REQUIRE(e.values.size() == 4);
    CHECK(e.values[0] > 0);
    for (int k = 0; k < 4; ++k) CHECK(e.residuals[k] < 1e-6);
    // The first gap near the sphere's 2/r² (μ is thinner than h here, so only roughly).
    CHECK(e.values[1] - e.values[0] == Approx(2.0).epsilon(0.4));
}

TEST_CASE("regression gpis: the pole-to-pole geodesic converges as the labels grow (paper Fig. 13)", "[regression_gpis]") {
    std::vector<double> length, distance;
    for (std::size_t n : {40, 80, 160, 320}) {
        const SphereModel s = sphereModel(n);
        const Band band = regressionBand(s, 0.05);
        const GeodesicResult geo = geodesicDistance(band, {Vec3d(0, 0, 1)}, {Vec3d(0, 0, -1)});
        REQUIRE(geo.paths[0].reachedSource);
        length.push_back(geo.paths[0].length);
        distance.push_back(geo.paths[0].distance);
    }
    INFO("path length " << length[0] << ", " << length[1] << ", " << length[2] << ", " << length[3] << "; U " << distance[0] << ", "
                        << distance[1] << ", " << distance[2] << ", " << distance[3]);
    CHECK(std::abs(distance[3] - distance[2]) < std::abs(distance[1] - distance[0]));
    CHECK(distance[3] < distance[0]);  // less uncertainty, shorter distances (paper App. F)
    CHECK(std::abs(length[3] - M_PI) < 0.05 * M_PI);
}

TEST_CASE("regression gpis: bad labels and options are refused", "[regression_gpis]") {
    LabelledPoints t;
    RegressionGpisOptions o;
    o.smoothing = 0.1;
    CHECK_THROWS_AS(RegressionGpis(t, o), InputError);
    t.position = {Vec3d(0, 0, 0), Vec3d(1, 0, 0)};
    t.label = {1, std::nan("")};
    CHECK_THROWS_AS(RegressionGpis(t, o), InputError);
    t.label = {1, 0};
    RegressionGpisOptions bad = o;
    bad.smoothing = 0;
    CHECK_THROWS_AS(RegressionGpis(t, bad), ParameterError);
    bad = o;
    bad.labelNoise = -1;
    CHECK_THROWS_AS(RegressionGpis(t, bad), ParameterError);
    bad = o;
    bad.amplitude = 0;
    CHECK_THROWS_AS(RegressionGpis(t, bad), ParameterError);
    // Repeated points with exact labels: K is singular.
    t.position = {Vec3d(0, 0, 0), Vec3d(0, 0, 0)};
    bad = o;
    bad.labelNoise = 0;
    CHECK_THROWS_WITH(RegressionGpis(t, bad), Catch::Contains("raise the label noise (RegressionGpisOptions::labelNoise)"));
    CHECK_THROWS_AS(trainingFromSamples(Samples{}), InputError);
}

TEST_CASE("regression gpis: labelled points are read from x,y,z,label[,noise] files", "[regression_gpis]") {
    const std::string path = (test::scratchDir() / "labels.csv").string();
    std::ofstream(path) << "x,y,z,label\n0,0,0,1\n1,0,0,0\n2,0,0,-1\n";
    const LabelledPoints t = readLabelledPoints(path);
    REQUIRE(t.size() == 3);
    CHECK(t.label[2] == -1);
    CHECK(t.noise.empty());
    CHECK_THROWS_AS(readLabelledPoints("/nonexistent.csv"), InputError);
}
