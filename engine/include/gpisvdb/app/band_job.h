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

/// Builds the default band of `model`: planDefaultBandFor, then buildPlannedBand with `build`. `job.warnings` is
/// left empty: the front end words them (bandWarnings).
/// \param model     the loaded model; where the plan's voxel size sets s (voxel values), the band is built on a
///                  copy rebuilt at that s and `model` is left as it was
/// \param asked     the settings `model` was loaded with (the report's and the rebuilt model's)
/// \param options   the band's options as asked: voxel size (0: the default rule), budget, values, memory limit
/// \param progress  reports the band's search; its interrupt stops it and the resolution before it (Cancelled)
/// \param build     builds the band from the resolved options (empty: buildBand; mpi/ passes its distributed build)
/// \return the band with its plan, model and settings, secondsBand and bandBytesPerVoxel set
/// \throws ParameterError for bad options; MemoryLimitError when the band would not fit the memory limit (before the
///         model is evaluated at a single voxel); Cancelled when interrupted
/// \par Complexity
///   The resolution at up to 200 000 of the samples, then O(E) model and Kac–Rice evaluations for E evaluated voxels
///   (estimate.evaluated, ≈ 1.5× the band), each O(log n) with Barnes–Hut over n samples and O(S) in the QMC count S.
///   Memory estimate.memory (docs/memory.md#band).
/// \par Thread safety
///   Reads `model` only: concurrent calls are safe. Parallel inside (TBB); the band is the same for any thread count.
BandJob buildBandJob(std::shared_ptr<const LoadedModel> model, const ModelOptions& asked, const DefaultBandOptions& options,
                     const Progress& progress = {}, const BandBuilder& build = {});

/// loadModel(data, asked), then buildBandJob; `source` is data.path and secondsModel the model's load.
/// \param data      the input as read (readInput, or a mesh or cloud made in memory)
/// \param asked     the model's settings (σ, smoothing, the model's kind, Barnes–Hut β)
/// \param options   the band's options, as for buildBandJob
/// \param progress  as for buildBandJob
/// \param build     as for buildBandJob
/// \return as buildBandJob's
/// \throws InputError for an input loadModel refuses (empty, non-finite, degenerate); ParameterError and
///         MemoryLimitError as loadModel and buildBandJob; Cancelled when interrupted
/// \par Complexity
///   loadModel's O(n log n) for n samples (their tree), then buildBandJob's.
/// \par Thread safety
///   Reads `data` only: concurrent calls are safe. Parallel inside (TBB); the result is the same for any thread count.
BandJob runBandJob(const InputData& data, const ModelOptions& asked, const DefaultBandOptions& options, const Progress& progress = {},
                   const BandBuilder& build = {});

/// The warnings for a built band, each naming the setting to change in the front end's words (docs/band.md#warnings):
/// a Barnes–Hut β below 6, a QMC count below 512, more than 1 % of the voxels with T regularised by the anisotropy cap.
std::vector<std::string> bandWarnings(const BandJob& job, FrontEnd frontEnd);

/// The report's input, parameters (relative and absolute), band, warnings and memory (the process's peak resident
/// set so far) sections (docs/band.md#report); the front end adds timings and its own sections.
nlohmann::json bandReport(const BandJob& job);

}  // namespace gpisvdb::app
