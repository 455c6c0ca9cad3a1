// The README's main job, end to end at a small setting: every promised file exists and independent readers
// (vdb_print, pyopenvdb, VTK, a PNG decoder) read it; an interrupted demo leaves nothing behind.
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include "cli_run.h"
#include "gpisvdb/output/render.h"
#include "png_stats.h"

using namespace gpisvdb::test::cli;

namespace {

std::string slurp(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

vtkSmartPointer<vtkPolyData> readVtp(const std::string& path) {
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    reader->SetFileName(path.c_str());
    reader->Update();
    return reader->GetOutput();
}

/// The small setting: two σ, coarse voxels, two eigenpairs, small pictures (a few seconds on 2 cores).
constexpr int kPictureWidth = 160;  ///< --picture-width
const std::string kSmall = " --sigma 1 --sigma 3 --voxel-size 0.08 -k 2 --picture-width " + std::to_string(kPictureWidth) + " --quiet";

/// Height of the caption strip renderPng puts under captioned panels, measured on a one-panel picture.
int captionStripHeight() {
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    for (int i = -3; i <= 3; ++i)
        for (int j = -3; j <= 3; ++j) grid->tree().setValue({i, j, 0}, float(i + j));
    gpisvdb::RenderPanel slice;
    slice.sliceGrid = grid.get();
    slice.slice = gpisvdb::sliceOf("z=0");
    gpisvdb::RenderOptions o;
    o.panelWidth = o.panelHeight = 96;
    o.caption = "caption";
    const std::string path = temp("caption_strip.png");
    gpisvdb::renderPng({slice}, o, path);
    const gpisvdb::test::PngStats s = gpisvdb::test::pngStats(path);
    REQUIRE(s.readable);
    return s.height - o.panelHeight;
}

}  // namespace

TEST_CASE("demo: writes every promised file, and each opens in an independent reader", "[demo][cli]") {
    const std::string dir = temp("demo");
    fs::remove_all(dir);
    const Run r = run("demo -o " + dir + kSmall);
    INFO(r.err);
    REQUIRE(r.code == 0);

    // === summary.md links the pictures; report.json has one run per σ
    const std::string summary = slurp(dir + "/summary.md");
    CHECK_THAT(summary, Catch::Contains("](comparison.png)"));
    CHECK_THAT(summary, Catch::Contains("](input.png)"));
    const auto report = nlohmann::json::parse(slurp(dir + "/report.json"));
    REQUIRE(report["runs"].size() == 2);
    for (const auto& run : report["runs"]) {
        CHECK(run["band_voxels"].get<std::size_t>() > 1000);
        CHECK(run["voxel_size"].get<double>() == Approx(0.08).epsilon(1e-12));  // --voxel-size holds for every σ
        CHECK(run["path"]["reached_source"].get<bool>());
        const auto ev = run["eigenvalues"].get<std::vector<double>>();
        REQUIRE(ev.size() == 2);
        CHECK(0 < ev[0]);
        CHECK(ev[0] <= ev[1]);
    }
    // At σ = 3ℓ the GPIS closes the gap: the shortest path crosses it and is much shorter than the way round.
    CHECK(report["runs"][1]["path"]["crosses_gap"].get<bool>());
    CHECK(report["runs"][1]["path"]["length"].get<double>() < 2.0);

    for (const std::string s : {"sigma-1", "sigma-3"}) {
        const std::string vdb = dir + "/" + s + "/gpis.vdb";
        // === vdb_print
        const Run print = runShell("vdb_print -l " + vdb);
        CHECK(print.code == 0);
        for (const char* grid : {"mu", "mean", "stddev", "normal", "green", "geodesic", "eigen_000", "eigen_001"})
            CHECK_THAT(print.out, Catch::Contains(std::string("Name: ") + grid));
        // === pyopenvdb: grid classes and vector types Houdini and Blender read
        const std::string script = temp("read_demo.py");
        std::ofstream(script)
            << "import sys, pyopenvdb as vdb\n"
               "grids, meta = vdb.readAll(sys.argv[1])\n"
               "for g in grids: print(g.name, g.gridClass.replace(' ', '_'), g.vectorType.replace(' ', '_'), g.activeVoxelCount())\n"
               "print('meta', meta['sigma_rel'], meta['iso'], meta['gpisvdb_version'])\n";
        const Run py = runShell("/usr/bin/python3 " + script + " " + vdb);
        INFO(py.err);
        CHECK(py.code == 0);
        CHECK_THAT(py.out, Catch::Contains("mu fog_volume"));
        CHECK_THAT(py.out, Catch::Contains("normal unknown covariant_normalize"));
        CHECK_THAT(py.out, Catch::Contains("meta " + std::string(s == "sigma-1" ? "1.0" : "3.0") + " 0.5"));
        // === vdb_render draws mu as a fog volume
        const std::string ppm = dir + "/" + s + "/mu.ppm";
        const Run render =
            runShell("vdb_render " + vdb + " " + ppm + " -name mu -res 96x64 -translate 0,-4,3 -lookat 0,0,0 -up 0,0,1 -cpus 1");
        CHECK(render.code == 0);
        const std::string image = slurp(ppm);
        REQUIRE(image.size() > 96 * 64 * 3);
        CHECK(std::set<char>(image.end() - 96 * 64 * 3, image.end()).size() > 20);
        // === VTK: the surface with its fields, the path as a line
        auto surface = readVtp(dir + "/" + s + "/surface.vtp");
        CHECK(surface->GetNumberOfPolys() > 500);
        for (const char* a : {"mu", "stddev", "green", "geodesic", "eigen_000", "eigen_001"}) {
            INFO(a);
            REQUIRE(surface->GetPointData()->GetArray(a));
            CHECK(surface->GetPointData()->GetArray(a)->GetNumberOfTuples() == surface->GetNumberOfPoints());
        }
        auto path = readVtp(dir + "/" + s + "/path.vtp");
        CHECK(path->GetNumberOfLines() == 1);
        CHECK(path->GetNumberOfPoints() > 10);
    }

    // === PNGs decode at the expected size with varied content
    const gpisvdb::test::PngStats input = gpisvdb::test::pngStats(dir + "/input.png");
    REQUIRE(input.readable);
    CHECK(input.width == kPictureWidth);
    CHECK(input.height > 0);
    CHECK(input.height <= kPictureWidth);  // one landscape panel; the comparison uses panels of this size
    CHECK(input.colours > 30);
    const gpisvdb::test::PngStats comparison = gpisvdb::test::pngStats(dir + "/comparison.png");
    REQUIRE(comparison.readable);
    // one column per σ; six rows (μ, Green, geodesic, eigenfunction, μ on z = 0, plausible sections on z = 0:
    // docs/guide.md) and the caption
    const int strip = captionStripHeight();
    CHECK(strip > 0);
    CHECK(comparison.width == int(report["runs"].size()) * kPictureWidth);
    CHECK(comparison.height == 6 * input.height + strip);
    CHECK(comparison.colours > 500);
    CHECK(comparison.nonWhite > 0.2);
}

TEST_CASE("demo: an interrupted run leaves no output directory", "[demo][cli]") {
    const std::string dir = temp("demo_interrupted");
    fs::remove_all(dir);
    const Run r = runInterrupted("demo -o " + dir);
    INFO(r.err);
    CHECK(r.code == 130);
    CHECK_THAT(r.err, Catch::Contains("interrupted"));
    CHECK_FALSE(directoryLeftovers(dir));
}

TEST_CASE("demo: bad parameters are refused before any work", "[demo][cli]") {
    const std::string dir = temp("demo_bad");
    fs::remove_all(dir);
    for (const char* args :
         {" --sigma 0", " --sigma -1", " --voxel-size 0.001", " --voxel-size 5", " -k 0", " --picture-width 10", " --threads -1"}) {
        const Run r = run("demo -o " + dir + args);
        INFO(args << ": " << r.err);
        CHECK(r.code == 1);
        CHECK(lines(r.err) == 1);
        CHECK_FALSE(directoryLeftovers(dir));
    }
    const std::string file = temp("demo_file", "x");
    CHECK(run("demo -o " + file).code == 1);
}
