#include "regress_job.h"

#include <cmath>
#include <iostream>
#include <limits>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/write_vdb.h"
#include "spectrum_job.h"

namespace gpisvdb::cli {

void addRegressFlags(CLI::App& cmd_, RegressArgs& args) {
    CLI::App* cmd = &cmd_;
    RegressArgs* a = &args;
    cmd->add_option("INPUT", a->input, kInputHelp)->required();
    cmd->add_option("--data", a->data, "CSV of x,y,z,value[,noise] (world units; noise: std of the value, 0 = exact)")->required();
    cmd->add_option("-o,--output", a->output, "output .vdb (band grids, regression_mean, regression_variance)")->required();
    cmd->add_option("--nu", a->nu, "Matern smoothness: 0.5, 1.5, 2.5, any value > 0, or inf (squared exponential)")->capture_default_str();
    cmd->add_option("--kappa", a->kappa, "Matern length scale kappa (world units, > 0; default 0.1 sqrt(expected area))");
    cmd->add_option("--amplitude", a->amplitude, "prior variance (data units^2, > 0; default the variance of the values)");
    addEigenFlags(*cmd, a->eigen);
    addBandFlags(*cmd, a->flags);
}

RegressionOptions regressionOptions(const RegressArgs& a) {
    RegressionOptions ro;
    if (a.nu == "inf" || a.nu == "infinity") {
        ro.kernel.nu = std::numeric_limits<double>::infinity();
    } else {
        std::size_t used = 0;
        try {
            ro.kernel.nu = std::stod(a.nu, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != a.nu.size() || !(ro.kernel.nu > 0) || !std::isfinite(ro.kernel.nu))
            throw ParameterError("--nu must be a number > 0 or inf, got '" + a.nu + "'");
    }
    if (a.kappa < 0 || !std::isfinite(a.kappa)) throw ParameterError("--kappa must be > 0");
    if (a.amplitude < 0 || !std::isfinite(a.amplitude)) throw ParameterError("--amplitude must be > 0");
    if (a.eigen.count < 1) throw ParameterError("-k must be >= 1");
    ro.kernel.kappa = a.kappa;
    if (a.amplitude > 0) {
        ro.kernel.amplitude = a.amplitude;
        ro.amplitudeFromData = false;
    }
    return ro;
}

MemoryEstimate estimateRegression(const BandJob& job, const RegressionOptions& options, const PointData& points, std::size_t voxels, int k,
                                  std::vector<std::pair<std::string, double>> ahead, const std::string& stage, const std::string& held) {
    std::vector<std::pair<std::string, double>> parts = std::move(ahead);
    double dataBytes = 0;  // the features and the solve go with the data points and k, not the band
    for (auto& p : regressionBytes(voxels, points, k, options)) {
        if (p.first != "posterior_on_band") dataBytes += p.second;
        parts.push_back(std::move(p));
    }
    const double h = job.options.voxelSize;
    const std::size_t m = points.value.size();
    return estimateStageWithin(job.maxMemory, stage, held, std::move(parts), [&](double need, double available) {
        if (dataBytes >= 0.9 * available)
            return "use fewer data points (--data holds " + std::to_string(m) + ") or fewer eigenpairs (-k " + std::to_string(k) + ")";
        // The rest (the eigenvectors, the posterior on the band, the gathered band) goes as h⁻³
        return "use a voxel size (--voxel-size) of " + numberText(h * std::cbrt((need - dataBytes) / (available - dataBytes)) * 1.1) +
               " or larger";
    });
}

void finishRegress(const BandJob& job, const RegressArgs& args, const RegressionOptions& options, const PointData& points,
                   const EigenResult& e, const nlohmann::json& spectrumStage, double secondsSpectrum, AtomicOutput& out,
                   AtomicOutput* report, const Progress& progress, std::chrono::steady_clock::time_point start,
                   const nlohmann::json& extra) {
    const Band& band = job.result.band;
    // The regression's own vectors beside the eigenpairs, estimated again now that they are held (the command
    // refused it before the eigen solver ran: estimateRegression), and measured over them (docs/memory.md#regression)
    const MemoryEstimate regressionMemory =
        estimateRegression(job, options, points, band.size(), int(e.values.size()), {}, "regression", "libraries, input, band, eigenpairs");
    const bool regressionOnly = resetPeakResident();
    const auto tRegress = Clock::now();
    progress.update("regression", 0);
    const RegressionResult r = gpRegression(band, e, points, options, progress.interruptOnly());
    progress.update("regression", 1);
    const double regressionPeak = peakResidentBytes();
    const double secondsRegress = std::chrono::duration<double>(Clock::now() - tRegress).count();
    openvdb::MetaMap meta = bandMetadata(job, args.flags);
    meta.insertMeta("regression_nu", openvdb::DoubleMetadata(options.kernel.nu));
    meta.insertMeta("regression_kappa", openvdb::DoubleMetadata(r.kappa));
    meta.insertMeta("regression_amplitude", openvdb::DoubleMetadata(r.amplitude));
    meta.insertMeta("regression_prior_mean", openvdb::DoubleMetadata(r.priorMean));
    meta.insertMeta("regression_data", openvdb::StringMetadata(args.data));
    meta.insertMeta("regression_points", openvdb::Int64Metadata(openvdb::Int64(points.value.size())));
    meta.insertMeta("regression_eigenpairs", openvdb::Int32Metadata(int(e.values.size())));
    writeBandVdb(band, out.tempPath(), meta, {{"regression_mean", &r.mean, float(r.priorMean)}, {"regression_variance", &r.variance}}, {},
                 args.flags.vdb);
    out.commit();
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    if (report) {
        nlohmann::json json = app::bandReport(job);
        json["spectrum"] = spectrumReport(e);
        json["memory"]["stages"] = {{"spectrum", spectrumStage},
                                    {"regression", memoryStageReport(regressionMemory, regressionPeak, regressionOnly)}};
        const std::vector<double> meanAt(r.meanAtData.data(), r.meanAtData.data() + r.meanAtData.size());
        const std::vector<double> varAt(r.varianceAtData.data(), r.varianceAtData.data() + r.varianceAtData.size());
        json["regression"] = {{"data", args.data},
                              {"points", points.value.size()},
                              {"nu", std::isinf(options.kernel.nu) ? nlohmann::json("inf") : nlohmann::json(options.kernel.nu)},
                              {"kappa", r.kappa},
                              {"amplitude", r.amplitude},
                              {"prior_mean", r.priorMean},
                              {"solve", r.weightSpace ? "weight space (k x k)" : "function space (m x m)"},
                              {"mean_at_data", meanAt},
                              {"variance_at_data", varAt}};
        json["timings_s"] = {{"model", job.secondsModel},
                             {"band", job.secondsBand},
                             {"spectrum", secondsSpectrum},
                             {"regression", secondsRegress},
                             {"total", total}};
        json["outputs"] = {args.output};
        for (auto it = extra.begin(); it != extra.end(); ++it) json[it.key()] = it.value();
        commitReport(*report, json);
    }
    if (!args.flags.model.quiet)
        std::cerr << "regress: " << band.size() << " voxels, " << points.value.size() << " data points, " << e.values.size()
                  << " eigenpairs, kappa " << r.kappa << ", " << total << " s\n";
}

}  // namespace gpisvdb::cli
