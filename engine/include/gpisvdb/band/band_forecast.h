#pragma once
// What a planned band (planDefaultBand) will cost before it is built: a pilot, buildBand's own search run inside a few
// compact boxes around the samples, gives the band voxels and evaluated voxels per sample voxel and the time per
// evaluated voxel; scaled to all the sample voxels, they give the band's size, peak memory and time
// (docs/band.md#forecast; gpisvdb info).
#include <cstddef>
#include <vector>

#include "gpisvdb/band/default_band.h"

namespace gpisvdb {

struct BandForecastOptions {
    /// Voxels the pilot evaluates, about (≥ 256). More time the model more steadily and average over more of the
    /// shape; 131072 take ≈ 1–3 s on 2 cores (the search, then two timed passes).
    std::size_t pilotVoxels = 131072;
    int patches = 16;  ///< boxes the pilot searches, spread over the samples (≥ 1), each about pilotVoxels / patches
};

/// Wall-clock seconds per voxel that buildBand spends beyond evaluating the model and Kac–Rice: the BFS's mask and
/// frontier per evaluated voxel, and the channels gathered into leaf order per band voxel (measured on 2 cores,
/// docs/band.md#forecast).
constexpr double kSearchSecondsPerEvaluatedVoxel = 0.5e-6;
constexpr double kFinishSecondsPerBandVoxel = 0.5e-6;
/// Wall-clock seconds per band voxel of writing the band's grids as .vdb (writeBandVdb, full floats, measured on 2
/// cores).
constexpr double kVdbWriteSecondsPerBandVoxel = 0.9e-6;

struct BandForecast {
    double voxels = 0;            ///< band voxels
    double evaluated = 0;         ///< voxels buildBand evaluates
    double peakBytes = 0;         ///< the build's (or the .vdb write's) peak resident set, bytes (as estimateBand)
    std::size_t pilotVoxels = 0;  ///< voxels the pilot evaluated
    /// The wall-clock time of evaluating them again in one call (the cells' far fields made; the faster of two), on
    /// this process's threads.
    double pilotSeconds = 0;
    double secondsPerEvaluated = 0;  ///< pilotSeconds / pilotVoxels
    /// buildBand's wall-clock time: evaluated × secondsPerEvaluated plus the search's and the finish's shares.
    double buildSeconds = 0;
    double writeSeconds = 0;  ///< writing its grids as .vdb: voxels × kVdbWriteSecondsPerBandVoxel
};

/// Where a pilot searches: boxes (index space) of half-width `radius` voxels around `patches` centres spread over the
/// sample voxels, and the sample voxels inside any box (sorted).
struct PilotRegion {
    std::vector<openvdb::CoordBBox> boxes;
    std::vector<openvdb::Coord> seeds;
    bool contains(const openvdb::Coord& c) const;
};
PilotRegion pilotRegion(const std::vector<openvdb::Coord>& sampleVoxels, int radius, int patches);

/// The forecast of buildPlannedBand(model, samples, plan): buildBand's search (η from the region's sample voxels, the
/// plan's voxel size, iso, values and QMC count) inside a pilotRegion, its band and evaluated voxels scaled by all the
/// sample voxels over the region's. Throws ParameterError for pilotVoxels < 256 or patches < 1, InputError where the
/// band would (μ vanishing at the samples' voxels), Cancelled when `progress` asks to stop.
BandForecast forecastBand(const GpisModel& model, const Samples& samples, const DefaultBandPlan& plan,
                          const BandForecastOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
