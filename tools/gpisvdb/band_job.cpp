#include "band_job.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>

#include "gpisvdb/app/band_metadata.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb::cli {

void addBandFlags(CLI::App& cmd, BandFlags& f) {
    addModelFlags(cmd, f.model, true);
    cmd.add_option("--iso", f.band.iso, "iso-value u of the surface phi = u (default: 0.5 for the winding model, 0 for regression)");
    cmd.add_option("--eta", f.band.etaRelative, "band threshold: keep mu > eta x (median mu at the samples' voxels) (> 0)")
        ->capture_default_str();
    const std::string k = numberText(kMuWidthFactor);
    auto* vs =
        cmd.add_option("--voxel-size", f.band.voxelSize,
                       "voxel size h in world units (default: min(h*, " + k + " w_mu), h* = l / max stencil width, w_mu mu's width)");
    cmd.add_option(
           "--resolution-scale", f.resolutionScale,
           "scales the default voxel size, h* and " + k + " w_mu alike (> 0; below 1 is finer: 0.6 for pictures of mu without moire)")
        ->excludes(vs)
        ->each([&f](const std::string&) { f.resolutionScaleGiven = true; })
        ->capture_default_str();
    cmd.add_option("--max-voxels", f.maxBandVoxels,
                   "band-voxel budget: a default voxel size that would make more band voxels is raised until the band "
                   "holds about this many (0: none; not applied to --voxel-size, nor to --resolution-scale unless given "
                   "with it)")
        ->each([&f](const std::string&) { f.maxBandVoxelsGiven = true; })
        ->capture_default_str();
    cmd.add_option("--voxel-values", f.voxelValues,
                   "mu and T at the voxels' centres (point), as their means along the voxels' axes (column), or as each "
                   "voxel's own share of the expected surface (voxel; the winding model's s is then at least 2h); auto: "
                   "column where the band-voxel budget raised the voxel size above 2 w_mu, else point")
        ->check(CLI::IsMember({"auto", "point", "voxel", "column"}))
        ->capture_default_str();
    cmd.add_option("--qmc", f.band.qmcSamples, "QMC points S for mu and T (>= 1)")->capture_default_str();
    cmd.add_option("--max-anisotropy", f.band.maxAnisotropy, "T is regularised to sqrt(lmax/lmin) <= this (>= 1)")->capture_default_str();
    cmd.add_option("--max-memory", f.maxMemory, "refuse bands needing more memory than this (default: half the RAM)");
    cmd.add_option("--report", f.report, "write a JSON report (parameters, band, timings, memory)");
    cmd.add_flag("--half", f.vdb.halfFloat, "store the .vdb grids as 16-bit floats (half the file, about 3 significant digits)");
    cmd.add_flag("--stencils", f.vdb.sellingStencils,
                 "also write the Selling stencils (selling_weight_0..5, selling_offset_0..5), from which L can be rebuilt");
    cmd.add_option("--fog-name", f.vdb.occupancyName,
                   "name of the occupancy fog volume P(phi > u), the probability of being inside (\"density\": what "
                   "Blender and Houdini render without set-up; \"\": not written)")
        ->capture_default_str()
        ->check([](const std::string& name) {
            const auto& taken = bandGridNames();
            return std::find(taken.begin(), taken.end(), name) == taken.end() ? std::string()
                                                                              : "'" + name + "' is one of the band's own grids";
        });
    cmd.add_flag("--nanovdb", f.vdb.nanoVdb, "write the grids as NanoVDB (also chosen by an output ending in .nvdb)");
}

void addBandArgs(CLI::App& cmd, BandArgs& a, const std::string& outputHelp) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    cmd.add_option("-o,--output", a.output, outputHelp)->required();
    addBandFlags(cmd, a.flags);
}

void addGreenArgs(CLI::App& cmd, GreenArgs& a, const std::string& outputHelp, SolverFlags solverFlags) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    cmd.add_option("--source", a.source, "source point X,Y,Z (world units); snapped to the nearest band voxel")
        ->required()
        ->delimiter(',')
        ->expected(3);
    cmd.add_option("-o,--output", a.output, outputHelp)->required();
    addBandFlags(cmd, a.flags);
    addSolverFlags(cmd, a.solver, solverFlags);
}

Vec3d GreenArgs::sourcePoint() const {
    if (source.size() != 3 || !Vec3d(source[0], source[1], source[2]).allFinite())
        throw ParameterError("--source needs three finite numbers X,Y,Z");
    return Vec3d(source[0], source[1], source[2]);
}

DefaultBandOptions defaultBandOptions(const BandFlags& flags) {
    DefaultBandOptions options;
    options.band = flags.band;
    options.resolutionScale = flags.resolutionScale;
    options.maxBandVoxels = flags.resolutionScaleGiven && !flags.maxBandVoxelsGiven ? 0.0 : flags.maxBandVoxels;
    if (flags.voxelValues != "auto") options.values = voxelValuesNamed(flags.voxelValues);
    options.maxMemory = flags.maxMemory.empty() ? 0 : parseBytes(flags.maxMemory);
    return options;
}

BandJob runBand(const InputData& data, const BandFlags& flags, const Progress& progress, const BandBuilder& build) {
    BandJob job = app::runBandJob(data, modelOptions(flags.model), defaultBandOptions(flags), progress, build);
    job.warnings = app::bandWarnings(job, app::FrontEnd::CommandLine);
    if (!flags.model.quiet) {
        if (job.model->input.normalsFlipped) std::cerr << "note: " << kNormalsFlippedNote << "\n";
        if (job.budgeted)
            std::cerr << "note: the band-voxel budget (--max-voxels " << std::llround(job.maxBandVoxels)
                      << (flags.maxBandVoxelsGiven || flags.budgetDefaultWhy.empty() ? "" : ", " + flags.budgetDefaultWhy)
                      << ") set the voxel size: the accuracy-driven " << numberText(job.accuracyVoxelSize) << " would make about "
                      << numberText(std::round(job.accuracyVoxels)) << " band voxels; " << job.voxelSizeNote << "\n";
        for (const std::string& w : job.warnings) std::cerr << "warning: " << w << "\n";
    }
    return job;
}

BandCommand startBandCommand(const std::string& input, const std::string& output, BandFlags& flags) {
    flags.vdb.nanoVdb = flags.vdb.nanoVdb || isNanoVdbPath(output);
    const InputData data = readInput(input);
    BandCommand c;
    c.out = std::make_unique<AtomicOutput>(output);
    c.report = optionalOutput(flags.report);
    c.progress = makeProgress(flags.model.quiet);
    c.job = runBand(data, flags, c.progress);
    return c;
}

void addSolverFlags(CLI::App& cmd, PcgOptions& o, SolverFlags which) {
    const bool distributed = which == SolverFlags::Distributed;
    cmd.add_option("--tolerance", o.tolerance,
                   distributed ? "CG relative residual to reach (>= 1e-12; PETSc solves in double)"
                               : "PCG relative residual to reach (>= 1e-12; below 1e-6 the PCG refines in double)")
        ->capture_default_str();
    cmd.add_option("--max-iterations", o.maxIterations, "PCG iteration cap (>= 1)")->capture_default_str();
    if (which == SolverFlags::ToleranceOnly) return;
    std::map<std::string, Preconditioner> names;  // gpisvdb-mpi's PETSc solve has neither ic nor aggregation
    for (const auto& [name, p] : preconditionerChoices())
        if (!distributed || (p != Preconditioner::IncompleteCholesky && p != Preconditioner::Aggregation)) names.emplace(name, p);
    cmd.add_option("--preconditioner", o.preconditioner,
                   std::string("auto (default: ") + (distributed ? "multigrid" : "aggregation") +
                       " from 1e5 voxels, Jacobi below), multigrid (hypre BoomerAMG)" +
                       (distributed ? " or jacobi"
                                    : ", aggregation (memory-light multigrid, docs/operators.md#aggregation), jacobi or ic "
                                      "(incomplete Cholesky)"))
        ->transform(CLI::CheckedTransformer(names));
}

void requireConverged(const PcgResult& r, const PcgOptions& options) {
    if (r.converged) return;
    const std::string at = "the PCG stopped at relative residual " + numberText(r.relativeResidual) + " after " +
                           std::to_string(r.iterations) + " iterations" +
                           (r.refinements > 0 ? " (" + std::to_string(r.refinements) + " refinements in double)" : "");
    if (r.iterations >= options.maxIterations) throw Error(at + ": raise --max-iterations");
    // Refinement in double stalls only where the operator's own rounding in double decides (or it is not
    // positive definite on this right-hand side): no tolerance below that can be met.
    throw Error(at + ", where it stopped gaining: use --tolerance " + numberText(2 * r.relativeResidual) + " or larger");
}

MemoryEstimate estimateStage(const BandJob& job, const std::string& stage, std::vector<std::pair<std::string, double>> parts) {
    // The stage's bytes go as h⁻³ with the band's voxels
    const double h = job.options.voxelSize;
    return estimateStageWithin(job.maxMemory, stage, "libraries, input, band", std::move(parts), [h](double need, double available) {
        return "use a voxel size (--voxel-size) of " + numberText(h * std::cbrt(need / available) * 1.1) + " or larger";
    });
}

std::vector<std::pair<std::string, double>> greenSolveBytes(std::size_t voxels, const PcgOptions& options, Preconditioner preconditioner) {
    std::vector<std::pair<std::string, double>> parts = {
        {"laplacian", laplacianOperatorBytes(voxels)}, {"pcg", pcgWorkBytes(voxels, options)}, {"rhs_and_solution", 8.0 * double(voxels)}};
    if (preconditioner == Preconditioner::Multigrid) parts.emplace_back("multigrid", multigridBytes(voxels));
    if (preconditioner == Preconditioner::Aggregation) parts.emplace_back("aggregation", aggregationBytes(voxels));
    if (preconditioner == Preconditioner::IncompleteCholesky) parts.emplace_back("incomplete_cholesky", incompleteCholeskyBytes(voxels));
    return parts;
}

openvdb::MetaMap bandMetadata(const BandJob& job, const BandFlags& flags) {
    return app::bandMetadata({commandLine(), job.source, flags.model.labels}, job.modelOptions, *job.model, job.options, job.resolution,
                             job.budgeted, job.result, flags.vdb);
}

void addGreenMetadata(openvdb::MetaMap& meta, const Vec3d& source, const openvdb::Coord& y, const PcgResult& solve) {
    meta.insertMeta("green_source", openvdb::Vec3DMetadata(openvdb::Vec3d(source.x(), source.y(), source.z())));
    meta.insertMeta("green_source_voxel", openvdb::Vec3IMetadata(openvdb::Vec3i(y.x(), y.y(), y.z())));
    meta.insertMeta("solver_iterations", openvdb::Int32Metadata(solve.iterations));
    meta.insertMeta("solver_relative_residual", openvdb::DoubleMetadata(solve.relativeResidual));
    meta.insertMeta("solver_float_residual", openvdb::DoubleMetadata(solve.floatResidual));
    meta.insertMeta("solver_refinements", openvdb::Int32Metadata(solve.refinements));
    meta.insertMeta("solver_preconditioner", openvdb::StringMetadata(preconditionerName(solve.preconditioner)));
}

}  // namespace gpisvdb::cli
