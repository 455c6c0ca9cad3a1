#include "gpisvdb/app/band_job.h"

#include <sys/resource.h>

#include <chrono>
#include <cmath>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::app {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Documented accuracy limits (docs/band.md#warnings).
constexpr double kDocumentedBeta = 6;          // docs/model.md
constexpr int kDocumentedQmc = 512;            // docs/band.md, μ and T
constexpr double kRegularisedFraction = 0.01;  // more than 1 % of the voxels regularised

/// "--beta 5" on the command line, "beta=5" in Python.
std::string setting(std::string_view field, const std::string& value, FrontEnd frontEnd) {
    const std::string_view name = parameterName(field, frontEnd);
    return std::string(name) + (frontEnd == FrontEnd::CommandLine ? " " : "=") + value;
}

}  // namespace

BandJob buildBandJob(std::shared_ptr<const LoadedModel> model, const ModelOptions& asked, const DefaultBandOptions& options,
                     const Progress& progress, const BandBuilder& build) {
    const auto start = Clock::now();
    BandJob job;
    job.modelOptions = asked;
    job.modelOptions.labels.reset();
    job.requested = options;
    const DefaultBandPlan plan = planDefaultBandFor(model, asked, options, progress);
    static_cast<DefaultBand&>(job) = buildPlannedBand(*model->model, model->input.samples, plan, build, progress);
    job.model = std::move(model);
    job.secondsBand = since(start);
    job.voxelSizeNote = voxelSizeNote(job);
    job.bandBytesPerVoxel = job.result.band.bytesPerVoxel();
    return job;
}

BandJob runBandJob(const InputData& data, const ModelOptions& asked, const DefaultBandOptions& options, const Progress& progress,
                   const BandBuilder& build) {
    const auto start = Clock::now();
    auto model = std::make_shared<const LoadedModel>(loadModel(data, asked));
    const double secondsModel = since(start);
    BandJob job = buildBandJob(std::move(model), asked, options, progress, build);
    job.source = data.path;
    job.secondsModel = secondsModel;
    return job;
}

std::vector<std::string> bandWarnings(const BandJob& job, FrontEnd frontEnd) {
    std::vector<std::string> w;
    const ModelOptions& mo = job.modelOptions;
    // docs/model.md: β = 6 keeps every model number within 1e-3 of its scale on all test inputs; β = 5 missed it.
    if (mo.kind == ModelKind::Winding && !mo.exact && mo.barnesHut.beta < kDocumentedBeta)
        w.push_back("the Barnes-Hut accuracy " + setting("BarnesHutOptions::beta", numberText(mo.barnesHut.beta), frontEnd) + " is below " +
                    numberText(kDocumentedBeta) +
                    ", the smallest documented to keep the model within 1e-3 of the direct sum: mu and T may err more");
    // docs/band.md: S = 512 is within 1 % of S = 8192 near the surface.
    if (job.options.qmcSamples < kDocumentedQmc)
        w.push_back(setting("BandOptions::qmcSamples", std::to_string(job.options.qmcSamples), frontEnd) + " is below " +
                    std::to_string(kDocumentedQmc) + ", the smallest QMC count documented within 1% of the converged mu and T");
    const std::size_t n = job.result.band.size(), reg = job.result.stats.regularised;
    if (n && double(reg) > kRegularisedFraction * double(n))
        w.push_back(std::to_string(reg) + " of " + std::to_string(n) + " voxels (" + numberText(100.0 * double(reg) / double(n)) +
                    "%) had T regularised by the anisotropy cap " +
                    setting("BandOptions::maxAnisotropy", numberText(job.options.maxAnisotropy), frontEnd) +
                    ": their diffusion is more isotropic than the model's; a larger cap changes fewer");
    return w;
}

nlohmann::json bandReport(const BandJob& job) {
    const InputSamples& in = job.model->input;
    const ModelOptions& mo = job.modelOptions;
    const Band& band = job.result.band;
    const BandStats& st = job.result.stats;
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    const openvdb::CoordBBox bb = band.bbox();
    // === What was read
    nlohmann::json input = {{"path", job.source},
                            {"samples", in.samples.size()},
                            {"model_samples", job.model->modelSamples},
                            {"length_scale", in.samples.lengthScale},
                            {"kind", in.isSoup ? "triangle soup" : "oriented point cloud"},
                            {"skipped_zero_area", in.degenerateSkipped},
                            {"normals_flipped", in.normalsFlipped}};
    // === The parameters, as asked (relative) and as used (absolute)
    nlohmann::json parameters = {{"sigma_rel", mo.sigmaRel},
                                 {"sigma", in.sigma},
                                 {"smoothing_rel", mo.smoothingRel},
                                 {"smoothing", job.model->smoothing},
                                 {"noise_smoothing", mo.noiseSmoothing},
                                 {"merge_rel", mo.mergeRel},
                                 {"smoothing_set_by", smoothingSourceName(job.model->smoothingSource)},
                                 {"model", mo.kind == ModelKind::Regression ? "regression" : "winding"},
                                 {"training_labels", job.model->trainingSize},
                                 {"iso", job.options.iso},
                                 {"eta_rel", job.options.etaRelative},
                                 {"eta", st.etaAbsolute},
                                 {"voxel_size", job.options.voxelSize},
                                 {"h_star", job.resolution.hStar},
                                 {"mu_width", job.resolution.muWidth},
                                 {"resolution_scale", job.requested.resolutionScale},
                                 {"voxel_values", voxelValuesName(job.options.values)},
                                 {"max_band_voxels", job.maxBandVoxels},
                                 {"voxel_size_by_budget", job.budgeted},
                                 {"accuracy_voxel_size", job.accuracyVoxelSize},
                                 {"accuracy_voxels", job.accuracyVoxels},
                                 {"voxel_size_note", job.voxelSizeNote},
                                 {"qmc_samples", job.options.qmcSamples},
                                 {"beta", mo.barnesHut.beta},
                                 {"exact", mo.exact},
                                 {"max_anisotropy", job.options.maxAnisotropy},
                                 {"max_memory_bytes", job.maxMemory}};
    // === The band as built
    nlohmann::json bandSection = {
        {"voxels", band.size()},
        {"voxel_size", job.options.voxelSize},
        {"bbox_voxels", {bb.dim().x(), bb.dim().y(), bb.dim().z()}},
        {"bbox_min", {bb.min().x(), bb.min().y(), bb.min().z()}},
        {"mass", band.mass()},
        {"max_stencil_l1", st.maxStencilL1},
        {"max_stencil_l1_at_samples", job.resolution.maxStencilL1},
        {"evaluated_voxels", st.evaluated},
        {"bfs_levels", st.levels},
        {"estimated_voxels", job.estimate.voxels},
        {"estimated_evaluated_voxels", job.estimate.evaluated},
        {"regularised_voxels", st.regularised},
        {"median_mu_at_samples", st.medianSampleMu},
        {"stage_seconds",
         {{"model", st.modelSeconds}, {"kac_rice", st.kacRiceSeconds}, {"search", st.searchSeconds}, {"finish", st.finishSeconds}}}};
    nlohmann::json memory = {{"peak_rss_bytes", double(ru.ru_maxrss) * 1024.0},
                             {"band_bytes_per_voxel", job.bandBytesPerVoxel},
                             {"estimated_peak_bytes", job.estimate.memory.peakBytes()},
                             {"estimate_baseline_bytes", job.estimate.memory.baselineBytes}};
    return {{"input", std::move(input)},
            {"parameters", std::move(parameters)},
            {"band", std::move(bandSection)},
            {"warnings", job.warnings},
            {"memory", std::move(memory)}};
}

}  // namespace gpisvdb::app
