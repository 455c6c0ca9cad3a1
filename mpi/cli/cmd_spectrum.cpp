// gpisvdb-mpi spectrum INPUT -k K -o OUT.vdb: gpisvdb spectrum across MPI ranks, solved by SLEPc (docs/mpi.md).
#include <chrono>
#include <iostream>

#include "gpisvdb/mpi/slepc_spectrum.h"
#include "mpi_band_job.h"
#include "mpi_commands.h"
#include "spectrum_job.h"

namespace gpisvdb::cli {

namespace {

openvdb::MetaMap spectrumMetadata(const BandJob& job, const SpectrumArgs& a, const mpi::DistributedSpectrum& s) {
    openvdb::MetaMap meta = bandMetadata(job, a.flags);
    for (Eigen::Index i = 0; i < s.values.size(); ++i)
        meta.insertMeta(eigenGridName(int(i)) + "_eigenvalue", openvdb::DoubleMetadata(s.values(i)));
    meta.insertMeta("spectrum_max_residual", openvdb::DoubleMetadata(s.residuals.maxCoeff()));
    return meta;
}

/// Rank 0's report: the band's, with the eigenpairs, the ranks and the timings.
nlohmann::json spectrumReport(const BandJob& job, const SpectrumArgs& a, const mpi::DistributedSpectrum& s,
                              const nlohmann::json& mpiSection, double total) {
    nlohmann::json report = app::bandReport(job);
    report["spectrum"] = slepcSpectrumReport(s);
    report["mpi"] = mpiSection;
    report["timings_s"] = {{"model", job.secondsModel},
                           {"band", job.secondsBand},
                           {"operators", s.assembleSeconds},
                           {"solve", s.solveSeconds},
                           {"total", total}};
    report["outputs"] = {a.output};
    return report;
}

/// `gpisvdb-mpi spectrum` once its flags are parsed, on every rank.
void execute(const mpi::Ranks& ranks, SpectrumArgs& a, Clock::time_point start) {
    mpi::together(ranks, [&] {
        if (a.eigen.count < 1) throw ParameterError("-k must be >= 1");
    });
    MpiBandCommand run = startMpiBandCommand(ranks, a.input, a.output, a.flags);
    const BandJob& job = run.job;
    const mpi::DistributedSpectrum s = mpi::spectrumSlepc(ranks, run.band, a.eigen, run.progress);
    std::vector<std::vector<float>> vectors;
    for (const std::vector<double>& v : s.local) {
        const std::vector<double> all = mpi::gatherChannel(ranks, v);
        vectors.emplace_back(all.begin(), all.end());  // float grids, as gpisvdb spectrum writes them
    }
    const std::size_t ghosts = mpi::sum(ranks, s.ghosts);
    const nlohmann::json mpiSection = mpiReport(ranks, run.band, {{"halo_unknowns", ghosts}});
    gatherWholeBand(ranks, run, a.flags);  // after the solve: rank 0 never holds both
    mpi::together(ranks, [&] {
        if (ranks.rank != 0) return;
        const Band& band = job.result.band;
        std::vector<NamedChannel> grids;
        for (std::size_t i = 0; i < vectors.size(); ++i) grids.push_back({eigenGridName(int(i)), &vectors[i]});
        const openvdb::MetaMap meta = spectrumMetadata(job, a, s);
        writeBandVdb(band, run.out->tempPath(), meta, grids, {}, a.flags.vdb);
        run.out->commit();
        const double total = std::chrono::duration<double>(Clock::now() - start).count();
        if (run.report) commitReport(*run.report, spectrumReport(job, a, s, mpiSection, total));
        if (!a.flags.model.quiet)
            std::cerr << "spectrum: " << band.size() << " voxels on " << ranks.size << " ranks, " << s.values.size()
                      << " eigenpairs, lambda " << s.values(0) << " ... " << s.values(s.values.size() - 1) << ", max residual "
                      << s.residuals.maxCoeff() << ", " << total << " s\n";
    });
}

}  // namespace

void addMpiSpectrum(CLI::App& app, Action& action, const mpi::Ranks& ranks) {
    addCommand<SpectrumArgs>(
        app, action, "spectrum",
        {"lowest eigenpairs of the GPIS Laplacian (as gpisvdb spectrum), solved across the MPI ranks by SLEPc",
         "lanczos: SLEPc Krylov-Schur on L^-1 M, L factored by MUMPS (auto up to 1e6 voxels); lobpcg: SLEPc LOBPCG\n"
         "preconditioned by hypre BoomerAMG. PETSC_OPTIONS overrides the solver's settings (prefix spectrum_).\n"
         "Example:\n  mpirun -n 4 gpisvdb-mpi spectrum bunny.obj -k 20 -o spectrum.vdb --sigma 1 --threads 1"},
        [](CLI::App& cmd, SpectrumArgs& a) {
            addSpectrumFlags(cmd, a, "output .vdb (band grids and eigen_000, eigen_001, ...; written by rank 0)");
        },
        bandThreads<SpectrumArgs>, [&ranks](SpectrumArgs& a, Clock::time_point start) { execute(ranks, a, start); });
}

}  // namespace gpisvdb::cli
