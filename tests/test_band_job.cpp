// The default band as every front end builds it (app/band_job.h): the model at the analysis scale, the report, the
// warnings in each front end's words.
#include <catch2/catch.hpp>
#include <string>

#include "gpisvdb/app/band_job.h"
#include "gpisvdb/input/procedural.h"

using namespace gpisvdb;

namespace {

InputData sphereInput() {
    InputData data;
    data.path = "sphere (procedural)";
    data.soup = icosphere(2);
    return data;
}

bool mentions(const std::vector<std::string>& lines, const std::string& text) {
    for (const std::string& l : lines)
        if (l.find(text) != std::string::npos) return true;
    return false;
}

}  // namespace

TEST_CASE("band job: a voxel size that sets s rebuilds the band's model and leaves the given one as it was", "[app]") {
    ModelOptions asked;
    asked.sigmaRel = 0.5;
    const auto given = std::make_shared<const LoadedModel>(loadModel(sphereInput(), asked));
    const double s = given->smoothing;
    // === Voxel values at h well above s/2: the model is rebuilt at s = kVoxelSmoothing·h
    DefaultBandOptions coarse;
    coarse.band.voxelSize = 0.3;
    coarse.values = VoxelValues::Voxel;
    REQUIRE(s < kVoxelSmoothing * coarse.band.voxelSize);
    const app::BandJob rebuilt = app::buildBandJob(given, asked, coarse);
    CHECK(rebuilt.model != given);
    CHECK(rebuilt.model->smoothing == Approx(kVoxelSmoothing * coarse.band.voxelSize).epsilon(1e-12));
    CHECK(rebuilt.model->smoothingSource == SmoothingSource::VoxelSize);
    CHECK(given->smoothing == s);
    CHECK(rebuilt.result.band.size() > 0);
    CHECK(rebuilt.secondsModel == 0);  // given, not loaded
    // === The centres' values: the band is built on the model given
    DefaultBandOptions fine;
    fine.band.voxelSize = 0.1;
    fine.values = VoxelValues::Point;
    const app::BandJob same = app::buildBandJob(given, asked, fine);
    CHECK(same.model == given);
    CHECK(same.options.voxelSize == 0.1);
    CHECK(same.bandBytesPerVoxel == same.result.band.bytesPerVoxel());
}

TEST_CASE("band job: the report holds the band's, the plan's and the settings' values", "[app]") {
    ModelOptions asked;
    asked.sigmaRel = 0.5;
    DefaultBandOptions options;
    options.band.voxelSize = 0.1;
    options.resolutionScale = 1.0;
    app::BandJob job = app::runBandJob(sphereInput(), asked, options);
    job.warnings = {"a warning"};
    const nlohmann::json r = app::bandReport(job);
    CHECK(r["input"]["path"] == "sphere (procedural)");
    CHECK(r["input"]["kind"] == "triangle soup");
    CHECK(r["input"]["samples"] == job.model->input.samples.size());
    CHECK(r["parameters"]["sigma_rel"] == 0.5);
    CHECK(r["parameters"]["sigma"] == job.model->input.sigma);
    CHECK(r["parameters"]["smoothing"] == job.model->smoothing);
    CHECK(r["parameters"]["model"] == "winding");
    CHECK(r["parameters"]["voxel_size"] == 0.1);
    CHECK(r["parameters"]["iso"] == 0.5);
    CHECK(r["parameters"]["h_star"] == job.resolution.hStar);
    CHECK(r["parameters"]["beta"] == asked.barnesHut.beta);
    CHECK(r["band"]["voxels"] == job.result.band.size());
    CHECK(r["band"]["mass"] == job.result.band.mass());
    CHECK(r["band"]["estimated_voxels"] == job.estimate.voxels);
    CHECK(r["band"]["evaluated_voxels"] == job.result.stats.evaluated);
    CHECK(r["warnings"] == nlohmann::json::array({"a warning"}));
    CHECK(r["memory"]["band_bytes_per_voxel"] == job.bandBytesPerVoxel);
    CHECK(r["memory"]["peak_rss_bytes"].get<double>() > 0);
    CHECK(job.secondsModel > 0);
    CHECK(job.secondsBand > 0);
}

TEST_CASE("band job: the warnings name the command line's flag and Python's keyword to change", "[app]") {
    ModelOptions asked;
    asked.sigmaRel = 0.5;
    asked.barnesHut.beta = 5;
    DefaultBandOptions options;
    options.band.voxelSize = 0.15;
    options.band.qmcSamples = 64;
    const app::BandJob job = app::runBandJob(sphereInput(), asked, options);
    const auto cli = app::bandWarnings(job, app::FrontEnd::CommandLine);
    const auto python = app::bandWarnings(job, app::FrontEnd::Python);
    CHECK(cli.size() == 2);
    CHECK(mentions(cli, "accuracy --beta 5 is below 6"));
    CHECK(mentions(cli, "--qmc 64 is below 512"));
    CHECK(python.size() == 2);
    CHECK(mentions(python, "accuracy beta=5 is below 6"));
    CHECK(mentions(python, "qmc=64 is below 512"));
    // === The exact sum has no β to warn of; the default β and QMC count warn of nothing
    asked.exact = true;
    CHECK(app::bandWarnings(app::runBandJob(sphereInput(), asked, options), app::FrontEnd::CommandLine).size() == 1);
    DefaultBandOptions byDefault;
    byDefault.band.voxelSize = options.band.voxelSize;
    CHECK(app::bandWarnings(app::runBandJob(sphereInput(), ModelOptions{}, byDefault), app::FrontEnd::CommandLine).empty());
}
