// gpisvdb-mpi band INPUT -o OUT.vdb: gpisvdb band, built across MPI ranks (docs/mpi.md).
#include <chrono>
#include <iostream>

#include "mpi_band_job.h"
#include "mpi_commands.h"

namespace gpisvdb::cli {

namespace {

/// `gpisvdb-mpi band` once its flags are parsed: the band built across the ranks, gathered and written by rank 0.
void execute(const mpi::Ranks& ranks, BandArgs& a, Clock::time_point start) {
    MpiBandCommand run = startMpiBandCommand(ranks, a.input, a.output, a.flags);
    const nlohmann::json mpiSection = mpiReport(ranks, run.band);
    gatherWholeBand(ranks, run, a.flags);
    const BandJob& job = run.job;
    mpi::together(ranks, [&] {
        if (ranks.rank != 0) return;
        writeBandVdb(job.result.band, run.out->tempPath(), bandMetadata(job, a.flags), {}, {}, a.flags.vdb);
        run.out->commit();
        const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (run.report) {
            nlohmann::json report = app::bandReport(job);
            report["mpi"] = mpiSection;
            report["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"total", total}};
            report["outputs"] = {a.output};
            commitReport(*run.report, report);
        }
        if (!a.flags.model.quiet)
            std::cerr << "band: " << job.result.band.size() << " voxels of size " << job.options.voxelSize << " on " << ranks.size
                      << " ranks, mass " << job.result.band.mass() << ", " << total << " s\n";
    });
}

}  // namespace

void addMpiBand(CLI::App& app, Action& action, const mpi::Ranks& ranks) {
    addCommand<BandArgs>(
        app, action, "band",
        {"narrow band of the GPIS (as gpisvdb band), built across the MPI ranks",
         "The same grids and metadata as gpisvdb band; the report adds an 'mpi' section.\n"
         "Example:\n  mpirun -n 4 gpisvdb-mpi band bunny.obj -o bunny.vdb --sigma 1 --threads 1"},
        [](CLI::App& cmd, BandArgs& a) { addBandArgs(cmd, a, "output .vdb (written by rank 0)"); }, bandThreads<BandArgs>,
        [&ranks](BandArgs& a, Clock::time_point start) { execute(ranks, a, start); });
}

}  // namespace gpisvdb::cli
