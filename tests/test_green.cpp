#include <catch2/catch.hpp>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/green.h"

using namespace gpisvdb;

TEST_CASE("green: symmetric G(x,y) = G(y,x), positive, largest at its source", "[green]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    const PcgOptions o{1e-6, 50000};
    const Vec3d a(1.0, 0.0, -0.2), b(-0.7, 0.7, 0.1);  // on the tube, far apart; b near the gap's edge
    const GreenResult ga = greensFunction(band, L, a, o), gb = greensFunction(band, L, b, o);
    REQUIRE(ga.solver.converged);
    REQUIRE(gb.solver.converged);
    const double gab = ga.values[gb.sourceIndex], gba = gb.values[ga.sourceIndex];
    INFO("G(a,b) = " << gab << ", G(b,a) = " << gba << ", iterations " << ga.solver.iterations);
    CHECK(std::abs(gab - gba) <= 1e-4 * std::abs(gab));
    for (const GreenResult* g : {&ga, &gb}) {
        const auto maxIt = std::max_element(g->values.begin(), g->values.end());
        CHECK(std::size_t(maxIt - g->values.begin()) == g->sourceIndex);
        CHECK(*std::min_element(g->values.begin(), g->values.end()) >= -1e-6f * *maxIt);
    }
}

TEST_CASE("green: the source snaps to the nearest band voxel, a non-finite source is refused", "[green]") {
    const Band& band = test::torusGapBand();
    const std::size_t i = band.size() / 2;
    const Vec3d x = band.voxelSize * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z());
    CHECK(nearestBandVoxel(band, x + Vec3d(0.2, -0.1, 0.3) * band.voxelSize) == i);
    CHECK_THROWS_AS(nearestBandVoxel(band, Vec3d(0, std::nan(""), 0)), ParameterError);
}
