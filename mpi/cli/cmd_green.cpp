// gpisvdb-mpi green INPUT --source X,Y,Z -o OUT.vdb: gpisvdb green across MPI ranks, solved by PETSc (docs/mpi.md).
#include <chrono>
#include <iostream>

#include "gpisvdb/mpi/petsc_green.h"
#include "mpi_band_job.h"
#include "mpi_commands.h"

namespace gpisvdb::cli {

namespace {

using Args = GreenArgs;

/// The flags of `gpisvdb-mpi green`.
void addFlags(CLI::App& cmd, Args& a) {
    addGreenArgs(cmd, a, "output .vdb (band grids and 'green'; written by rank 0)", SolverFlags::Distributed);
}

/// The distributed solve in the terms of the PCG's result (the report's and the convergence check's).
PcgResult pcgResultOf(const mpi::DistributedGreen& g) {
    PcgResult solve;
    solve.iterations = g.iterations;
    solve.relativeResidual = solve.floatResidual = g.relativeResidual;
    solve.converged = g.converged;
    solve.preconditioner = g.preconditioner;
    return solve;
}

/// Rank 0's report: the band's, with the solve, the ranks, the source and the timings.
nlohmann::json greenReport(const BandJob& job, const Args& a, const mpi::DistributedGreen& g, const PcgResult& solve,
                           const openvdb::Coord& y, const nlohmann::json& mpiSection, double total) {
    nlohmann::json report = app::bandReport(job);
    report["solver"] = app::solverReport(solve, a.solver);
    report["solver"]["method"] = std::string("PETSc CG, ") + preconditionerName(g.preconditioner) +
                                 (g.preconditioner == Preconditioner::Multigrid ? " (hypre BoomerAMG)" : "");
    report["mpi"] = mpiSection;
    report["green"] = {{"source", a.source}, {"source_voxel", {y.x(), y.y(), y.z()}}, {"source_index", g.sourceIndex}};
    report["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"operators", g.assembleSeconds},
                           {"setup", g.setupSeconds},   {"solve", g.solveSeconds}, {"total", total}};
    report["outputs"] = {a.output};
    return report;
}

/// `gpisvdb-mpi green` once its flags are parsed, on every rank.
void execute(const mpi::Ranks& ranks, Args& a, Clock::time_point start) {
    Vec3d source;
    mpi::together(ranks, [&] {
        source = a.sourcePoint();
        checkPcgOptions(a.solver);
    });
    MpiBandCommand run = startMpiBandCommand(ranks, a.input, a.output, a.flags);
    const BandJob& job = run.job;
    const mpi::DistributedGreen g = greensFunctionPetsc(ranks, run.band, source, a.solver, run.progress);
    const PcgResult solve = pcgResultOf(g);
    mpi::together(ranks, [&] { requireConverged(solve, a.solver); });
    const std::vector<float> values = mpi::gatherChannel(ranks, g.local);
    const std::size_t ghosts = mpi::sum(ranks, g.ghosts);
    const nlohmann::json mpiSection = mpiReport(ranks, run.band, {{"halo_unknowns", ghosts}});
    gatherWholeBand(ranks, run, a.flags);  // after the solve: rank 0 never holds both
    mpi::together(ranks, [&] {
        if (ranks.rank != 0) return;
        const Band& band = job.result.band;
        openvdb::MetaMap meta = bandMetadata(job, a.flags);
        const openvdb::Coord y = band.coord[g.sourceIndex];
        addGreenMetadata(meta, source, y, solve);
        writeBandVdb(band, run.out->tempPath(), meta, {{"green", &values}}, {}, a.flags.vdb);
        run.out->commit();
        const double total = std::chrono::duration<double>(Clock::now() - start).count();
        if (run.report) commitReport(*run.report, greenReport(job, a, g, solve, y, mpiSection, total));
        if (!a.flags.model.quiet)
            std::cerr << "green: " << band.size() << " voxels on " << ranks.size << " ranks, PETSc CG ("
                      << preconditionerName(g.preconditioner) << ") " << g.iterations << " iterations to " << g.relativeResidual << ", "
                      << total << " s\n";
    });
}

}  // namespace

void addMpiGreen(CLI::App& app, Action& action, const mpi::Ranks& ranks) {
    addCommand<Args>(app, action, "green",
                     {"Green's function of the GPIS Laplacian (as gpisvdb green), solved across the MPI ranks by PETSc",
                      "Solves L f = M delta_y with PETSc's CG; the solver's settings can be overridden through PETSC_OPTIONS\n"
                      "(prefix green_, e.g. PETSC_OPTIONS='-green_pc_hypre_boomeramg_strong_threshold 0.6').\n"
                      "Example:\n  mpirun -n 4 gpisvdb-mpi green bunny.obj --source 0.5,6,1 -o green.vdb --sigma 1 --threads 1"},
                     addFlags, bandThreads<Args>, [&ranks](Args& a, Clock::time_point start) { execute(ranks, a, start); });
}

}  // namespace gpisvdb::cli
