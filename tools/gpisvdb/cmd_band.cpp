// gpisvdb band INPUT -o OUT.vdb: the narrow band with μ, T and the Selling stencils, as an OpenVDB file.
#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "common.h"
#include "gpisvdb/band/build_band.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/stencil/resolution.h"

namespace gpisvdb::cli {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// "8G", "512M", "1e9": bytes.
double parseBytes(const std::string& s) {
    char* end = nullptr;
    double v = std::strtod(s.c_str(), &end);
    const std::string unit(end);
    if (unit == "K" || unit == "k") v *= 1024.0;
    else if (unit == "M" || unit == "m") v *= 1024.0 * 1024.0;
    else if (unit == "G" || unit == "g") v *= 1024.0 * 1024.0 * 1024.0;
    else if (!unit.empty() || end == s.c_str()) throw ParameterError("--max-memory: expected bytes like 8G, 512M or 1e9, got '" + s + "'");
    if (!(v > 0) || !std::isfinite(v)) throw ParameterError("--max-memory must be > 0");
    return v;
}

double physicalMemory() { return double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE)); }

/// Peak bytes per evaluated voxel while the band is built (values of the visited voxels, the frontier's model
/// evaluations, the visited mask, then the band): measured ≈ 270 (bunny, 1.57 M evaluated voxels, peak RSS
/// 422 MB); 400 leaves headroom.
constexpr double kBuildBytesPerVoxel = 400;

}  // namespace

void addBand(CLI::App& app, Action& action) {
    auto* cmd = app.add_subcommand("band", "narrow band of the GPIS with mu, T and Selling stencils, as a .vdb");
    struct Args {
        std::string input, output, report, maxMemory;
        ModelFlags flags;
        BandOptions band;
        double resolutionScale = 1.0;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("INPUT", a->input, "mesh (.obj .off .ply .stl .vtp) or oriented cloud (.xyz .ply .vtp)")->required();
    cmd->add_option("-o,--output", a->output, "output .vdb")->required();
    addModelFlags(*cmd, a->flags, true);
    cmd->add_option("--iso", a->band.iso, "iso-value u of the surface phi = u")->capture_default_str();
    cmd->add_option("--eta", a->band.etaRelative, "band threshold: keep mu > eta x (median mu at the samples' voxels) (> 0)")
        ->capture_default_str();
    auto* vs = cmd->add_option("--voxel-size", a->band.voxelSize, "voxel size h in world units (default: min(h*, w_mu/2))");
    cmd->add_option("--resolution-scale", a->resolutionScale, "scales lambda_res = l in h* = lambda_res / max stencil width (> 0)")
        ->excludes(vs)->capture_default_str();
    cmd->add_option("--qmc", a->band.qmcSamples, "QMC points S for mu and T (>= 1)")->capture_default_str();
    cmd->add_option("--max-anisotropy", a->band.maxAnisotropy, "T is regularised to sqrt(lmax/lmin) <= this (>= 1)")
        ->capture_default_str();
    cmd->add_option("--max-memory", a->maxMemory, "refuse bands needing more memory than this (default: half the RAM)");
    cmd->add_option("--report", a->report, "write a JSON report (parameters, band, timings, memory)");
    cmd->footer("Writes grids mu, mean, stddev, T_diag, T_offdiag, normal, stencil_width (voxel centres at h*k).\n"
                "Example:\n  gpisvdb band bunny.obj -o bunny.vdb --sigma 1 --report bunny.json");
    cmd->callback([&action, a] {
        action = [a] {
            const auto start = Clock::now();
            const auto threads = limitThreads(a->flags.threads);
            const double maxMemory = a->maxMemory.empty() ? 0.5 * physicalMemory() : parseBytes(a->maxMemory);
            const InputData data = readInput(a->input);
            AtomicOutput out(a->output);
            std::unique_ptr<AtomicOutput> reportOut;
            if (!a->report.empty()) reportOut = std::make_unique<AtomicOutput>(a->report);
            const Progress progress = makeProgress(a->flags.quiet);

            // === Model
            const LoadedModel m = loadModel(data, a->flags);
            const double tModel = since(start);
            // === Resolution (paper Eq. 25 and μ's width)
            ResolutionOptions ro;
            ro.iso = a->band.iso;
            ro.qmcSamples = a->band.qmcSamples;
            ro.resolutionScale = a->resolutionScale;
            ro.maxAnisotropy = a->band.maxAnisotropy;
            const Resolution res = chooseResolution(*m.model, m.input.samples, ro);
            BandOptions bo = a->band;
            if (!(bo.voxelSize > 0)) bo.voxelSize = res.h;
            const double h = bo.voxelSize;
            if (!(a->band.etaRelative > 0)) throw ParameterError("--eta must be > 0");
            // === Estimate before allocating: area × (width where μ > η) / h³, plus the rejected shell
            double area = 0;
            for (const auto& w : m.input.samples.normal) area += w.norm();
            const double thickness = 2.0 * res.muWidth * std::sqrt(2.0 * std::max(0.0, std::log(1.0 / std::min(a->band.etaRelative, 0.5)))) + 2.0 * h;
            const double estimate = area * (thickness + 2.0 * h) / (h * h * h);
            if (estimate * kBuildBytesPerVoxel > maxMemory) {
                const double suggest = h * std::cbrt(estimate * kBuildBytesPerVoxel / maxMemory) * 1.1;
                throw ParameterError("the band would need about " + std::to_string(estimate) + " voxels (" +
                                     std::to_string(estimate * kBuildBytesPerVoxel / 1e9) + " GB) at voxel size " +
                                     std::to_string(h) + ", more than --max-memory allows: use --voxel-size " +
                                     std::to_string(suggest) + " or larger");
            }
            bo.maxVoxels = std::size_t(maxMemory / kBuildBytesPerVoxel);
            const auto tBand0 = Clock::now();
            const BandResult br = buildBand(*m.model, m.input.samples, bo, progress);
            const double tBand = since(tBand0);
            const Band& band = br.band;

            // === Output
            openvdb::MetaMap meta;
            const double ell = m.input.samples.lengthScale;
            meta.insertMeta("gpisvdb_version", openvdb::StringMetadata(GPISVDB_VERSION));
            meta.insertMeta("command_line", openvdb::StringMetadata(commandLine()));
            meta.insertMeta("input", openvdb::StringMetadata(data.path));
            meta.insertMeta("input_samples", openvdb::Int64Metadata(openvdb::Int64(m.input.samples.size())));
            meta.insertMeta("length_scale", openvdb::DoubleMetadata(ell));
            meta.insertMeta("sigma_rel", openvdb::DoubleMetadata(a->flags.sigmaRel));
            meta.insertMeta("sigma", openvdb::DoubleMetadata(m.input.sigma));
            meta.insertMeta("smoothing_rel", openvdb::DoubleMetadata(a->flags.smoothingRel));
            meta.insertMeta("smoothing", openvdb::DoubleMetadata(m.smoothing));
            meta.insertMeta("iso", openvdb::DoubleMetadata(bo.iso));
            meta.insertMeta("eta_rel", openvdb::DoubleMetadata(bo.etaRelative));
            meta.insertMeta("eta", openvdb::DoubleMetadata(br.stats.etaAbsolute));
            meta.insertMeta("voxel_size", openvdb::DoubleMetadata(h));
            meta.insertMeta("h_star", openvdb::DoubleMetadata(res.hStar));
            meta.insertMeta("mu_width", openvdb::DoubleMetadata(res.muWidth));
            meta.insertMeta("qmc_samples", openvdb::Int32Metadata(bo.qmcSamples));
            meta.insertMeta("beta", openvdb::DoubleMetadata(a->flags.beta));
            meta.insertMeta("exact", openvdb::BoolMetadata(a->flags.exact));
            meta.insertMeta("max_anisotropy", openvdb::DoubleMetadata(bo.maxAnisotropy));
            meta.insertMeta("band_voxels", openvdb::Int64Metadata(openvdb::Int64(band.size())));
            meta.insertMeta("band_mass", openvdb::DoubleMetadata(band.mass()));
            writeBandVdb(band, out.tempPath(), meta);
            out.commit();

            struct rusage ru {};
            getrusage(RUSAGE_SELF, &ru);
            const openvdb::CoordBBox bb = band.bbox();
            nlohmann::json report = {
                {"input", {{"path", data.path}, {"samples", m.input.samples.size()}, {"length_scale", ell},
                           {"kind", m.input.isSoup ? "triangle soup" : "oriented point cloud"},
                           {"skipped_zero_area", m.input.degenerateSkipped}}},
                {"parameters", {{"sigma_rel", a->flags.sigmaRel}, {"sigma", m.input.sigma},
                                {"smoothing_rel", a->flags.smoothingRel}, {"smoothing", m.smoothing},
                                {"iso", bo.iso}, {"eta_rel", bo.etaRelative}, {"eta", br.stats.etaAbsolute},
                                {"voxel_size", h}, {"h_star", res.hStar}, {"mu_width", res.muWidth},
                                {"resolution_scale", a->resolutionScale}, {"qmc_samples", bo.qmcSamples},
                                {"beta", a->flags.beta}, {"exact", a->flags.exact},
                                {"max_anisotropy", bo.maxAnisotropy}, {"max_memory_bytes", maxMemory}}},
                {"band", {{"voxels", band.size()}, {"voxel_size", h},
                          {"bbox_voxels", {bb.dim().x(), bb.dim().y(), bb.dim().z()}},
                          {"bbox_min", {bb.min().x(), bb.min().y(), bb.min().z()}},
                          {"mass", band.mass()}, {"max_stencil_l1", br.stats.maxStencilL1},
                          {"max_stencil_l1_at_samples", res.maxStencilL1},
                          {"evaluated_voxels", br.stats.evaluated}, {"bfs_levels", br.stats.levels},
                          {"regularised_voxels", br.stats.regularised},
                          {"median_mu_at_samples", br.stats.medianSampleMu}}},
                {"timings_s", {{"model", tModel}, {"band", tBand}, {"total", since(start)}}},
                {"memory", {{"peak_rss_bytes", double(ru.ru_maxrss) * 1024.0},
                            {"band_bytes_per_voxel", band.bytesPerVoxel()}}},
                {"outputs", {a->output}}};
            if (reportOut) {
                std::ofstream(reportOut->tempPath()) << report.dump(2) << "\n";
                reportOut->commit();
            }
            if (!a->flags.quiet)
                std::cerr << "band: " << band.size() << " voxels of size " << h << ", mass " << band.mass() << " (expected area), "
                          << since(start) << " s\n";
        };
    });
}

}  // namespace gpisvdb::cli
