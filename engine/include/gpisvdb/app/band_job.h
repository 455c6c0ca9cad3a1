#pragma once
// The default band as every front end makes it (docs/band.md): the model, the plan at the voxel size accuracy and the
// band-voxel budget choose, the model again at the analysis scale where that voxel size sets s, the band; then what
// the report and the warnings say of it. The command line, gpisvdb-mpi and the Python module all call these, so a
// band's report is the same from each.
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gpisvdb/app/parameter_names.h"
#include "gpisvdb/band/default_band.h"
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/load_model.h"

namespace gpisvdb::app {

/// A default band (its plan and result: DefaultBand) with the model it was built on and the settings that made it.
struct BandJob : DefaultBand {
    std::string source;                        ///< the input file's path ("numpy" for arrays)
    std::shared_ptr<const LoadedModel> model;  ///< the band's model: the one given, or rebuilt at the analysis scale
    ModelOptions modelOptions;                 ///< the model's settings as asked (labels left out: the model holds them)
    DefaultBandOptions requested;              ///< the band's options as asked (voxel size 0: the default)
    std::string voxelSizeNote;                 ///< voxelSizeNote(): h / w_μ, the values and their accuracy
    double secondsModel = 0;                   ///< wall time of loading the model (0 where it was given)
    double secondsBand = 0;                    ///< wall time of planning and building the band
    double bandBytesPerVoxel = 0;              ///< the band's, as built (a spill frees some of its channels later)
    /// Settings that change the result beyond its documented error (bandWarnings): the report's `warnings`.
    std::vector<std::string> warnings;
};

/// Builds the default band of `model` (built from `asked`): planDefaultBandFor, then buildPlannedBand with `build`
/// (empty: buildBand; mpi/ passes its distributed build). Throws what they throw (MemoryLimitError before the
/// model is evaluated at a voxel). `job.warnings` is left empty: the front end words them (bandWarnings).
BandJob buildBandJob(std::shared_ptr<const LoadedModel> model, const ModelOptions& asked, const DefaultBandOptions& options,
                     const Progress& progress = {}, const BandBuilder& build = {});

/// loadModel(data, asked), then buildBandJob; `source` is data.path.
BandJob runBandJob(const InputData& data, const ModelOptions& asked, const DefaultBandOptions& options, const Progress& progress = {},
                   const BandBuilder& build = {});

/// The warnings for a built band, each naming the setting to change in the front end's words (docs/band.md#warnings):
/// a Barnes–Hut β below 6, a QMC count below 512, more than 1 % of the voxels with T regularised by the anisotropy cap.
std::vector<std::string> bandWarnings(const BandJob& job, FrontEnd frontEnd);

/// The report's input, parameters (relative and absolute), band, warnings and memory (the process's peak resident
/// set so far) sections (docs/band.md#report); the front end adds timings and its own sections.
nlohmann::json bandReport(const BandJob& job);

}  // namespace gpisvdb::app
