#pragma once
// The band as every front end builds it (docs/band.md): the iso-value defaults to the model's own level, the voxel
// size to the resolution rule (paper Eq. 25 and μ's width; stencil/resolution.h), and a band whose estimated size
// would not fit in memory is refused before the model is evaluated at a single voxel.
#include <cstddef>
#include <limits>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/stencil/resolution.h"

namespace gpisvdb {

/// Peak bytes per evaluated voxel while the band is built (values of the visited voxels, the frontier's model
/// evaluations, the visited mask, then the band): measured ≈ 270 (bunny, 1.57 M evaluated voxels, peak RSS
/// 422 MB); 400 leaves headroom.
constexpr double kBuildBytesPerVoxel = 400;

/// The most band voxels accepted whatever the memory limit: fast marching handles 5.4e8, and at ≈ 400 bytes per
/// voxel while building, 5e8 voxels already need 200 GB.
constexpr double kMaxBandVoxels = 5e8;

/// Bytes of physical memory of this machine.
double physicalMemory();

struct DefaultBandOptions {
    DefaultBandOptions() { band.iso = std::numeric_limits<double>::quiet_NaN(); }
    /// voxelSize 0: the default h of chooseResolution; iso NaN: the model's naturalIso(); maxVoxels is set from
    /// maxMemory.
    BandOptions band;
    double resolutionScale = 1.0;  ///< c of ResolutionOptions (> 0): scales the default voxel size
    double maxMemory = 0;          ///< bytes the band may need while it is built (> 0; 0: half the physical memory)
};

struct DefaultBand {
    Resolution resolution;  ///< h*, w_μ and the default h at the samples
    BandOptions options;    ///< as used: voxel size and iso resolved, maxVoxels from the memory limit
    double maxMemory = 0;   ///< the memory limit as used, bytes
    BandResult result;
};

/// Resolution, estimate (expected area × the width where μ > η, over h³), then buildBand. Throws ParameterError
/// for bad options, MemoryLimitError (naming DefaultBandOptions::maxMemory and BandOptions::voxelSize, with the
/// voxel size that would fit) when the estimate exceeds kMaxBandVoxels or maxMemory / kBuildBytesPerVoxel, and
/// Cancelled when `progress` asks to stop.
DefaultBand buildDefaultBand(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options = {},
                             const Progress& progress = {});

}  // namespace gpisvdb
