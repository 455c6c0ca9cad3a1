// Plausible surfaces: draws of the linearised GPIS (docs/uncertainty.md#plausible-surfaces).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <tbb/global_control.h>
#include <vtkFieldData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkXMLPolyDataReader.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "band_fixtures.h"
#include "cli_run.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/point_cloud.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/triangle_soup.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/tasks/plausible_surfaces.h"
#include "helpers.h"
#include "png_stats.h"

using namespace gpisvdb;

namespace {

struct Input {
    const char* name;
    Samples samples;
    double s;
};

/// A soup (App. B noise) and a cloud (normal noise of rank 2), at σ = ℓ.
std::vector<Input> inputs() {
    std::vector<Input> out;
    const SoupSamples soup = soupSamples(icosphere(2), {1.0});
    out.push_back({"icosphere soup", soup.samples, 0.4 * soup.samples.lengthScale});
    const CloudSamples cloud = cloudSamples(scanLineTorus(0.35, 0.35), {1.0});
    out.push_back({"scan-line torus cloud", cloud.samples, 0.4 * cloud.samples.lengthScale});
    return out;
}

/// Points around the samples: each sample's position moved by up to 2 ℓ in a random direction.
std::vector<Vec3d> pointsNear(const Samples& samples, int count, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<std::size_t> pick(0, samples.size() - 1);
    std::uniform_real_distribution<double> along(-2.0, 2.0);
    std::vector<Vec3d> points;
    for (int k = 0; k < count; ++k)
        points.push_back(samples.position[pick(rng)] + along(rng) * samples.lengthScale * test::randomUnit(rng));
    return points;
}

SurfaceDrawOptions drawOptions(int count, std::uint64_t seed, int firstDraw = 0, double openingRatio = SurfaceDrawOptions{}.openingRatio) {
    SurfaceDrawOptions o;
    o.count = count;
    o.seed = seed;
    o.firstDraw = firstDraw;
    o.openingRatio = openingRatio;
    return o;
}

}  // namespace

TEST_CASE("plausible surfaces: the tree equals the direct sum within 2 % of the field's std, converging with beta", "[surfaces]") {
    // The far nodes' zeroth-order terms err by a share r/d of their part; at the default β = 6 the measured worst
    // case over these inputs is 1.7 % (docs/uncertainty.md#plausible-surfaces), and it shrinks like β^-3.
    for (const Input& in : inputs()) {
        INFO(in.name << ", " << in.samples.size() << " samples");
        const DirectGpis model(in.samples, in.s);
        const auto worstError = [&](double beta) {
            const SurfaceDraws draws(in.samples, in.s, drawOptions(4, 7, 0, beta));
            double worst = 0;
            for (const Vec3d& x : pointsNear(in.samples, 60, 3)) {
                const double sd = std::sqrt(model.evaluate(x).cov(0, 0));
                const auto tree = draws.perturbation(x), exact = draws.perturbationExact(x);
                for (int k = 0; k < draws.count(); ++k) worst = std::max(worst, std::abs(tree[k] - exact[k]) / sd);
            }
            return worst;
        };
        const double atDefault = worstError(SurfaceDrawOptions{}.openingRatio), coarse = worstError(3.0), fine = worstError(8.0);
        INFO("largest error / std at beta 3: " << coarse << ", default: " << atDefault << ", 8: " << fine);
        CHECK(atDefault < 0.02);
        CHECK(coarse > atDefault);  // the tree does collapse nodes: the two paths differ
        CHECK(fine < 0.5 * atDefault);
    }
}

TEST_CASE("plausible surfaces: the draws' pointwise mean and variance converge to 0 and the model's c00", "[surfaces]") {
    // J ε has mean 0 and variance c₀₀ exactly (it is the model's linear map of the noise); over n independent draws
    // the sample mean is within a few √(c₀₀ / n) and the sample variance within a few √(2 / n) of c₀₀.
    constexpr int kDraws = 2000;
    for (const Input& in : inputs()) {
        INFO(in.name);
        const DirectGpis model(in.samples, in.s);
        const SurfaceDraws draws(in.samples, in.s, drawOptions(kDraws, 11, 0));
        double worstMean = 0, worstVariance = 0;
        for (const Vec3d& x : pointsNear(in.samples, 12, 5)) {
            const double c00 = model.evaluate(x).cov(0, 0);
            const auto d = draws.perturbation(x);
            double sum = 0, sum2 = 0;
            for (double v : d) sum += v, sum2 += v * v;
            const double mean = sum / kDraws, variance = sum2 / kDraws;  // about the known mean 0
            worstMean = std::max(worstMean, std::abs(mean) / std::sqrt(c00 / kDraws));
            worstVariance = std::max(worstVariance, std::abs(variance / c00 - 1) / std::sqrt(2.0 / kDraws));
        }
        INFO("largest mean error in standard errors: " << worstMean << ", variance: " << worstVariance);
        CHECK(worstMean < 4.0);
        CHECK(worstVariance < 4.0);
    }
}

TEST_CASE("plausible surfaces: a draw depends on its seed and index alone, not on n, the first draw or threads", "[surfaces]") {
    const Band& band = test::sphereBand();
    const SoupSamples ss = soupSamples(icosphere(2), {1.0});
    const double s = 0.4 * ss.samples.lengthScale;
    const auto three = SurfaceDraws(ss.samples, s, drawOptions(3, 5, 0)).onBand(band);
    const auto third = SurfaceDraws(ss.samples, s, drawOptions(1, 5, 2)).onBand(band);
    CHECK(three[2] == third[0]);
    CHECK(three[0] != three[1]);
    const auto otherSeed = SurfaceDraws(ss.samples, s, drawOptions(1, 6, 2)).onBand(band);
    CHECK(otherSeed[0] != third[0]);
    std::vector<std::vector<float>> single;
    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        single = SurfaceDraws(ss.samples, s, drawOptions(3, 5, 0)).onBand(band);
    }
    CHECK(single == three);

    // Listed voxels (a slice's, for a section's lines) hold the whole band's values there.
    std::vector<std::size_t> layer;
    for (std::size_t i = 0; i < band.size(); ++i)
        if (band.coord[i].z() == 0) layer.push_back(i);
    REQUIRE(layer.size() > 100);
    const auto listed = SurfaceDraws(ss.samples, s, drawOptions(3, 5, 0)).onBand(band, layer);
    bool same = listed.size() == 3;
    for (std::size_t k = 0; k < listed.size(); ++k)
        for (std::size_t j = 0; j < layer.size(); ++j) same = same && listed[k][j] == three[k][layer[j]];
    CHECK(same);
    const auto layerGrid = drawGrid(band, layer, listed[0]);
    CHECK(layerGrid->activeVoxelCount() == openvdb::Index64(layer.size()));
    CHECK_THROWS_AS(SurfaceDraws(ss.samples, s, drawOptions(1, 5, 0)).onBand(band, {band.size()}), Error);
}

TEST_CASE("plausible surfaces: the draws' mean area matches the expected area sum mu h^3 within its standard error", "[surfaces]") {
    // Kac–Rice: E[area {φ = u}] = ∫ μ. The draws' level sets are meshed on the band's voxels, so the voxel must be
    // well below the smoothing s (0.08 here) for their wrinkles to be resolved.
    const SoupSamples ss = soupSamples(icosphere(2), {0.5});
    const double s = 0.4 * ss.samples.lengthScale;
    const BarnesHutGpis model(ss.samples, s);
    BandOptions o;
    o.voxelSize = 0.25 * s;
    const Band band = buildBand(model, ss.samples, o).band;
    constexpr int kDraws = 24;
    const auto fields = SurfaceDraws(ss.samples, s, drawOptions(kDraws, 2, 0)).onBand(band);
    double sum = 0, sum2 = 0;
    for (const auto& f : fields) {
        const double area = surfaceArea(meanSurface(*drawGrid(band, f), band.iso));
        sum += area, sum2 += area * area;
    }
    const double mean = sum / kDraws, sd = std::sqrt((sum2 - kDraws * mean * mean) / (kDraws - 1));
    const double standardError = sd / std::sqrt(double(kDraws)), expected = band.mass();
    INFO("draws' area " << mean << " +- " << standardError << " (sd " << sd << "), sum mu h^3 " << expected << ", mean surface "
                        << surfaceArea(meanSurface(*drawGrid(band, band.mean), band.iso)));
    CHECK(std::abs(mean - expected) < 3 * standardError + 0.01 * expected);
}

TEST_CASE("plausible surfaces: bad options are refused with the field they name", "[surfaces]") {
    const SoupSamples ss = soupSamples(icosphere(1), {1.0});
    const double s = 0.4 * ss.samples.lengthScale;
    CHECK_THROWS_AS(SurfaceDraws(ss.samples, s, drawOptions(0, 1, 0)), ParameterError);
    CHECK_THROWS_AS(SurfaceDraws(ss.samples, s, drawOptions(10001, 1, 0)), ParameterError);
    CHECK_THROWS_AS(SurfaceDraws(ss.samples, s, drawOptions(8, 1, -1)), ParameterError);
    CHECK_THROWS_AS(SurfaceDraws(ss.samples, s, drawOptions(8, 1, 0, 1.0)), ParameterError);
    CHECK_THROWS_AS(SurfaceDraws(ss.samples, s, drawOptions(8, 1, 0, NAN)), ParameterError);
    CHECK_THROWS_AS(SurfaceDraws(ss.samples, 0.0, {}), ParameterError);
    CHECK_THROWS_AS(SurfaceDraws(Samples{}, s, {}), Error);
}

TEST_CASE("plausible surfaces: the surfaces command writes one mesh per draw, named and commented by its index, as the report says",
          "[surfaces][cli]") {
    namespace fs = std::filesystem;
    using namespace test::cli;
    const std::string bunny = test::dataPath("bunny.obj"), dir = temp("draws"), json = temp("draws.json");
    const std::string common = "surfaces " + bunny + " --sigma 2 --voxel-size 0.25 --quiet";
    fs::remove_all(dir);
    const Run r = run(common + " -n 3 --seed 4 -o " + dir + " --report " + json);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    const auto& surfaces = report["surfaces"];
    CHECK(surfaces["count"] == 3);
    REQUIRE(surfaces["meshes"].size() == 3);
    for (int k = 0; k < 3; ++k) {
        const auto& mesh = surfaces["meshes"][std::size_t(k)];
        CHECK(mesh["draw"] == k);
        const std::string file = (fs::path(dir) / mesh["file"].get<std::string>()).string();
        REQUIRE(fs::exists(file));
        CHECK_THAT(fileText(file), Catch::Contains("comment gpisvdb plausible surface: draw " + std::to_string(k) + " of seed 4\n"));
        CHECK(mesh["triangles"].get<double>() > 100);
    }
    // The draws' areas scatter about Σ μ h³ (the test above checks the mean on a finer band)
    const double expected = surfaces["expected_area"], mean = surfaces["mean_area"];
    CHECK(std::abs(mean / expected - 1) < 0.25);
    // --picture: the mean surface and three draws side by side
    const std::string png = temp("draws.png");
    fs::remove(png);
    REQUIRE(run(common + " -n 3 --seed 4 -o " + temp("draws_pictured") + " --picture " + png).code == 0);
    const test::PngStats picture = test::pngStats(png);
    CHECK(picture.readable);
    CHECK(picture.width == 4 * 480);
    CHECK(picture.nonWhite > 0.05);
    // --format vtp: the draw in the file's field data
    const std::string vtp = temp("draws_vtp");
    fs::remove_all(vtp);
    REQUIRE(run(common + " -n 1 --first 2 --seed 4 --format vtp -o " + vtp).code == 0);
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    reader->SetFileName((vtp + "/surface_0002.vtp").c_str());
    reader->Update();
    auto* comment = vtkStringArray::SafeDownCast(reader->GetOutput()->GetFieldData()->GetAbstractArray("comment"));
    REQUIRE(comment != nullptr);
    CHECK(comment->GetValue(0) == "gpisvdb plausible surface: draw 2 of seed 4");
    CHECK(reader->GetOutput()->GetNumberOfPolys() > 100);
    // Draw 1 alone, by --first: the same mesh, byte for byte
    const std::string one = temp("draws_one");
    fs::remove_all(one);
    REQUIRE(run(common + " -n 1 --first 1 --seed 4 -o " + one).code == 0);
    CHECK(fileText(one + "/surface_0001.ply") == fileText(dir + "/surface_0001.ply"));
    // Interrupted at its first progress line: exit 130, no directory and no temporary left
    const std::string stopped = temp("draws_interrupted");
    fs::remove_all(stopped);
    const Run i = runInterrupted("surfaces " + bunny + " --sigma 2 -n 8 -o " + stopped);
    INFO(i.err);
    CHECK(i.code == 130);
    CHECK_FALSE(directoryLeftovers(stopped));
    // Refused with one line and nothing written
    const std::string bad = temp("draws_bad");
    fs::remove_all(bad);
    for (const std::string& args : {common + " -n 0", common + " --draw-beta 1", common + " --first -1", common + " --model regression"}) {
        INFO(args);
        const Run e = run(args + " -o " + bad);
        CHECK(e.code == 1);
        CHECK(lines(e.err) == 1);
        CHECK_FALSE(directoryLeftovers(bad));
    }
}
