// Level lines on a slice (marching squares): a sphere's distance field gives its great circle on any axis, closed
// and on the circle to the interpolation's error; saddles, inactive voxels and absent crossings.
#include <catch2/catch.hpp>

#include <cmath>
#include <map>

#include "gpisvdb/output/slice_contour.h"

using namespace gpisvdb;

namespace {

/// |x − centre| on the voxels within `shell` voxels of the sphere of radius R (world units), voxel size h.
openvdb::FloatGrid::Ptr sphereShell(const Vec3d& centre, double R, double h, int shell) {
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(h));
    auto acc = grid->getAccessor();
    const int n = int(std::ceil((R + std::abs(centre.x()) + std::abs(centre.y()) + std::abs(centre.z())) / h)) + shell + 1;
    for (int i = -n; i <= n; ++i)
        for (int j = -n; j <= n; ++j)
            for (int k = -n; k <= n; ++k) {
                const double d = (Vec3d(i * h, j * h, k * h) - centre).norm();
                if (std::abs(d - R) <= shell * h) acc.setValue({i, j, k}, float(d));
            }
    return grid;
}

double length(const std::vector<std::vector<Vec3d>>& segments) {
    double sum = 0;
    for (const auto& s : segments) sum += (s[1] - s[0]).norm();
    return sum;
}

}  // namespace

TEST_CASE("slice contour: a sphere's distance field gives the closed circle of its section, on every axis", "[slice_contour]") {
    const double R = 1, h = 0.05;
    const Vec3d centre(0.013, -0.021, 0.004);
    const auto grid = sphereShell(centre, R, h, 2);
    for (int axis = 0; axis < 3; ++axis) {
        const SliceSpec slice{axis, 0.0};
        const auto segments = sliceContour(*grid, slice, R);
        REQUIRE(segments.size() > 100);
        // The layer's circle: radius √(R² − c_axis²) about the centre's projection.
        const double r = std::sqrt(R * R - centre[axis] * centre[axis]);
        double worst = 0;
        std::map<std::array<long long, 3>, int> ends;
        for (const auto& s : segments) {
            REQUIRE(s.size() == 2);
            for (const Vec3d& p : s) {
                CHECK(p[axis] == Approx(0).margin(1e-12));
                Vec3d q = p - centre;
                q[axis] = 0;
                worst = std::max(worst, std::abs(q.norm() - r));
                ++ends[{std::llround(p.x() * 1e6), std::llround(p.y() * 1e6), std::llround(p.z() * 1e6)}];
            }
        }
        INFO("axis " << axis << ": worst distance to the circle " << worst / h << " voxels");
        CHECK(worst < 0.02 * h);  // linear along an edge: ≈ h²/(8r)
        CHECK(length(segments) == Approx(2 * 3.14159265358979 * r).epsilon(0.003));
        bool closed = true;  // every end shared by exactly two segments
        for (const auto& e : ends) closed = closed && e.second == 2;
        CHECK(closed);
    }
}

TEST_CASE("slice contour: the layer nearest the plane, inactive corners end the line, no crossing gives none", "[slice_contour]") {
    const auto grid = sphereShell(Vec3d(0, 0, 0), 1, 0.05, 2);
    const auto atZero = sliceContour(*grid, {2, 0.0}, 1.0);
    const auto nearZero = sliceContour(*grid, {2, 0.02}, 1.0);  // 0.4 voxels off: the same layer
    CHECK(atZero == nearZero);
    CHECK(sliceContour(*grid, {2, 0.0}, 5.0).empty());
    CHECK(sliceContour(*grid, {2, 3.0}, 1.0).empty());  // no voxels on that layer
    // A hole in the shell: the segments of its squares go, the rest stay.
    auto holed = grid->deepCopy();
    holed->tree().setValueOff(openvdb::Coord(20, 0, 0));
    const auto open = sliceContour(*holed, {2, 0.0}, 1.0);
    CHECK(open.size() < atZero.size());
    CHECK(open.size() + 4 >= atZero.size());
}

TEST_CASE("slice contour: a saddle joins the corners on the side of the square's mean", "[slice_contour]") {
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    auto acc = grid->getAccessor();
    // Corners (0,0) and (1,1) above the level 0, (1,0) and (0,1) below.
    auto set = [&](float f00, float f10, float f11, float f01) {
        acc.setValue({0, 0, 0}, f00), acc.setValue({1, 0, 0}, f10), acc.setValue({1, 1, 0}, f11), acc.setValue({0, 1, 0}, f01);
    };
    auto cutCorners = [&] {  // the corner each segment cuts off: nearest to its midpoint
        std::vector<std::pair<int, int>> corners;
        for (const auto& s : sliceContour(*grid, {2, 0.0}, 0.0)) {
            const Vec3d m = 0.5 * (s[0] + s[1]);
            corners.emplace_back(int(std::lround(m.x())), int(std::lround(m.y())));
        }
        std::sort(corners.begin(), corners.end());
        return corners;
    };
    set(1.0f, -0.5f, 1.0f, -0.5f);  // mean above: the below corners are cut off
    CHECK(cutCorners() == std::vector<std::pair<int, int>>{{0, 1}, {1, 0}});
    set(0.5f, -1.0f, 0.5f, -1.0f);  // mean below: the above corners are cut off
    CHECK(cutCorners() == std::vector<std::pair<int, int>>{{0, 0}, {1, 1}});
    set(1.0f, -1.0f, -1.0f, 1.0f);  // no saddle: one segment, across the square
    const auto one = sliceContour(*grid, {2, 0.0}, 0.0);
    REQUIRE(one.size() == 1);
    CHECK(one[0][0].x() == Approx(0.5));
    CHECK(one[0][1].x() == Approx(0.5));
}
