// Pictures: size, content, colours that follow the field, slices, and the errors of bad requests.
#include <catch2/catch.hpp>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/output/render.h"
#include "helpers.h"
#include "png_stats.h"

using namespace gpisvdb;

namespace {

/// The unit icosphere as a SurfaceMesh with the array "height" = z.
SurfaceMesh sphereWithHeight() {
    const TriangleSoup soup = icosphere(3);
    SurfaceMesh m;
    std::vector<float> z;
    for (const Vec3d& v : soup.vertices) {
        m.vertices.emplace_back(float(v.x()), float(v.y()), float(v.z()));
        z.push_back(float(v.z()));
    }
    m.triangles = soup.triangles;
    m.arrayNames = {"height"};
    m.arrays = {z};
    m.components = {1};
    return m;
}

std::string png(const std::string& name) { return (test::scratchDir() / name).string(); }

/// A fog-like float grid: active voxels in the ball of radius r (voxels) about the origin, value = distance.
openvdb::FloatGrid::Ptr ballGrid(int r, double h) {
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("ball");
    grid->setTransform(openvdb::math::Transform::createLinearTransform(h));
    auto acc = grid->getAccessor();
    for (int i = -r; i <= r; ++i)
        for (int j = -r; j <= r; ++j)
            for (int k = -r; k <= r; ++k)
                if (i * i + j * j + k * k <= r * r) acc.setValue({i, j, k}, float(std::sqrt(i * i + j * j + k * k)));
    return grid;
}

}  // namespace

TEST_CASE("render: a surface picture has the requested size and is neither blank nor uniform", "[render]") {
    const SurfaceMesh sphere = sphereWithHeight();
    RenderPanel p;
    p.title = "height";
    p.surface = &sphere;
    p.array = "height";
    RenderOptions o;
    o.panelWidth = 320, o.panelHeight = 240;
    const std::string path = png("surface.png");
    renderPng({p}, o, path);
    const test::PngStats s = test::pngStats(path);
    REQUIRE(s.readable);
    CHECK(s.width == o.panelWidth);
    CHECK(s.height == o.panelHeight);
    CHECK(s.colours > 200);
    CHECK(s.nonWhite > 0.15);
    CHECK(s.nonWhite < 0.9);
}

TEST_CASE("render: colours follow the field (coolwarm: the top of a sphere coloured by height is red)", "[render]") {
    const SurfaceMesh sphere = sphereWithHeight();
    RenderPanel p;
    p.surface = &sphere;
    p.array = "height";
    p.colormap = Colormap::Coolwarm;
    RenderOptions o;
    o.panelWidth = o.panelHeight = 300;
    o.elevation = 0;  // side view: +z is up in the picture
    const std::string path = png("coolwarm.png");
    renderPng({p}, o, path);
    // Rows from the bottom; the colour bar takes the lowest ~17 %.
    const double top = test::redMinusBlue(path, 100, 200, 190, 240);
    const double bottom = test::redMinusBlue(path, 100, 200, 80, 120);
    INFO("top " << top << ", bottom " << bottom);
    CHECK(top > 40);
    CHECK(bottom < -20);
}

TEST_CASE("render: panels tile the picture, and a slice leaves inactive voxels white", "[render]") {
    const SurfaceMesh sphere = sphereWithHeight();
    const auto ball = ballGrid(12, 0.1);
    RenderPanel surface;
    surface.surface = &sphere;
    surface.array = "height";
    RenderPanel slice;
    slice.sliceGrid = ball.get();
    slice.slice = sliceOf("z=0");
    slice.colormap = Colormap::Magma;
    RenderOptions o;
    o.panelWidth = 200, o.panelHeight = 160;
    o.columns = 1;
    o.caption = "a caption";
    const std::string path = png("tiles.png");
    renderPng({surface, slice, surface}, o, path);
    const test::PngStats s = test::pngStats(path);
    REQUIRE(s.readable);
    // One column of three panels above one caption strip, the strip as tall as under a single captioned panel.
    const std::string captioned = png("captioned.png");
    renderPng({slice}, o, captioned);
    const test::PngStats c = test::pngStats(captioned);
    REQUIRE(c.readable);
    const int strip = c.height - o.panelHeight;
    CHECK(strip > 0);
    CHECK(strip < o.panelHeight / 2);
    CHECK(c.width == o.panelWidth);
    CHECK(s.width == o.panelWidth);
    CHECK(s.height == 3 * o.panelHeight + strip);
    // The slice panel alone: no caption, no strip; its corners (outside the ball) are white, its centre is coloured.
    RenderOptions one;
    one.panelWidth = one.panelHeight = 200;
    const std::string slicePath = png("slice.png");
    renderPng({slice}, one, slicePath);
    CHECK(test::pngStats(slicePath).width == one.panelWidth);
    CHECK(test::pngStats(slicePath).height == one.panelHeight);
    CHECK(test::redMinusBlue(slicePath, 0, 8, 192, 200) == 0);  // only background there
    CHECK(test::pngStats(slicePath).colours > 20);
}

TEST_CASE("render: log and symmetric ranges, fixed ranges", "[render]") {
    SurfaceMesh sphere = sphereWithHeight();
    std::vector<float> positive, negative;
    for (float z : sphere.arrays[0]) positive.push_back(std::exp(4 * z)), negative.push_back(-std::exp(4 * z));
    sphere.arrayNames.insert(sphere.arrayNames.end(), {"exp", "negative"});
    sphere.arrays.insert(sphere.arrays.end(), {positive, negative});
    sphere.components.insert(sphere.components.end(), {1, 1});
    RenderPanel p;
    p.surface = &sphere;
    p.array = "exp";
    p.logScale = true;
    RenderOptions o;
    o.panelWidth = o.panelHeight = 160;
    CHECK_NOTHROW(renderPng({p}, o, png("log.png")));
    p.array = "negative";
    CHECK_THROWS_WITH(renderPng({p}, o, png("log_bad.png")), Catch::Contains("positive values"));
    p.logScale = false;
    p.array = "height";
    p.range = {-1.0, -0.5};
    CHECK_NOTHROW(renderPng({p}, o, png("fixed.png")));
    p.range = {std::nan(""), std::nan("")};
    p.symmetric = true;
    CHECK_NOTHROW(renderPng({p}, o, png("symmetric.png")));
}

TEST_CASE("render: lines drawn over a slice show in their colour, over the greys map's light ground", "[render]") {
    const auto ball = ballGrid(12, 0.1);
    RenderPanel slice;
    slice.sliceGrid = ball.get();
    slice.slice = sliceOf("z=0");
    slice.colormap = Colormap::Greys;
    RenderOptions o;
    o.panelWidth = o.panelHeight = 200;
    const std::string plain = png("slice_greys.png");
    renderPng({slice}, o, plain);
    CHECK(test::redMinusBlue(plain, 0, 200, 0, 200) == Approx(0).margin(1.0));  // greys only
    std::vector<Vec3d> circle;
    for (int k = 0; k <= 64; ++k)
        circle.emplace_back(0.6 * std::cos(k * 2 * 3.14159265358979 / 64), 0.6 * std::sin(k * 2 * 3.14159265358979 / 64), 0.3);
    slice.sliceLines.push_back({{circle}, {1, 0, 0}, 2.0});
    const std::string lined = png("slice_lines.png");
    renderPng({slice}, o, lined);
    CHECK(test::redMinusBlue(lined, 0, 200, 0, 200) > 3);  // measured 4.8: a thin circle among grey pixels
    // The circle of radius 0.6, half the ball's: grey at the centre.
    CHECK(test::redMinusBlue(lined, 95, 105, 95, 105) == Approx(0).margin(1.0));
}

TEST_CASE("render: bad requests are refused with a clear error", "[render]") {
    SurfaceMesh sphere = sphereWithHeight();
    sphere.arrayNames.push_back("vector");
    sphere.arrays.push_back(std::vector<float>(3 * sphere.vertices.size(), 1.0f));
    sphere.components.push_back(3);
    const auto ball = ballGrid(4, 0.1);
    RenderOptions o;
    const std::string path = png("bad.png");
    CHECK_THROWS_AS(renderPng({}, o, path), ParameterError);
    RenderPanel neither;
    CHECK_THROWS_AS(renderPng({neither}, o, path), ParameterError);
    RenderPanel both;
    both.surface = &sphere;
    both.sliceGrid = ball.get();
    CHECK_THROWS_AS(renderPng({both}, o, path), ParameterError);
    RenderPanel unknown;
    unknown.surface = &sphere;
    unknown.array = "nosuch";
    CHECK_THROWS_WITH(renderPng({unknown}, o, path), Catch::Contains("no array 'nosuch'"));
    unknown.array = "vector";
    CHECK_THROWS_WITH(renderPng({unknown}, o, path), Catch::Contains("vector field"));
    RenderPanel miss;
    miss.sliceGrid = ball.get();
    miss.slice = sliceOf("x=5");
    CHECK_THROWS_WITH(renderPng({miss}, o, path), Catch::Contains("misses the grid"));
    RenderPanel linedSurface;
    linedSurface.surface = &sphere;
    linedSurface.sliceLines.push_back({{{Vec3d(0, 0, 0), Vec3d(1, 0, 0)}}});
    CHECK_THROWS_WITH(renderPng({linedSurface}, o, path), Catch::Contains("need a slice panel"));
    RenderPanel tiny;
    tiny.surface = &sphere;
    o.panelWidth = 10;
    CHECK_THROWS_AS(renderPng({tiny}, o, path), ParameterError);
    o.panelWidth = 200;
    CHECK_THROWS_AS(renderPng({tiny}, o, "/nonexistent-dir/x.png"), OutputError);
}

TEST_CASE("render: colour map and slice names parse, and others are refused", "[render]") {
    CHECK(colormapOf("viridis") == Colormap::Viridis);
    CHECK(colormapOf("coolwarm") == Colormap::Coolwarm);
    CHECK(colormapOf("grey") == Colormap::Gray);
    CHECK(colormapOf("greys") == Colormap::Greys);
    CHECK_THROWS_AS(colormapOf("jet"), ParameterError);
    CHECK(sliceOf("x=-2.5").axis == 0);
    CHECK(sliceOf("x=-2.5").value == -2.5);
    CHECK(sliceOf("y=1e-3").axis == 1);
    CHECK(sliceOf("z=0").axis == 2);
    for (const char* bad : {"", "z", "z=", "w=1", "zz=1", "z=abc", "z=1x", "z=nan", "z=inf"}) CHECK_THROWS_AS(sliceOf(bad), ParameterError);
}
