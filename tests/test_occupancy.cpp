// Occupancy P(φ > u) and its fog volume (docs/uncertainty.md#occupancy).
#include <catch2/catch.hpp>
#include <cmath>
#include <openvdb/openvdb.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/output/occupancy.h"
#include "gpisvdb/output/write_vdb.h"

using namespace gpisvdb;

namespace {

/// Volume of a closed, outward-oriented triangle mesh (divergence theorem).
double enclosedVolume(const TriangleSoup& soup) {
    double v = 0;
    for (const auto& t : soup.triangles) v += soup.vertices[t[0]].dot(soup.vertices[t[1]].cross(soup.vertices[t[2]])) / 6.0;
    return v;
}

}  // namespace

TEST_CASE("occupancy: the inside probability is the normal CDF of the standardised mean", "[occupancy]") {
    CHECK(insideProbability(0.5, 0.1, 0.5) == Approx(0.5).margin(1e-15));
    CHECK(insideProbability(0.6, 0.1, 0.5) == Approx(0.8413447460685429).epsilon(1e-12));  // Φ(1)
    CHECK(insideProbability(0.3, 0.1, 0.5) == Approx(0.0227501319481792).epsilon(1e-12));  // Φ(−2)
    for (double z : {-3.0, -0.7, 0.0, 1.3})                                                // symmetric: P(z) + P(−z) = 1
        CHECK(insideProbability(z, 1.0, 0.0) + insideProbability(-z, 1.0, 0.0) == Approx(1.0).epsilon(1e-14));
    CHECK(insideProbability(0.6, 0.0, 0.5) == 1.0);  // no uncertainty: a step
    CHECK(insideProbability(0.4, 0.0, 0.5) == 0.0);
    CHECK(insideProbability(1e6, 1e-6, 0.5) == 1.0);                                             // extreme scales stay finite
    CHECK(insideProbability(0.5 - 1e6, 1e6, 0.5) == Approx(0.1586552539314571).epsilon(1e-12));  // Φ(−1)
}

TEST_CASE("occupancy: band voxels hold their probability, the enclosed region is 1 and the outside 0", "[occupancy]") {
    const Band& band = test::sphereBand();
    const auto grid = occupancyGrid(band, "density");
    CHECK(grid->getName() == "density");
    CHECK(grid->getGridClass() == openvdb::GRID_FOG_VOLUME);
    CHECK(grid->isInWorldSpace());
    CHECK(grid->voxelSize()[0] == Approx(band.voxelSize));
    auto acc = grid->getConstAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) {
        REQUIRE(acc.isValueOn(band.coord[i]));
        REQUIRE(acc.getValue(band.coord[i]) == float(insideProbability(band.mean[i], band.stddev[i], band.iso)));
    }
    // The centre lies deep inside the band's shell; twice the radius lies outside the band.
    const int R = int(std::lround(1.0 / band.voxelSize));
    CHECK(acc.isValueOn(openvdb::Coord(0, 0, 0)));
    CHECK(acc.getValue(openvdb::Coord(0, 0, 0)) == 1.0f);
    CHECK_FALSE(acc.isValueOn(openvdb::Coord(2 * R, 0, 0)));
    CHECK(acc.getValue(openvdb::Coord(2 * R, 0, 0)) == 0.0f);
    // Along each axis, from the centre out, the probability falls from 1 to 0 without rising by more than
    // a float's rounding (the winding number of a sphere decreases along the radius).
    for (int axis = 0; axis < 3; ++axis)
        for (int sign : {-1, 1}) {
            float last = 1.0f;
            for (int k = 0; k <= 2 * R; ++k) {
                openvdb::Coord c(0, 0, 0);
                c[axis] = sign * k;
                const float p = acc.getValue(c);
                INFO("axis " << axis << " sign " << sign << " k " << k << ": " << p << " after " << last);
                CHECK(p <= last + 1e-6f);
                last = p;
            }
            CHECK(last == 0.0f);
        }
}

TEST_CASE("occupancy: the expected inside volume exceeds the mean surface's by its curvature term", "[occupancy]") {
    // Σ P h³ = E[volume of {φ > u}]. Across a flat surface P − 1{γ > u} is odd in the signed distance and adds
    // nothing; on a sphere of radius R the area element 1 + 2d/R leaves + 4π R τ² (τ = √c₀₀ / |∇γ|, the surface's
    // positional standard deviation): positive, and below 2 % of the volume at this σ (τ < 0.1 R). The mean
    // surface's volume comes from another path: OpenVDB's mesher on γ, then the divergence theorem.
    const Band& band = test::sphereBand();
    const auto grid = occupancyGrid(band, "density");
    double sum = 0;
    for (auto it = grid->cbeginValueOn(); it; ++it) sum += double(*it) * double(it.getVoxelCount());
    const double h = band.voxelSize, expected = sum * h * h * h;
    const auto grids = bandGrids(band);
    const auto mean = openvdb::gridPtrCast<openvdb::FloatGrid>(grids[1]);
    REQUIRE(mean->getName() == "mean");
    const SurfaceMesh mesh = meanSurface(*mean, band.iso);
    double meanVolume = 0;
    for (const auto& t : mesh.triangles) {
        const openvdb::Vec3d a = mesh.vertices[std::size_t(t[0])], b = mesh.vertices[std::size_t(t[1])],
                             c = mesh.vertices[std::size_t(t[2])];
        meanVolume += a.dot(b.cross(c)) / 6.0;
    }
    meanVolume = std::abs(meanVolume);  // the mesher's orientation is its own
    INFO("E[volume] " << expected << " against the mean surface's " << meanVolume << " and the polyhedron's "
                      << enclosedVolume(icosphere(2)));
    CHECK(expected > meanVolume);
    CHECK(expected < 1.02 * meanVolume);
}

TEST_CASE("occupancy: an open surface's fill stays within the band's bounding box", "[occupancy]") {
    const Band& band = test::torusGapBand();
    const auto grid = occupancyGrid(band, "density");
    const openvdb::CoordBBox box = band.bbox();
    openvdb::CoordBBox active;
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        openvdb::CoordBBox b;
        it.getBoundingBox(b);
        active.expand(b);
    }
    CHECK(box.isInside(active));
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        REQUIRE(*it >= 0.0f);
        REQUIRE(*it <= 1.0f);
    }
}

TEST_CASE("occupancy: a band without its mean or stddev is refused", "[occupancy]") {
    Band band = test::sphereBand();
    band.stddev.clear();
    CHECK_THROWS_AS(occupancyGrid(band, "density"), Error);
}
