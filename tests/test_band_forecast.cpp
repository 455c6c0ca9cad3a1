#include <algorithm>
#include <catch2/catch.hpp>
#include <random>

#include "gpisvdb/band/band_forecast.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/point_cloud.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/input/triangle_soup.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "helpers.h"

using namespace gpisvdb;
using openvdb::Coord;

namespace {

/// A unit-sphere cloud of n random points with radial normals and its own σ (world units) per point.
Samples sphereCloud(int n, double sigma) {
    std::mt19937 rng(7);
    std::normal_distribution<double> g;
    PointCloud cloud;
    for (int i = 0; i < n; ++i) {
        const Vec3d p = Vec3d(g(rng), g(rng), g(rng)).normalized();
        cloud.positions.push_back(p), cloud.normals.push_back(p), cloud.sigmas.push_back(sigma);
    }
    return cloudSamples(cloud, {}).samples;
}

/// An input, its model's smoothing (world units) and the band-voxel budget (0: none).
struct Case {
    const char* name;
    Samples samples;
    double smoothing;
    double maxBandVoxels;
};

}  // namespace

TEST_CASE("band forecast: the pilot's region is compact boxes centred on sample voxels, with the sample voxels inside", "[band]") {
    const Samples samples = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
    const std::vector<Coord> seeds = sampleVoxels(samples, 0.5 * samples.lengthScale);
    openvdb::CoordBBox all;
    for (const Coord& c : seeds) all.expand(c);
    for (const int radius : {2, 8}) {
        const PilotRegion region = pilotRegion(seeds, radius, 8);
        INFO("radius " << radius << ", " << region.seeds.size() << " sample voxels in the region");
        REQUIRE(region.boxes.size() == 8);
        CHECK(std::is_sorted(region.seeds.begin(), region.seeds.end()));
        std::size_t inside = 0;
        for (const Coord& s : seeds) inside += region.contains(s);
        CHECK(inside == region.seeds.size());
        for (const openvdb::CoordBBox& box : region.boxes) {
            CHECK(box.dim() == Coord(2 * radius + 1));
            CHECK(std::binary_search(seeds.begin(), seeds.end(), Coord::round(box.getCenter())));  // centred on a sample voxel
            CHECK(double(box.volume()) < 0.1 * double(all.volume()));                              // a patch, not the shape
        }
        CHECK(region.seeds.size() >= 8 * std::size_t(radius));
    }
}

TEST_CASE("band forecast: the band's voxels and evaluated voxels are within 25 % of the built band's, on soups and clouds", "[band]") {
    const Samples bunny = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
    const Samples ring = soupSamples(torus(48, 16), {1.0}).samples;
    std::vector<Case> cases = {{"bunny, sigma_rel 0.5", bunny, 0.4 * bunny.lengthScale, 0},
                               {"torus, sigma_rel 1", ring, 0.4 * ring.lengthScale, 0},
                               // dense and noisy: the budget sets h (s = 1.2 σ as the noise smoothing makes it)
                               {"sphere cloud, 3000 points, sigma 0.02", sphereCloud(3000, 0.02), 0.024, 60000},
                               {"sphere cloud, 2000 points, sigma 0.005", sphereCloud(2000, 0.005), 0.4 * 0.04, 60000}};
    for (const Case& c : cases) {
        INFO(c.name);
        const BarnesHutGpis model(c.samples, c.smoothing);
        DefaultBandOptions options;
        options.maxBandVoxels = c.maxBandVoxels;
        const DefaultBandPlan plan = planDefaultBand(model, c.samples, options);
        BandForecastOptions fo;
        fo.pilotVoxels = 4096;
        const BandForecast f = forecastBand(model, c.samples, plan, fo);
        const DefaultBand built = buildPlannedBand(model, c.samples, plan);
        const double voxels = double(built.result.band.size()), evaluated = double(built.result.stats.evaluated);
        INFO("area " << plan.resolution.area << " bandVolume " << plan.resolution.bandVolume << " h " << plan.options.voxelSize << " w "
                     << plan.resolution.muWidth << " mass " << built.result.band.mass());
        INFO("voxels " << voxels << " forecast " << f.voxels << ", evaluated " << evaluated << " forecast " << f.evaluated);
        CHECK(f.voxels == Approx(voxels).epsilon(0.25));
        CHECK(f.evaluated == Approx(evaluated).epsilon(0.25));
        CHECK(f.pilotVoxels >= 2048);
        CHECK(f.secondsPerEvaluated > 0);
        CHECK(f.buildSeconds > f.evaluated * f.secondsPerEvaluated);
    }
}

TEST_CASE("band forecast: refuses a pilot too small to time", "[band]") {
    const Samples samples = soupSamples(icosphere(1), {1.0}).samples;
    const BarnesHutGpis model(samples, 0.4 * samples.lengthScale);
    const DefaultBandPlan plan = planDefaultBand(model, samples);
    BandForecastOptions o;
    o.pilotVoxels = 100;
    CHECK_THROWS_AS(forecastBand(model, samples, plan, o), ParameterError);
    o.pilotVoxels = 4096;
    o.patches = 0;
    CHECK_THROWS_AS(forecastBand(model, samples, plan, o), ParameterError);
}
