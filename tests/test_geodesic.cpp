#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/geodesic.h"
#include "gpisvdb/tasks/green.h"

using namespace gpisvdb;

namespace {

/// Unit sphere soup (1280 triangles) at σ = ℓ, h = 0.05 (μ's profile across the surface spans a few voxels;
/// about 29 000 voxels).
const Band& thinSphereBand() {
    static const Band band = test::bandOf(icosphere(3), 1.0, 0.05);
    return band;
}

Vec3d world(const Band& band, std::size_t i) { return band.voxelSize * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z()); }

double angle(const Vec3d& a, const Vec3d& b) { return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)); }

}  // namespace

TEST_CASE("geodesic: on a unit-sphere soup at low sigma U is proportional to the great-circle angle", "[geodesic]") {
    const Band& band = thinSphereBand();
    const Vec3d source(0, 0, 1);
    const GeodesicResult g = geodesicDistance(band, {source});
    REQUIRE(g.march.unreached == 0);
    // U/θ on the voxels nearest the mean surface (|x| within h/2 of the sphere the band is centred on), away from
    // the source and the antipode (θ ∈ [0.4, 2.6]), where both are singular
    double radius = 0, mass = 0;
    for (std::size_t i = 0; i < band.size(); ++i) radius += band.mu[i] * world(band, i).norm(), mass += band.mu[i];
    radius /= mass;
    std::vector<double> ratio;
    for (std::size_t i = 0; i < band.size(); ++i) {
        const Vec3d x = world(band, i);
        const double theta = angle(x, source);
        if (std::abs(x.norm() - radius) > band.voxelSize / 2 || theta < 0.4 || theta > 2.6) continue;
        ratio.push_back(g.march.distance[i] / theta);
    }
    double mean = 0, var = 0;
    for (double r : ratio) mean += r;
    mean /= double(ratio.size());
    for (double r : ratio) var += (r - mean) * (r - mean);
    const double spread = std::sqrt(var / double(ratio.size())) / mean;
    INFO(ratio.size() << " voxels, mean radius " << radius << ", U/θ = " << mean << " ± " << spread * 100 << "%");
    REQUIRE(ratio.size() > 500);
    CHECK(spread < 0.05);
}

TEST_CASE("geodesic: paths run from the target to the source with U decreasing, no shorter than the straight line", "[geodesic]") {
    const Band& band = thinSphereBand();
    const Vec3d source(0, 0, 1);
    const std::vector<Vec3d> targets = {Vec3d(1, 0, 0), Vec3d(0.3, -0.5, -0.8).normalized(), Vec3d(-0.1, 0.2, 0.97).normalized()};
    const GeodesicResult g = geodesicDistance(band, {source}, targets);
    REQUIRE(g.paths.size() == targets.size());
    for (std::size_t k = 0; k < targets.size(); ++k) {
        const GeodesicPath& p = g.paths[k];
        INFO("target " << k << ": " << p.points.size() << " points, length " << p.length);
        REQUIRE(p.reachedSource);
        CHECK(p.source == g.sourceIndex[0]);
        CHECK((p.points.front() - world(band, g.targetIndex[k])).norm() == 0);
        CHECK((p.points.back() - world(band, g.sourceIndex[0])).norm() == 0);
        // the point before the last is in a cell that has the source as a corner: within one voxel diagonal
        if (p.points.size() > 1) CHECK((p.points[p.points.size() - 2] - p.points.back()).norm() <= std::sqrt(3.0) * band.voxelSize);
        CHECK(p.distance == g.march.distance[g.targetIndex[k]]);
        for (std::size_t i = 1; i < p.values.size(); ++i) CHECK(p.values[i] < p.values[i - 1]);
        double length = 0;
        for (std::size_t i = 1; i < p.points.size(); ++i) length += (p.points[i] - p.points[i - 1]).norm();
        CHECK(std::abs(length - p.length) <= 1e-9 * length);
        const double chord = (p.points.front() - p.points.back()).norm();
        CHECK(p.length >= chord);
        // on the sphere: the great-circle arc (within the first-order error), and never far from the surface
        const double arc = angle(p.points.front(), p.points.back());
        CHECK(std::abs(p.length - arc) < 0.1 * arc);
        for (const Vec3d& x : p.points) CHECK(std::abs(x.norm() - 1) < 2 * band.voxelSize);
    }
}

TEST_CASE("geodesic: several sources give the least distance, a target at a source has an empty path", "[geodesic]") {
    const Band& band = thinSphereBand();
    const Vec3d north(0, 0, 1), south(0, 0, -1);
    const GeodesicResult both = geodesicDistance(band, {north, south}, {north});
    const GeodesicResult fromNorth = geodesicDistance(band, {north});
    const GeodesicResult fromSouth = geodesicDistance(band, {south});
    std::size_t equal = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        const double least = std::min(fromNorth.march.distance[i], fromSouth.march.distance[i]);
        CHECK(both.march.distance[i] <= least * (1 + 1e-12));
        if (both.march.distance[i] >= least * (1 - 0.05)) ++equal;  // the fronts meet near the equator only
    }
    CHECK(double(equal) > 0.95 * double(band.size()));
    REQUIRE(both.paths.size() == 1);
    CHECK(both.paths[0].points.size() == 1);
    CHECK(both.paths[0].length == 0);
    CHECK(both.paths[0].reachedSource);
}

TEST_CASE("geodesic: an early stop still gives the target's path, bad points are refused", "[geodesic]") {
    const Band& band = test::torusGapBand();
    const Vec3d s(1.0, 0.0, -0.2), t(-1.0, 0.0, -0.2);
    GeodesicOptions early;
    early.stopAtTargets = true;
    const GeodesicResult full = geodesicDistance(band, {s}, {t});
    const GeodesicResult part = geodesicDistance(band, {s}, {t}, early);
    CHECK(part.march.stoppedEarly);
    CHECK(part.march.unreached > 0);
    REQUIRE(part.paths[0].reachedSource);
    CHECK(part.paths[0].points == full.paths[0].points);  // the accepted region is the same
    CHECK_THROWS_AS(geodesicDistance(band, {}), ParameterError);
    CHECK_THROWS_AS(geodesicDistance(band, {Vec3d(NAN, 0, 0)}), ParameterError);
    CHECK_THROWS_AS(geodesicDistance(band, {s}, {Vec3d(0, INFINITY, 0)}), ParameterError);
    CHECK_THROWS_AS(backtrack(band, std::vector<double>(3, 0.0), 0), ParameterError);
    CHECK_THROWS_AS(backtrack(band, full.march.distance, band.size()), ParameterError);
    BacktrackOptions zeroStep;
    zeroStep.step = 0;
    CHECK_THROWS_AS(backtrack(band, full.march.distance, 0, zeroStep), ParameterError);
}

TEST_CASE("geodesic: a target the march never reached gives a one-point path marked unreached", "[geodesic]") {
    const Band& band = test::torusGapBand();
    std::vector<double> U(band.size(), std::numeric_limits<double>::infinity());
    U[0] = 0;
    const GeodesicPath p = backtrack(band, U, band.size() / 2);
    CHECK_FALSE(p.reachedSource);
    CHECK(p.points.size() == 1);
    CHECK(std::isinf(p.distance));
}

TEST_CASE("geodesic: absurd point counts and a march beyond the memory budget are refused before any work", "[geodesic]") {
    const Band& band = test::sphereBand();
    const Vec3d s(1.0, 0.0, 0.0);
    const std::vector<Vec3d> many(kMaxGeodesicPoints + 1, s);
    CHECK_THROWS_WITH(geodesicDistance(band, many), Catch::Contains("at most 1e+06 source points"));
    CHECK_THROWS_AS(geodesicDistance(band, {s}, many), ParameterError);
    GeodesicOptions tight;
    tight.maxBytes = 1e3;
    try {
        geodesicDistance(band, {s}, {}, tight);
        FAIL("no refusal");
    } catch (const ParameterError& e) {
        CHECK_THAT(e.what(), Catch::Contains("(GeodesicOptions::maxBytes)") && Catch::Contains("(BandOptions::voxelSize) of"));
        CHECK(e.parameters() == std::vector<std::string>{"GeodesicOptions::maxBytes", "BandOptions::voxelSize"});
    }
    tight.maxBytes = geodesicMarchBytes(band) * 1.01;
    CHECK(geodesicDistance(band, {s}, {}, tight).march.accepted == band.size());
}
