#pragma once
// What every band-based command shares: its flags, building the band from an input, the .vdb metadata and the
// JSON report (docs/band.md, "The .vdb file" and "Report").
#include <CLI/CLI.hpp>
#include <limits>
#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include "common.h"
#include "gpisvdb/app/band_job.h"
#include "gpisvdb/app/solver_report.h"
#include "gpisvdb/band/default_band.h"
#include "gpisvdb/core/memory_estimate.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/solve/pcg.h"
#include "gpisvdb/stencil/resolution.h"
#include "memory_stage.h"

namespace gpisvdb::cli {

struct BandFlags {
    BandFlags() { band.iso = std::numeric_limits<double>::quiet_NaN(); }  // unset: the model's own level
    ModelFlags model;
    BandOptions band;
    double resolutionScale = 1.0;
    bool resolutionScaleGiven = false;             ///< --resolution-scale was given: the budget applies only with --max-voxels
    double maxBandVoxels = kDefaultMaxBandVoxels;  ///< --max-voxels (0: none)
    bool maxBandVoxelsGiven = false;
    std::string budgetDefaultWhy;      ///< why this command's default budget is not kDefaultMaxBandVoxels (the note says it)
    std::string voxelValues = "auto";  ///< --voxel-values: auto, point, voxel or column
    std::string maxMemory;             ///< "8G", "512M", "1e9"; empty: half the RAM
    std::string report;                ///< JSON report path; empty: none
    VdbWriteOptions vdb;               ///< --half, --stencils, --fog-name, --nanovdb (or an output ending in .nvdb)
};
void addBandFlags(CLI::App& cmd, BandFlags& flags);

/// What `band` and `green` (gpisvdb and gpisvdb-mpi alike) take: an input, an output and the band's flags.
struct BandArgs {
    std::string input, output;
    BandFlags flags;
};
/// INPUT, -o,--output (described by `outputHelp`) and the band's flags.
void addBandArgs(CLI::App& cmd, BandArgs& a, const std::string& outputHelp);

/// Which flags addSolverFlags registers.
enum class SolverFlags {
    ToleranceOnly,   ///< --tolerance and --max-iterations (the operator picks its own preconditioner)
    Preconditioner,  ///< also --preconditioner auto|multigrid|jacobi|ic
    Distributed,     ///< also --preconditioner auto|multigrid|jacobi (gpisvdb-mpi: PETSc double, no incomplete Cholesky)
};

/// What `green` adds: the source point (--source X,Y,Z, required) and the PCG's settings.
struct GreenArgs : BandArgs {
    std::vector<double> source;
    PcgOptions solver;
    /// The source as a point; throws a ParameterError unless --source gave three finite numbers.
    Vec3d sourcePoint() const;
};
/// INPUT, --source, -o,--output (`outputHelp`), the band's flags and the solver's (`solverFlags`).
void addGreenArgs(CLI::App& cmd, GreenArgs& a, const std::string& outputHelp, SolverFlags solverFlags);

/// --threads of a command that takes the band's flags as `flags` (addCommand's `threads`).
template <class Args>
int& bandThreads(Args& a) {
    return a.flags.model.threads;
}

/// The band every band command works on (app/band_job.h).
using BandJob = app::BandJob;

/// The engine's options for a default band from the flags (reads nothing; parses --max-memory).
DefaultBandOptions defaultBandOptions(const BandFlags& flags);

/// Model, resolution, memory check, band: the first half of every band command.
/// `build` replaces buildBand (a distributed build, mpi/); a rank other than 0 passes quiet flags.
BandJob runBand(const InputData& data, const BandFlags& flags, const Progress& progress, const BandBuilder& build = {});

/// What every band command opens before its own work: the input read, the output and (with --report) the report
/// file opened atomically, the progress bar; then the band built. An output ending in .nvdb sets
/// flags.vdb.nanoVdb.
struct BandCommand {
    std::unique_ptr<AtomicOutput> out;
    std::unique_ptr<AtomicOutput> report;  ///< null without --report
    Progress progress;
    BandJob job;
};
BandCommand startBandCommand(const std::string& input, const std::string& output, BandFlags& flags);

/// Whether a command writes the band's own grids to a side file before its long stage and frees their channels
/// (SpilledBandGrids, docs/memory.md#spill).
enum class Spill {
    Automatic,  ///< when the stage would not fit the memory limit otherwise
    Always,
    Never,
};

/// --tolerance, --max-iterations and (per `which`) --preconditioner, into `options`.
void addSolverFlags(CLI::App& cmd, PcgOptions& options, SolverFlags which);

/// Throws an Error naming the flag to change when a PCG solve stopped short of its tolerance.
void requireConverged(const PcgResult& result, const PcgOptions& options);

/// The estimate of a stage that allocates `parts` (bytes) on the band: the settled resident set now as its
/// baseline. Throws MemoryLimitError, before the stage allocates, when baseline + parts exceed the job's memory
/// limit, naming --max-memory and the voxel size that fits (the stage's bytes go as h⁻³ with the band's voxels).
MemoryEstimate estimateStage(const BandJob& job, const std::string& stage, std::vector<std::pair<std::string, double>> parts);

/// What a Green's function solve on `voxels` band voxels allocates, bytes by part (docs/memory.md): the matrix-free
/// L the PCG applies, its work vectors, the right-hand side and solution, and the set-up of `preconditioner` (the
/// aggregation multigrid sums L's edges into its coarse levels; hypre's multigrid assembles L and keeps its
/// hierarchy; the incomplete Cholesky assembles L and keeps its factor).
std::vector<std::pair<std::string, double>> greenSolveBytes(std::size_t voxels, const PcgOptions& options, Preconditioner preconditioner);

/// The Green's function's metadata: its source point and voxel, and the solve's iterations, residuals, refinements
/// and preconditioner (gpisvdb green and gpisvdb-mpi green write the same keys).
void addGreenMetadata(openvdb::MetaMap& meta, const Vec3d& source, const openvdb::Coord& sourceVoxel, const PcgResult& solve);

/// File metadata: version, command line, every parameter relative and absolute, input, band size and mass.
openvdb::MetaMap bandMetadata(const BandJob& job, const BandFlags& flags);

}  // namespace gpisvdb::cli
