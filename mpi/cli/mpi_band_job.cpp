#include "mpi_band_job.h"

#include <sys/resource.h>

#include <exception>
#include <iostream>

namespace gpisvdb::cli {

MpiBandCommand startMpiBandCommand(const mpi::Ranks& ranks, const std::string& input, const std::string& output, BandFlags& flags) {
    flags.vdb.nanoVdb = flags.vdb.nanoVdb || isNanoVdbPath(output);
    MpiBandCommand c;
    InputData data;
    mpi::together(ranks, [&] {
        data = readInput(input);  // every rank reads the input and builds the same model
        if (ranks.rank == 0) {
            c.out = std::make_unique<AtomicOutput>(output);
            c.report = optionalOutput(flags.report);
        }
    });
    c.progress = makeProgress(flags.model.quiet || ranks.rank != 0);  // every rank polls Ctrl-C
    // The model, resolution and memory estimate are each rank's own work; the build is collective. A rank that fails
    // before the build joins the agreement the others hold at its start, so none waits in the search for it.
    bool started = false;
    BandBuilder build = [&](const GpisModel& model, const Samples& samples, const BandOptions& options, const Progress& p) {
        started = true;
        mpi::together(ranks, [] {});
        c.band = mpi::buildBandDistributed(ranks, model, samples, options, p);
        BandResult r;
        r.stats = c.band.stats;
        return r;
    };
    BandFlags quiet = flags;
    quiet.model.quiet = true;  // the warnings need the whole band: printed below, by rank 0
    try {
        c.job = runBand(data, quiet, c.progress, build);
    } catch (...) {
        if (started) throw;
        const std::exception_ptr e = std::current_exception();
        mpi::together(ranks, [&] { std::rethrow_exception(e); });
    }
    return c;
}

void gatherWholeBand(const mpi::Ranks& ranks, MpiBandCommand& c, const BandFlags& flags, bool keepLocal) {
    c.job.result.band = mpi::gatherBand(ranks, c.band);
    if (!keepLocal) c.band.local = Band();
    if (ranks.rank == 0) {
        c.job.warnings = app::bandWarnings(c.job, app::FrontEnd::CommandLine);
        if (!flags.model.quiet) {
            if (c.job.model->input.normalsFlipped) std::cerr << "note: " << kNormalsFlippedNote << "\n";
            for (const std::string& w : c.job.warnings) std::cerr << "warning: " << w << "\n";
        }
    }
}

nlohmann::json mpiReport(const mpi::Ranks& ranks, const mpi::DistributedBand& band, nlohmann::json extra) {
    const double bytes = mpi::sum(ranks, ranks.bytesSent), seconds = mpi::max(ranks, ranks.secondsExchanging);
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    const std::vector<double> peaks = mpi::allGather(ranks, std::vector<double>{double(ru.ru_maxrss) * 1024.0});
    nlohmann::json r = {{"ranks", ranks.size},
                        {"voxels_per_rank", band.counts},
                        {"search_voxels_per_rank", band.searchVoxels},
                        {"search_evaluated_per_rank", band.searchEvaluated},
                        {"balance_seconds", band.balanceSeconds},
                        {"bytes_exchanged", bytes},
                        {"max_seconds_exchanging", seconds},
                        {"peak_rss_bytes_per_rank", peaks}};
    for (auto it = extra.begin(); it != extra.end(); ++it) r[it.key()] = it.value();
    return r;
}

nlohmann::json slepcSpectrumReport(const mpi::DistributedSpectrum& s) {
    const std::vector<double> values(s.values.data(), s.values.data() + s.values.size()),
        residuals(s.residuals.data(), s.residuals.data() + s.residuals.size());
    return {{"method", s.method == EigenMethod::Lobpcg ? "SLEPc LOBPCG preconditioned by the multigrid (hypre BoomerAMG)"
                                                       : "SLEPc Krylov-Schur on L^-1 M, MUMPS Cholesky of L"},
            {"count", values.size()},
            {"eigenvalues", values},
            {"residuals", residuals},
            {"orthonormality_error", s.orthonormalityError},
            {"iterations", s.iterations}};
}

}  // namespace gpisvdb::cli
