// gpisvdb green INPUT --source X,Y,Z -o OUT.vdb: the Green's function of the GPIS Laplacian (paper Alg. 1).
#include <chrono>
#include <iostream>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/tasks/green.h"

namespace gpisvdb::cli {

namespace {

struct Args : GreenArgs {
    Spill spill = Spill::Automatic;
};

/// The flags of `gpisvdb green`.
void addFlags(CLI::App& cmd, Args& a) {
    addGreenArgs(cmd, a, "output .vdb (band grids and 'green')", SolverFlags::Preconditioner);
    cmd.add_option("--spill", a.spill,
                   "auto (default), always or never: write the band's grids to a side file before the solve and free "
                   "their channels (44 B per voxel); auto does it when the solve would not fit --max-memory otherwise")
        ->transform(CLI::CheckedTransformer(
            std::map<std::string, Spill>{{"auto", Spill::Automatic}, {"always", Spill::Always}, {"never", Spill::Never}}));
}

/// Spill (docs/memory.md#spill): the band's own grids written ahead and their channels freed when asked, or, with
/// auto, when that makes the solve's `parts` fit; refused as it stands (before any file is written) when even that
/// would not. None when the grids stay in memory.
std::unique_ptr<SpilledBandGrids> spillForSolve(const Args& a, BandCommand& run, const std::vector<std::pair<std::string, double>>& parts) {
    Band& band = run.job.result.band;
    double stageBytes = 0;
    for (const auto& part : parts) stageBytes += part.second;
    const double held = settledResidentBytes(), freed = spillableChannelBytes(band);
    if (held - freed + stageBytes > run.job.maxMemory) {
        estimateStage(run.job, "Green's function solve", parts);  // throws: it does not fit as it stands
        return nullptr;
    }
    if (a.spill == Spill::Never || (a.spill == Spill::Automatic && held + stageBytes <= run.job.maxMemory)) return nullptr;
    std::unique_ptr<SpilledBandGrids> spilled;
    try {
        spilled = std::make_unique<SpilledBandGrids>(band, run.out->tempPath() + ".grids", a.flags.vdb);
    } catch (const OutputError& e) {
        throw OutputError(std::string(e.what()) +
                          " (the band's grids spilled before the solve; --spill never "
                          "keeps them in memory instead)");
    }
    releaseSpilledChannels(band);
    if (!a.flags.model.quiet)
        std::cerr << "green: the band's grids are written ahead to " << spilled->path() << ", freeing " << numberText(freed / 1e6)
                  << " MB for the solve\n";
    return spilled;
}

/// The report: the band's, with the solve and the source.
nlohmann::json greenReport(const BandJob& job, const Args& a, const GreenResult& g, const openvdb::Coord& y, bool spilled) {
    nlohmann::json report = app::bandReport(job);
    report["solver"] = app::solverReport(g.solver, a.solver);
    report["green"] = {
        {"source", a.source}, {"source_voxel", {y.x(), y.y(), y.z()}}, {"source_index", g.sourceIndex}, {"spilled_band_grids", spilled}};
    report["outputs"] = {a.output};
    return report;
}

/// `gpisvdb green` once its flags are parsed.
void execute(Args& a, Clock::time_point start) {
    const Vec3d source = a.sourcePoint();
    checkPcgOptions(a.solver);
    BandCommand run = startBandCommand(a.input, a.output, a.flags);
    const BandJob& job = run.job;
    Band& band = run.job.result.band;
    // The operator's and the solve's memory, estimated and refused before they allocate (docs/memory.md)
    const Preconditioner preconditioner =
        resolvePreconditioner(a.solver.preconditioner, band.size(), /*assemblable*/ true, /*bandLaplacian*/ true);
    std::vector<std::pair<std::string, double>> parts = greenSolveBytes(band.size(), a.solver, preconditioner);
    const std::unique_ptr<SpilledBandGrids> spilled = spillForSolve(a, run, parts);
    const MemoryEstimate memory = estimateStage(job, "Green's function solve", std::move(parts));
    const bool stageOnly = resetPeakResident();
    const auto tOps = Clock::now();
    const LaplacianOperator L(band);
    const double secondsOps = std::chrono::duration<double>(Clock::now() - tOps).count();
    const auto tSolve = Clock::now();
    const GreenResult g = greensFunction(band, L, source, a.solver, run.progress);
    const double secondsSolve = std::chrono::duration<double>(Clock::now() - tSolve).count();
    const double solvePeak = peakResidentBytes();
    requireConverged(g.solver, a.solver);
    openvdb::MetaMap meta = bandMetadata(job, a.flags);
    const openvdb::Coord y = band.coord[g.sourceIndex];
    addGreenMetadata(meta, source, y, g.solver);
    if (spilled) writeBandVdb(band, *spilled, run.out->tempPath(), meta, {{"green", &g.values}}, {}, a.flags.vdb);
    else writeBandVdb(band, run.out->tempPath(), meta, {{"green", &g.values}}, {}, a.flags.vdb);
    run.out->commit();
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    if (run.report) {
        nlohmann::json report = greenReport(job, a, g, y, bool(spilled));
        report["memory"]["stages"] = {{"green", memoryStageReport(memory, solvePeak, stageOnly)}};
        report["timings_s"] = {
            {"model", job.secondsModel}, {"band", job.secondsBand}, {"operators", secondsOps}, {"solve", secondsSolve}, {"total", total}};
        commitReport(*run.report, report);
    }
    if (!a.flags.model.quiet)
        std::cerr << "green: " << band.size() << " voxels, PCG (" << preconditionerName(g.solver.preconditioner) << ") "
                  << g.solver.iterations << " iterations to " << g.solver.relativeResidual << ", " << total << " s\n";
}

}  // namespace

void addGreen(CLI::App& app, Action& action) {
    addCommand<Args>(app, action, "green",
                     {"Green's function of the GPIS Laplacian from a source point, as a .vdb",
                      "Solves L f = M delta_y (delta_y: the Dirac of the measure mu at y, so that G(x,y) = G(y,x)).\n"
                      "Example:\n  gpisvdb green bunny.obj --source 0.5,6,1 -o green.vdb --sigma 1 --report green.json"},
                     addFlags, bandThreads<Args>, [](Args& a, Clock::time_point start) { execute(a, start); });
}

}  // namespace gpisvdb::cli
