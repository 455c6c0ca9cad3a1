#pragma once
// The band as every front end builds it (docs/band.md): the iso-value defaults to the model's own level, the voxel
// size to the resolution rule (paper Eq. 25 and μ's width; stencil/resolution.h), and a band whose estimated size
// would not fit in memory is refused before the model is evaluated at a single voxel.
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/core/memory_estimate.h"
#include "gpisvdb/model/load_model.h"
#include "gpisvdb/stencil/resolution.h"

namespace gpisvdb {

/// Bytes a band voxel holds once found, in the band's own storage (docs/memory.md#band): its coordinate, μ, T,
/// mean, σ, normal and Selling stencil.
constexpr double kFoundBytesPerVoxel = 104;
/// The index tree (an Int32Grid) per band voxel: 2 KB per 8³ leaf over the voxels it holds. Measured 14–36 on the
/// bunny's default bands (a thin shell fills a quarter of a leaf where the surface is flat, less where it curves).
constexpr double kIndexTreeBytesPerVoxel = 20;
/// The band's width beyond where μ > η, in voxels (half a voxel each side), fitted to measured bands.
constexpr double kBandShellVoxels = 1.0;
/// Bytes per evaluated voxel for the visited mask and the BFS frontier.
constexpr double kSearchBytesPerEvaluatedVoxel = 5;
/// Evaluated voxels per band voxel, at most (measured 1.43–1.56 on the bunny): sets the build's backstop.
constexpr double kEvaluatedPerBandVoxel = 1.6;
/// The largest BFS level's share of the evaluated voxels (measured 0.32–0.49 on the bunny, a sphere, a cloud).
constexpr double kLargestLevelShare = 0.35;
/// The share of the band found when the largest level is evaluated (measured 0.24–0.42).
constexpr double kFoundBeforeLargestLevel = 0.4;
/// The transient bytes per voxel in a batch (BandOptions::batchVoxels) being evaluated: coordinates and centres,
/// the Morton order, the model's 4×4 Gaussians and the double-precision voxels.
constexpr double kBatchBytesPerVoxel = 320;

/// The most band voxels accepted whatever the memory limit: fast marching handles 5.4e8, and at ≈ 180 bytes per
/// voxel while building and writing, 5e8 voxels already need 90 GB.
constexpr double kMaxBandVoxels = 5e8;

/// The default band-voxel budget (DefaultBandOptions::maxBandVoxels): the default voxel size is raised until the band
/// holds about this many voxels (docs/band.md#budget): what scans up to 1e5 points build in well under a minute on
/// 2 cores (docs/benchmarks.md#coarse-voxels).
constexpr double kDefaultMaxBandVoxels = 4e6;

/// With voxel or column values (BandOptions::values) the band is (kVoxelValueBandVolume·bandVolume + kVoxelValueShellVoxels·
/// area·h)/h³ voxels: the cubes' cross-sections reach ½ h ‖n‖₁ past their centres on each side (1.5 h on average over
/// the directions), and the μ profile's tails beyond them are thinner than μ's own (fitted to eight bands of sphere
/// clouds at h/w_μ 1.5–3, within 5 %).
constexpr double kVoxelValueShellVoxels = 1.5;
constexpr double kVoxelValueBandVolume = 0.6;

/// A band's size and memory, estimated before the model is evaluated at a single voxel.
struct BandEstimate {
    double voxels = 0;     ///< band voxels: (bandVolume + kBandShellVoxels·area·h) / h³
    double evaluated = 0;  ///< voxels evaluated: the band and its rejected shell, (bandVolume + 4·area·h) / h³
    /// The build's peak (the found voxels, the index tree, a channel gathered into leaf order, a batch in flight)
    /// or the .vdb write's (the band and its largest grid), whichever is larger, over the baseline.
    MemoryEstimate memory;
};

/// Peak bytes, above the resident set before it, of building a band of `voxels` band voxels that evaluates
/// `evaluated` voxels in batches of `batchVoxels` (buildBand), and of writing it (writeBandVdb). `firstLevel`: the BFS's
/// first level (the sample voxels and their neighbours), whose voxels are all held until η is known; where samples are
/// as dense as the voxels (10⁶-point scans) it is a large share of the band. 0: not counted (estimateBand).
double bandBuildBytes(double voxels, double evaluated, std::size_t batchVoxels, double firstLevel = 0);
double bandWriteBytes(double voxels);

/// The estimate for a band of cross-section `bandVolume` and surface `area` (Resolution::bandVolume and area; world
/// units³ and ²) at voxel size h, batch size and the resident set before the build (bytes), with `values` as
/// BandOptions::values.
BandEstimate estimateBand(double bandVolume, double area, double h, std::size_t batchVoxels, double baselineBytes,
                          VoxelValues values = VoxelValues::Point);

/// With the values left to the plan (DefaultBandOptions::values unset), column values where the band-voxel budget
/// raised h above this many w_μ, the centres' values below (and at a voxel size given): up to 2 w_μ both keep the sphere's area, energy and
/// l = 1 gap within 1 %, and the centres' cost a seventh of the columns' model evaluations and Kac–Rice (docs/benchmarks.md#column-values).
constexpr double kColumnValuesRatio = 2.0;
/// Gaussians a column-valued build holds per evaluated voxel at most (this round's and the last round's centres and
/// face neighbours; the first round, which at coarse voxels is most of the band, sets it), and bytes each.
constexpr double kColumnCentresPerEvaluatedVoxel = 1.3;
constexpr double kColumnCentreBytes = 168;

/// What builds the band once its options are resolved: buildBand by default; a distributed build (mpi/) returns this
/// process's part of the band with the whole band's statistics.
using BandBuilder = std::function<BandResult(const GpisModel&, const Samples&, const BandOptions&, const Progress&)>;

struct DefaultBandOptions {
    DefaultBandOptions() { band.iso = std::numeric_limits<double>::quiet_NaN(); }
    /// voxelSize 0: the default h of chooseResolution; iso NaN: the model's naturalIso(); maxVoxels is set from
    /// maxMemory.
    BandOptions band;
    double resolutionScale = 1.0;  ///< c of ResolutionOptions (> 0): scales the default voxel size
    double maxMemory = 0;          ///< bytes the band may need while it is built (> 0; 0: half the physical memory)
    /// The band-voxel budget: when band.voxelSize is 0 and the default h would make a band of more voxels than this
    /// (estimated), h is raised until it holds about this many (≥ 1000; 0: no budget). Ignored for a given voxel size.
    double maxBandVoxels = kDefaultMaxBandVoxels;
    /// Sets band.values; unset: column values where the budget raised h above kColumnValuesRatio·w_μ, else point.
    std::optional<VoxelValues> values;
    BandBuilder build;  ///< empty: buildBand
};

/// What buildDefaultBand will build, decided before the model is evaluated at a single voxel (planDefaultBand).
struct DefaultBandPlan {
    Resolution resolution;  ///< h*, w_μ and the default h at the samples
    BandOptions options;    ///< as used: voxel size, values and iso resolved, maxVoxels from the memory limit
    double maxMemory = 0;   ///< the memory limit as used, bytes
    BandEstimate estimate;  ///< size and memory estimated before the build
    /// The voxel size that accuracy alone asks for (resolution.h, or band.voxelSize when given) and the band voxels
    /// estimated there; budgeted is true when the band-voxel budget raised h above it.
    double accuracyVoxelSize = 0;
    double accuracyVoxels = 0;
    bool budgeted = false;
    double maxBandVoxels = 0;  ///< the budget as used (0: none)
};

struct DefaultBand : DefaultBandPlan {
    BandResult result;
};

/// h / w_μ of a band and how its values are sampled, in words for reports and messages, with where
/// the docs give their accuracy at each h / w_μ (docs/benchmarks.md#coarse-voxels).
std::string voxelSizeNote(const DefaultBandPlan& band);

/// Resolution, the band-voxel budget and the estimate (estimateBand), with buildDefaultBand's checks and errors: what a
/// default band will be, without building it (gpisvdb info's forecast).
DefaultBandPlan planDefaultBand(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options = {},
                                const Progress& progress = {});

/// With voxel values on a winding model, s is at least this × h: the voxel values take (φ, ∇φ) as linear across a
/// voxel (kacRiceVoxel), while γ ≈ Φ(−d/s) is linear only within ≈ s/2 of the surface. Measured on dense sphere clouds
/// (docs/band.md#coarse-voxels): the expected area loses 2.2 % at h = 0.92 s, 0.9 % at 0.59 s, 0.4 % at 0.44 s.
constexpr double kVoxelSmoothing = 2.0;

/// The smoothing that a plan asks of a winding model of smoothing s: kVoxelSmoothing·h where the plan takes voxel
/// values and s is below it; 0 when s may stay (and for the regression model, whose smoothing is its own).
double smoothingForPlan(const DefaultBandPlan& plan, const LoadedModel& model);

/// `first` planned again for a model rebuilt at smoothingForPlan(first, …): at first's voxel size and iso, with voxel
/// values, its budget and accuracy fields kept.
DefaultBandPlan replanForSmoothing(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options,
                                   const DefaultBandPlan& first, const Progress& progress = {});

/// planDefaultBand for a loaded model; where the plan takes voxel values at an h with s < kVoxelSmoothing·h (winding
/// model), `model` is replaced by one rebuilt from its samples at s = kVoxelSmoothing·h (withSmoothing; the one given
/// is left as it was) and the band planned again at that h, its budget and accuracy fields kept from the first plan.
DefaultBandPlan planDefaultBandFor(std::shared_ptr<const LoadedModel>& model, const ModelOptions& modelOptions,
                                   const DefaultBandOptions& options, const Progress& progress = {});

/// The band of a plan (planDefaultBand): `build` (empty: buildBand) with the plan's options.
/// \param model     the GPIS the plan was made for
/// \param samples   its samples
/// \param plan      the plan: resolution, options as used, memory limit, estimate
/// \param build     builds the band from the plan's options (empty: buildBand)
/// \param progress  passed to `build`
/// \return the plan with the band built
/// \throws what `build` throws (buildBand's errors)
/// \par Complexity
///   buildBand's at the plan's options; memory plan.estimate.memory.
/// \par Thread safety
///   As `build`.
DefaultBand buildPlannedBand(const GpisModel& model, const Samples& samples, const DefaultBandPlan& plan, const BandBuilder& build = {},
                             const Progress& progress = {});

/// planDefaultBand, then buildBand (or options.build).
/// \param model     the GPIS, world units
/// \param samples   its samples
/// \param options   the band's options; voxel size 0: the resolution rule and the band-voxel budget choose it
/// \param progress  reports the search; its interrupt stops it and the resolution before it (Cancelled)
/// \return the plan and the band
/// \throws ParameterError for bad options; MemoryLimitError (naming DefaultBandOptions::maxMemory and
///         BandOptions::voxelSize, with the voxel size that would fit) when the estimate exceeds kMaxBandVoxels voxels
///         or maxMemory bytes, before the model is evaluated at a voxel; Cancelled when interrupted
/// \par Complexity
///   The resolution at up to 200 000 of the samples, then buildBand's; memory estimate.memory.
/// \par Thread safety
///   As buildBand.
DefaultBand buildDefaultBand(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options = {},
                             const Progress& progress = {});

}  // namespace gpisvdb
