// gpisvdb band INPUT -o OUT.vdb: the narrow band with μ and T (and, with --stencils, the Selling stencils) as an OpenVDB file.
#include <chrono>
#include <iostream>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/output/write_vdb.h"

namespace gpisvdb::cli {

namespace {

/// `gpisvdb band` once its flags are parsed.
void execute(BandArgs& a, Clock::time_point start) {
    BandCommand run = startBandCommand(a.input, a.output, a.flags);
    const BandJob& job = run.job;
    writeBandVdb(job.result.band, run.out->tempPath(), bandMetadata(job, a.flags), {}, {}, a.flags.vdb);
    run.out->commit();
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (run.report) {
        nlohmann::json report = app::bandReport(job);
        report["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"total", total}};
        report["outputs"] = {a.output};
        commitReport(*run.report, report);
    }
    if (!a.flags.model.quiet)
        std::cerr << "band: " << job.result.band.size() << " voxels of size " << job.options.voxelSize << ", mass "
                  << job.result.band.mass() << " (expected area), " << total << " s\n";
}

}  // namespace

void addBand(CLI::App& app, Action& action) {
    addCommand<BandArgs>(
        app, action, "band",
        {"narrow band of the GPIS with mu, T and stencil widths (with --stencils the Selling stencils), as a .vdb",
         "Writes grids mu, mean, stddev, T_diag, T_offdiag, normal, stencil_width (voxel centres at h*k) and\n"
         "density, the probability of being inside (--fog-name); an output ending in .nvdb is NanoVDB;\n"
         "with --stencils also selling_weight_0..5 and selling_offset_0..5 (L can be rebuilt from them).\n"
         "Example:\n  gpisvdb band bunny.obj -o bunny.vdb --sigma 1 --report bunny.json"},
        [](CLI::App& cmd, BandArgs& a) { addBandArgs(cmd, a, "output .vdb"); }, bandThreads<BandArgs>, execute);
}

}  // namespace gpisvdb::cli
