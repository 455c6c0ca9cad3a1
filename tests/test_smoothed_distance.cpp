#include <catch2/catch.hpp>
#include <openvdb/tools/Interpolation.h>
#include <tbb/global_control.h>

#include <random>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/smoothed_distance.h"

using namespace gpisvdb;

namespace {

std::vector<Vec3d> randomPoints(std::size_t n, double extent, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-extent, extent);
    std::vector<Vec3d> p(n);
    for (auto& x : p) x = Vec3d(U(rng), U(rng), U(rng));
    return p;
}

/// μ-weighted mean radius of the band's voxels: the radius of its mean surface for a sphere.
double meanRadius(const Band& band) {
    double s = 0, w = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        const openvdb::Coord& k = band.coord[i];
        s += band.mu[i] * band.voxelSize * Vec3d(k.x(), k.y(), k.z()).norm();
        w += band.mu[i];
    }
    return s / w;
}

}  // namespace

TEST_CASE("smoothed distance: the tree equals the exact sum within the stated bound", "[smoothed_distance]") {
    const Band& band = test::sphereBand();
    const std::vector<Vec3d> xs = randomPoints(300, 3.0, 11);
    for (double alpha : {0.3, 3.0, 30.0, 300.0}) {
        const SmoothedDistance d(band, alpha);
        for (double tol : {1e-2, 1e-5}) {
            double worst = 0, terms = 0;
            for (const Vec3d& x : xs) {
                std::size_t t = 0;
                worst = std::max(worst, std::abs(d.at(x, tol, &t) - d.exact(x)));
                terms += double(t);
            }
            INFO("alpha " << alpha << ", tolerance " << tol << ": worst error " << worst << ", mean terms " << terms / xs.size() << " of "
                          << band.size());
            CHECK(worst <= tol * (1 + 1e-6) + 1e-12);
            // Gains are largest for sharp α (far nodes vanish) and smooth α (nodes are nearly constant); α ≈ 3/radius
            // near the band keeps most terms.
            if (tol == 1e-2 && alpha != 3.0) CHECK(terms / double(xs.size()) < 0.25 * double(band.size()));
        }
    }
}

TEST_CASE("smoothed distance: finite on the whole grid for extreme alpha, and below the distance to the band", "[smoothed_distance]") {
    const Band& band = test::sphereBand();
    for (double alpha : {1e-4, 1.0, 1e4}) {
        SmoothedDistanceOptions o;
        o.alpha = alpha;
        o.gridVoxelSize = 0.25;
        const SmoothedDistanceResult r = smoothedDistanceGrid(band, o);
        CHECK(r.points == r.grid->activeVoxelCount());
        std::size_t finite = 0;
        for (auto it = r.grid->cbeginValueOn(); it; ++it) finite += std::isfinite(*it) ? 1 : 0;
        CHECK(finite == r.points);
    }
    // Between the hard minimum d* and the weights: d* − log(W)/α ≤ d ≤ d* − log(w_nearest)/α; close to d* at large α.
    const SmoothedDistance d(band, 1e3);
    for (const Vec3d& x : randomPoints(50, 2.5, 3)) {
        double nearest = 1e300;
        for (std::size_t i = 0; i < band.size(); ++i) {
            const openvdb::Coord& k = band.coord[i];
            nearest = std::min(nearest, (band.voxelSize * Vec3d(k.x(), k.y(), k.z()) - x).norm());
        }
        const double v = d.at(x, 1e-6);
        CHECK(v >= nearest - std::log(band.mass()) / 1e3 - 1e-6);
        CHECK(v == Approx(nearest).margin(0.02));
    }
}

TEST_CASE("smoothed distance: tends to the distance to the mean surface as alpha grows, at low sigma", "[smoothed_distance]") {
    const Band band = test::bandOf(icosphere(3), 0.1, 0.03);
    const double R = meanRadius(band);
    std::vector<Vec3d> xs;
    for (const Vec3d& p : randomPoints(400, 2.0, 5)) {
        const double r = p.norm();
        if ((r > 0.3 && r < 0.8) || (r > 1.2 && r < 2.0)) xs.push_back(p);
    }
    double previous = 1e300;
    std::string table;
    for (double alpha : {2.0, 8.0, 32.0, 128.0}) {
        const SmoothedDistance d(band, alpha);
        double worst = 0;
        for (const Vec3d& x : xs) worst = std::max(worst, std::abs(d.at(x, 1e-4) - std::abs(x.norm() - R)));
        table += " alpha " + std::to_string(alpha) + ": " + std::to_string(worst) + ";";
        CHECK(worst < previous);
        previous = worst;
    }
    INFO(band.size() << " voxels, mean radius " << R << ", max |d_alpha - dist|:" << table);
    CHECK(previous < 0.05);
}

TEST_CASE("smoothed distance: the grid does not depend on the thread count, and brute force agrees", "[smoothed_distance]") {
    const Band& band = test::sphereBand();
    SmoothedDistanceOptions o;
    o.alpha = 5;
    o.gridVoxelSize = 0.3;
    SmoothedDistanceResult one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = smoothedDistanceGrid(band, o);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = smoothedDistanceGrid(band, o);
    }
    o.bruteForce = true;
    const SmoothedDistanceResult exact = smoothedDistanceGrid(band, o);
    auto b = two.grid->getConstAccessor();
    auto e = exact.grid->getConstAccessor();
    for (auto it = one.grid->cbeginValueOn(); it; ++it) {
        CHECK(*it == b.getValue(it.getCoord()));
        CHECK(*it == Approx(e.getValue(it.getCoord())).margin(one.tolerance + 1e-5 * std::abs(*it)));
    }
}

TEST_CASE("smoothed distance: bad alpha, grid sizes and empty bands are refused", "[smoothed_distance]") {
    const Band& band = test::sphereBand();
    CHECK_THROWS_AS(SmoothedDistance(band, 0.0), ParameterError);
    CHECK_THROWS_AS(SmoothedDistance(band, std::nan("")), ParameterError);
    SmoothedDistanceOptions o;
    o.alpha = 1;
    o.gridVoxelSize = 1e-6;  // (3 / 1e-6)³ ≈ 3e19 points
    CHECK_THROWS_WITH(smoothedDistanceGrid(band, o), Catch::Contains("grid voxel size (SmoothedDistanceOptions::gridVoxelSize) of"));
    o.gridVoxelSize = -1;
    CHECK_THROWS_AS(smoothedDistanceGrid(band, o), ParameterError);
    CHECK_THROWS_AS(SmoothedDistance(Band{}, 1.0), Error);
}

TEST_CASE("smoothed distance: increases along rays from the centre outside the band, and reads far beyond the box", "[smoothed_distance]") {
    // Beyond the band's largest radius R every voxel x_j has x_j·u < |x| for x = |x| u, so d_α strictly increases
    // along the ray: checked at every grid point on the 26 lattice rays from the centre (grid point k at H k, so
    // those points lie exactly on the rays), out to the box's edge.
    const Band& band = test::sphereBand();
    double R = 0;
    for (const openvdb::Coord& k : band.coord) R = std::max(R, band.voxelSize * Vec3d(k.x(), k.y(), k.z()).norm());
    SmoothedDistanceOptions o;
    o.alpha = 5;
    o.gridVoxelSize = 0.3;  // coarse, yet ≥ 3 grid points beyond R on every ray (checked below)
    o.padding = 1.2;
    const SmoothedDistanceResult r = smoothedDistanceGrid(band, o);
    const openvdb::CoordBBox box = r.grid->evalActiveVoxelBoundingBox();
    auto acc = r.grid->getConstAccessor();
    float largest = -1e30f;
    for (auto it = r.grid->cbeginValueOn(); it; ++it) largest = std::max(largest, *it);
    std::size_t checked = 0, rays = 0;
    for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dz = -1; dz <= 1; ++dz) {
                if (!dx && !dy && !dz) continue;
                const Vec3d u(dx, dy, dz);
                double previous = -1e300;
                std::size_t onRay = 0;
                for (int t = 1;; ++t) {
                    const openvdb::Coord c(t * dx, t * dy, t * dz);
                    if (!box.isInside(c)) break;
                    if (t * o.gridVoxelSize * u.norm() <= R) continue;
                    REQUIRE(acc.isValueOn(c));
                    const double v = acc.getValue(c);
                    INFO("ray " << dx << "," << dy << "," << dz << " at step " << t);
                    CHECK(v > previous);
                    previous = v;
                    ++onRay;
                }
                checked += onRay;
                rays += onRay >= 3 ? 1 : 0;
            }
    CHECK(rays == 26);
    CHECK(checked >= 26 * 3);
    // Beyond the box nothing was computed: the background reads far (above every computed value), never 0.
    CHECK(r.background == Approx(r.grid->background()));
    CHECK(r.grid->background() > largest);
    CHECK(r.grid->background() > 0);
    const double outside = (box.max().x() + 50) * o.gridVoxelSize;
    for (const Vec3d& x : {Vec3d(outside, 0, 0), Vec3d(-outside, outside, 0), Vec3d(0, 0, 10 * outside)}) {
        const openvdb::Vec3d xi = r.grid->transform().worldToIndex(openvdb::Vec3d(x.x(), x.y(), x.z()));
        CHECK(openvdb::tools::BoxSampler::sample(r.grid->tree(), xi) > largest);
    }
    // Just outside the box, interpolated against the last computed layer: still above that layer's value.
    const openvdb::Coord edge(box.max().x(), 0, 0);
    const float atEdge = acc.getValue(edge);
    CHECK(openvdb::tools::BoxSampler::sample(r.grid->tree(), openvdb::Vec3d(edge.x() + 0.5, 0, 0)) > atEdge);
}
