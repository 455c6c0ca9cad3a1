#pragma once
// The band as every front end builds it (docs/band.md): the iso-value defaults to the model's own level, the voxel
// size to the resolution rule (paper Eq. 25 and μ's width; stencil/resolution.h), and a band whose estimated size
// would not fit in memory is refused before the model is evaluated at a single voxel.
#include <cstddef>
#include <functional>
#include <limits>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/core/memory_estimate.h"
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

/// A band's size and memory, estimated before the model is evaluated at a single voxel.
struct BandEstimate {
    double voxels = 0;     ///< band voxels: (bandVolume + kBandShellVoxels·area·h) / h³
    double evaluated = 0;  ///< voxels evaluated: the band and its rejected shell, (bandVolume + 4·area·h) / h³
    /// The build's peak (the found voxels, the index tree, a channel gathered into leaf order, a batch in flight)
    /// or the .vdb write's (the band and its largest grid), whichever is larger, over the baseline.
    MemoryEstimate memory;
};

/// Peak bytes, above the resident set before it, of building a band of `voxels` band voxels that evaluates
/// `evaluated` voxels in batches of `batchVoxels` (buildBand), and of writing it (writeBandVdb).
double bandBuildBytes(double voxels, double evaluated, std::size_t batchVoxels);
double bandWriteBytes(double voxels);

/// The estimate for a band of cross-section `bandVolume` and surface `area` (Resolution::bandVolume and area; world
/// units³ and ²) at voxel size h, batch size and the resident set before the build (bytes).
BandEstimate estimateBand(double bandVolume, double area, double h, std::size_t batchVoxels, double baselineBytes);

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
    BandBuilder build;             ///< empty: buildBand
};

struct DefaultBand {
    Resolution resolution;  ///< h*, w_μ and the default h at the samples
    BandOptions options;    ///< as used: voxel size and iso resolved, maxVoxels from the memory limit
    double maxMemory = 0;   ///< the memory limit as used, bytes
    BandEstimate estimate;  ///< size and memory estimated before the build
    BandResult result;
};

/// Resolution, estimate (estimateBand), then buildBand. Throws ParameterError for bad options, MemoryLimitError
/// (naming DefaultBandOptions::maxMemory and BandOptions::voxelSize, with the voxel size that would fit) when the
/// estimate exceeds kMaxBandVoxels voxels or maxMemory bytes, and Cancelled when `progress` asks to stop.
DefaultBand buildDefaultBand(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options = {},
                             const Progress& progress = {});

}  // namespace gpisvdb
