// gpisvdb info INPUT: what the input holds once read, the absolute noise and smoothing it implies, and the forecast
// of the default band that `gpisvdb band` would build with the same flags (docs/band.md#forecast).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>

#include <tbb/global_control.h>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/band/band_forecast.h"
#include "gpisvdb/model/load_model.h"
#include "spectrum_job.h"

namespace gpisvdb::cli {

namespace {

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// The model loaded and the band planned as `gpisvdb <command>` does (both timed), then the pilot. A band that the
/// memory limit or the voxel cap refuses is a forecast too: the report's `refused` holds the message.
nlohmann::json forecastDefaultBand(const InputData& data, double readSeconds, const BandFlags& flags, const std::string& command) {
    const auto start = Clock::now();
    const ModelOptions mo = modelOptions(flags.model);
    // The model's own peak (its samples and tree while they are made) is measured: on large inputs it is the run's.
    resetPeakResident();
    auto model = std::make_shared<const LoadedModel>(loadModel(data, mo));
    const double modelSeconds = since(start), modelPeak = peakResidentBytes();
    const auto tPlan = Clock::now();
    nlohmann::json out = {{"read_seconds", readSeconds},
                          {"model_seconds", modelSeconds},
                          {"threads", tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)}};
    const Progress progress = makeProgress(true);  // no bar; Ctrl-C stops the pilot
    DefaultBandPlan plan;
    try {
        plan = planDefaultBandFor(model, mo, defaultBandOptions(flags), progress);
    } catch (const MemoryLimitError& e) {
        out["refused"] = e.what();
        std::cout << "default band: refused: " << e.what() << "\n";
        return out;
    }
    const double planSeconds = since(tPlan);
    const BandForecast f = forecastBand(*model->model, model->input.samples, plan, {}, progress);
    const double total = readSeconds + modelSeconds + planSeconds + f.buildSeconds + f.writeSeconds;
    const double peak = std::max(modelPeak, f.peakBytes);
    out.update({{"voxel_size", plan.options.voxelSize},
                {"voxel_size_by_budget", plan.budgeted},
                {"accuracy_voxel_size", plan.accuracyVoxelSize},
                {"accuracy_voxels", plan.accuracyVoxels},
                {"max_band_voxels", plan.maxBandVoxels},
                {"mu_width", plan.resolution.muWidth},
                {"voxel_size_note", voxelSizeNote(plan)},
                {"smoothing", model->smoothing},
                {"normals_flipped", model->input.normalsFlipped},
                {"smoothing_set_by", smoothingSourceName(model->smoothingSource)},
                {"model_samples", model->modelSamples},
                {"voxels", f.voxels},
                {"evaluated_voxels", f.evaluated},
                {"peak_bytes", peak},
                {"model_peak_bytes", modelPeak},
                {"band_peak_bytes", f.peakBytes},
                {"pilot_voxels", f.pilotVoxels},
                {"pilot_seconds", f.pilotSeconds},
                {"resolution_seconds", planSeconds},
                {"band_seconds", f.buildSeconds},
                {"write_seconds", f.writeSeconds},
                {"seconds", total}});
    const auto millions = [](double n) { return numberText(std::round(n / 1e3) / 1e3) + " M"; };
    std::cout << "default band (what `gpisvdb " << command << "` with these flags would build; a forecast, docs/band.md#forecast):\n"
              << "  " << voxelSizeNote(plan) << "\n";
    if (model->input.normalsFlipped) std::cout << "  normals:     " << kNormalsFlippedNote << "\n";
    if (plan.budgeted)
        std::cout << "  budget:      the band-voxel budget (--max-voxels " << std::llround(plan.maxBandVoxels)
                  << ") set the voxel size; accuracy alone asks " << numberText(plan.accuracyVoxelSize) << " for about "
                  << millions(plan.accuracyVoxels) << " voxels\n";
    std::cout << "  smoothing:   " << numberText(model->smoothing) << " (set by the " << smoothingSourceName(model->smoothingSource)
              << ")\n";
    if (model->modelSamples && model->modelSamples < model->input.samples.size())
        std::cout << "  model:       the samples merged into " << model->modelSamples << " Gaussian dipoles (cells of "
                  << numberText(mo.mergeRel) << " x s; docs/math.md#merging)\n";
    std::cout << "  voxels:      about " << millions(f.voxels) << " (" << millions(f.evaluated) << " evaluated)\n"
              << "  memory:      about " << numberText(peak / 1e9) << " GB at its peak (the model's " << numberText(modelPeak / 1e9)
              << " GB as measured now, the band's " << numberText(f.peakBytes / 1e9) << " GB)\n"
              << "  time:        about " << numberText(total) << " s on " << out["threads"].get<int>() << " threads: reading "
              << numberText(readSeconds) << " s, model " << numberText(modelSeconds) << " s and resolution " << numberText(planSeconds)
              << " s (as measured now), band " << numberText(f.buildSeconds) << " s, .vdb " << numberText(f.writeSeconds) << " s\n";
    return out;
}

}  // namespace

namespace {

struct Args {
    std::string input;
    BandFlags flags;
    bool forecast = true;
    std::string forCommand = "band";  ///< --for: whose default band to forecast
};

/// The flags of `gpisvdb info`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    addBandFlags(cmd, a.flags);
    cmd.add_flag("!--no-forecast", a.forecast, "describe the input only: no model, no band forecast");
    cmd.add_option("--for", a.forCommand,
                   "forecast the band this command builds: band (also green, geodesic, ...: the same band) or spectrum / "
                   "regress (their smaller default --max-voxels, docs/spectrum.md#budget)")
        ->check(CLI::IsMember({"band", "spectrum", "regress"}))
        ->capture_default_str();
}

/// σ as the model takes it: σ_rel·ℓ, or each point's own (a cloud with a σ per point, world units).
std::string noiseLine(const InputSamples& s, const ModelFlags& flags) {
    std::ostringstream line;
    if (s.absoluteNoise) line << "each point's own (the file's), median " << medianPositionStd(s.samples) << " (world units)";
    else line << flags.sigmaRel << " x l = " << s.sigma;
    return line.str();
}

/// The winding model's s and what set it, as loadModel chooses it (docs/math.md#smoothing).
std::string smoothingLine(const InputSamples& s, const ModelFlags& flags) {
    ModelOptions options;
    options.smoothingRel = flags.smoothingRel;
    options.noiseSmoothing = flags.noiseSmoothing;
    const auto [smoothing, source] = windingSmoothing(s, options);
    std::ostringstream line;
    if (source == SmoothingSource::Noise)
        line << options.noiseSmoothing << " x median sigma = " << smoothing << " (set by the noise, above " << options.smoothingRel
             << " x l = " << options.smoothingRel * s.samples.lengthScale << ")";
    else line << options.smoothingRel << " x l = " << smoothing;
    return line.str();
}

/// The samples (a triangle's or a point's position, normal and their covariances), described on stdout: estimated and
/// refused before they are made, measured over it (docs/memory.md#info). The input, read in whole before, is the
/// baseline; no setting makes fewer samples. The report's samples stage and input; the samples are freed on return
/// (the band command holds the input and the model only).
nlohmann::json describeSamples(const InputData& data, const ModelFlags& flags, double limit) {
    const MemoryEstimate memory = estimateStageWithin(limit, "sampling of the input", "libraries, the input", makeSamplesBytes(data),
                                                      [](double, double) { return std::string("raise it"); });
    const bool stageOnly = resetPeakResident();
    const InputSamples s = makeSamples(data, {flags.sigmaRel});
    const double peak = peakResidentBytes();
    Vec3d lo = s.samples.position[0], hi = lo;
    for (const auto& p : s.samples.position) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const double ell = s.samples.lengthScale;
    std::cout << "input:        " << data.path << " (" << (s.isSoup ? "triangle soup" : "oriented point cloud") << ")\n"
              << "samples:      " << s.samples.size() << "\n"
              << "length scale: " << ell
              << (s.isSoup             ? " (mean edge length)"
                  : s.lengthScaleGiven ? " (given in the file)"
                                       : " (sqrt(area / points))")
              << "\n"
              << "bbox min:     " << lo.transpose() << "\n"
              << "bbox max:     " << hi.transpose() << "\n"
              << "sigma:        " << noiseLine(s, flags) << "\n"
              << "smoothing:    " << smoothingLine(s, flags) << "\n"
              << "skipped:      " << s.degenerateSkipped << " zero-area triangles\n"
              << "triangulated: " << data.polygonsTriangulated << " polygons with more than 3 corners (fans)\n";
    nlohmann::json report = stageReport("samples", memoryStageReport(memory, peak, stageOnly));
    report["input"] = {{"path", data.path}, {"samples", s.samples.size()}, {"kind", s.isSoup ? "triangle soup" : "oriented point cloud"}};
    return report;
}

/// `gpisvdb info` once its flags are parsed.
void execute(Args& a) {
    const ModelFlags& flags = a.flags.model;
    if (!(flags.smoothingRel > 0)) throw ParameterError("--smoothing must be > 0");
    const double limit = memoryLimit({a.flags.maxMemory, a.flags.report});
    const auto start = Clock::now();
    const InputData data = readInput(a.input);
    const double readSeconds = since(start);
    std::unique_ptr<AtomicOutput> reportOut = optionalOutput(a.flags.report);
    nlohmann::json report = describeSamples(data, flags, limit);
    if (a.forCommand != "band" && !a.flags.maxBandVoxelsGiven) eigenBandBudget(a.flags);
    if (a.forecast) report["forecast"] = forecastDefaultBand(data, readSeconds, a.flags, a.forCommand);
    if (reportOut) commitReport(*reportOut, report);
}

}  // namespace

void addInfo(CLI::App& app, Action& action) {
    addCommand<Args>(app, action, "info",
                     {"describe an input (samples, length scale, bounding box, what was skipped) "
                      "and forecast the default band: voxel size, voxels, memory, time",
                      "The forecast takes the band command's flags and builds the model (its time is measured, not predicted).\n"
                      "Example:\n  gpisvdb info bunny.obj --sigma 0.25"},
                     addFlags, bandThreads<Args>, [](Args& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
