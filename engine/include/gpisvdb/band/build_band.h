#pragma once
// Building the band: a breadth-first search from the samples' voxels (the method), and a scan of the bounding
// box (the baseline it is measured and tested against). Both evaluate the GPIS, then μ and T by Kac–Rice, at
// every voxel they visit, and keep the voxels with μ > η.
#include <cstddef>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

struct BandOptions {
    double voxelSize = 0;          ///< h, world units (> 0; see chooseResolution)
    double iso = 0.5;              ///< iso-value u of the surface φ = u
    double etaRelative = 0.01;     ///< η relative to the median μ over the samples' voxels (> 0)
    int qmcSamples = 512;          ///< S, QMC points for μ and T (≥ 1)
    double maxAnisotropy = 20;     ///< T is regularised to √(λmax/λmin) ≤ this before Selling (≥ 1)
    std::size_t maxVoxels = 0;     ///< refuse once more voxels than this would be evaluated (0: no limit)
    std::size_t batchVoxels = std::size_t(1) << 18;  ///< voxels evaluated together (≥ 1): bounds the build's transient
                                   ///< memory (≈ 330 bytes each); the band does not depend on it
};

struct BandStats {
    double etaAbsolute = 0;        ///< η in world units⁻¹
    double medianSampleMu = 0;     ///< median μ over the samples' voxels
    std::size_t evaluated = 0;     ///< voxels where μ was computed (band + rejected frontier)
    std::size_t regularised = 0;   ///< voxels whose T was regularised for anisotropy
    int maxStencilL1 = 0;          ///< max ‖e‖₁ over the band
    int levels = 0;                ///< BFS levels (scan: growth rounds)
    // Wall-clock seconds per stage (they sum to about the whole build):
    double modelSeconds = 0;       ///< evaluating the GPIS at the visited voxels
    double kacRiceSeconds = 0;     ///< μ, T, the channels and the Selling stencils from the Gaussians
    double searchSeconds = 0;      ///< the BFS frontier (or the scan's boxes) and η
    double finishSeconds = 0;      ///< the index tree in leaf order and the channels gathered in that order
};

struct BandResult {
    Band band;
    BandStats stats;
};

/// One voxel's fields, as a builder computes them; also the way to make a band from analytic fields.
struct BandVoxel {
    openvdb::Coord coord;            ///< index space; the centre is h·coord
    double mu = 0;                   ///< μ, world units⁻¹
    Mat3d T = Mat3d::Zero();         ///< T, world units⁻¹ (symmetric positive semi-definite)
    double mean = 0;                 ///< γ
    double stddev = 0;               ///< √c₀₀
    Vec3d normal = Vec3d::Zero();    ///< outward unit normal
};

/// The band over `voxels` (distinct coordinates): the index tree in leaf order, the channels, and the Selling
/// stencil of T regularised to anisotropy ≤ maxAnisotropy. Fills stats.regularised and stats.maxStencilL1.
BandResult bandFromVoxels(std::vector<BandVoxel> voxels, double voxelSize, double maxAnisotropy,
                          const Progress& progress = {});

BandResult buildBand(const GpisModel& model, const Samples& samples, const BandOptions& options,
                     const Progress& progress = {});

/// Baseline: evaluates every voxel of the samples' bounding box, grown until no band voxel touches its boundary.
BandResult scanBand(const GpisModel& model, const Samples& samples, const BandOptions& options,
                    const Progress& progress = {});

}  // namespace gpisvdb
