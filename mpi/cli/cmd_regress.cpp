// gpisvdb-mpi regress INPUT --data DATA.csv -o OUT.vdb: the band and its eigenpairs across MPI ranks (SLEPc), the
// regression on rank 0 from the gathered eigenvectors (docs/mpi.md).
#include <chrono>

#include "gpisvdb/mpi/slepc_spectrum.h"
#include "mpi_band_job.h"
#include "mpi_commands.h"
#include "regress_job.h"

namespace gpisvdb::cli {

namespace {

/// The eigenpairs as gpisvdb's spectrum returns them, the vectors gathered on rank 0 (every rank takes part).
EigenResult gatheredEigenpairs(const mpi::Ranks& ranks, const mpi::DistributedSpectrum& s) {
    EigenResult e;
    e.values = s.values;
    e.residuals = s.residuals;
    e.orthonormalityError = s.orthonormalityError;
    e.method = s.method;
    e.iterations = s.iterations;
    for (std::size_t i = 0; i < s.local.size(); ++i) {
        const std::vector<double> all = mpi::gatherChannel(ranks, s.local[i]);
        if (ranks.rank != 0) continue;
        if (i == 0) e.vectors.resize(Eigen::Index(all.size()), Eigen::Index(s.local.size()));
        e.vectors.col(Eigen::Index(i)) = Eigen::Map<const Eigen::VectorXd>(all.data(), Eigen::Index(all.size()));
    }
    return e;
}

/// `gpisvdb-mpi regress` once its flags are parsed, on every rank.
void execute(const mpi::Ranks& ranks, RegressArgs& a, Clock::time_point start) {
    RegressionOptions options;
    PointData points;
    mpi::together(ranks, [&] {
        options = regressionOptions(a);
        if (ranks.rank == 0) points = readPointData(a.data);
    });
    MpiBandCommand run = startMpiBandCommand(ranks, a.input, a.output, a.flags);
    // === The posterior's memory on rank 0, refused before the eigen solver runs: beside what rank 0 holds now
    //     it will hold the whole band, gathered, and the k eigenvectors (8 B per voxel each)
    mpi::together(ranks, [&] {
        if (ranks.rank != 0) return;
        const double voxels = double(run.band.globalSize), local = double(run.band.local.size());
        estimateRegression(
            run.job, options, points, run.band.globalSize, a.eigen.count,
            {{"gathered_band", (voxels - local) * run.band.local.bytesPerVoxel()}, {"eigenvectors", 8.0 * voxels * double(a.eigen.count)}},
            "regression on rank 0 (with the whole band and the eigenvectors, before the eigen solver runs)",
            "libraries, input, this rank's band");
    });
    const auto tSolve = Clock::now();
    const mpi::DistributedSpectrum s = mpi::spectrumSlepc(ranks, run.band, a.eigen, run.progress);
    const EigenResult e = gatheredEigenpairs(ranks, s);
    const double secondsSpectrum = std::chrono::duration<double>(Clock::now() - tSolve).count();
    const std::size_t ghosts = mpi::sum(ranks, s.ghosts);
    const nlohmann::json mpiSection = mpiReport(ranks, run.band, {{"halo_unknowns", ghosts}});
    gatherWholeBand(ranks, run, a.flags);  // after the eigen solve: rank 0 computes the posterior on it
    const nlohmann::json spectrumSection = slepcSpectrumReport(s);
    mpi::together(ranks, [&] {
        if (ranks.rank == 0)
            finishRegress(run.job, a, options, points, e, nullptr, secondsSpectrum, *run.out, run.report.get(), run.progress, start,
                          {{"mpi", mpiSection}, {"spectrum", spectrumSection}});
    });
}

}  // namespace

void addMpiRegress(CLI::App& app, Action& action, const mpi::Ranks& ranks) {
    addCommand<RegressArgs>(app, action, "regress",
                            {"Gaussian-process regression on the GPIS (as gpisvdb regress): eigenpairs across the MPI ranks by SLEPc",
                             "The eigenpairs are SLEPc's across the ranks (see spectrum); rank 0 gathers them with the band and\n"
                             "computes the posterior (its memory holds the band and the k eigenvectors in double).\n"
                             "Example:\n  mpirun -n 4 gpisvdb-mpi regress bunny.obj --data temperature.csv -o regression.vdb --threads 1"},
                            addRegressFlags, bandThreads<RegressArgs>,
                            [&ranks](RegressArgs& a, Clock::time_point start) { execute(ranks, a, start); });
}

}  // namespace gpisvdb::cli
