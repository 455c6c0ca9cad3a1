#pragma once
// The smoothed distance to a GPIS (paper Eq. 31; docs/math.md#smoothed-distance):
//   d_α(x) = −(1/α) log Σ_j exp(−α ‖x − x_j‖) μ(x_j) h³   over the band's voxels x_j,
// a LogSumExp soft minimum of the distance weighted by the surface density. Stable for any α and distance: the sum
// is taken relative to d* = min_j ‖x − x_j‖ (found first), so its largest term is μ h³ and nothing under- or
// overflows.
//
// Acceleration with a stated bound: a k-d tree over the voxel centres; each node keeps its total weight W, weighted
// centroid c and radius r. Children are visited nearest first; a node is summed as one term v when its error is at
// most ε/2 (v + S W / W_total), S the sum so far, either
//  - v = W f(c) (f = e^{−α‖x − ·‖}; the first-order term vanishes at the centroid and the remainder is at most
//    ½ W r² f max(α², α/ρ) over the node's ball, ρ the distance from x to it), or
//  - v = the middle of [W e^{−α b}, W e^{−α a}] (a, b: distances to its box), erring by at most its half-width.
// The collapsed nodes then err by at most ε S_final ≤ ε (S + error) in total, so |d_tree − d_exact| ≤ tolerance
// when ε = (1 − q) / (2 − q), q = e^{−α · tolerance}. Far from the band whole subtrees collapse into one term.
#include <cstddef>
#include <memory>
#include <openvdb/openvdb.h>
#include <string>
#include <utility>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/core/progress.h"

namespace gpisvdb {

/// d_α at single points, over a tree built once per band and α.
class SmoothedDistance {
public:
    /// α in world units⁻¹ (> 0, finite). Throws ParameterError on a bad α, Error on an empty band.
    SmoothedDistance(const Band& band, double alpha);
    ~SmoothedDistance();
    SmoothedDistance(SmoothedDistance&&) noexcept;

    /// d_α(x) within `tolerance` (world units, > 0) of the exact sum. `terms`, when given, receives the number of
    /// voxels and collapsed nodes summed.
    double at(const Vec3d& x, double tolerance, std::size_t* terms = nullptr) const;
    /// The exact sum over every voxel (the baseline, O(N) per point).
    double exact(const Vec3d& x) const;
    double alpha() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

struct SmoothedDistanceOptions {
    double alpha = 0;          ///< α, world units⁻¹ (> 0); larger is sharper (d_α → distance to the band as α → ∞)
    double gridVoxelSize = 0;  ///< H, world units (0: the padded box's longest side / 128)
    double padding = -1;       ///< margin around the band's box, world units (< 0: 10 % of its longest side)
    double tolerance = 0;      ///< bound on |d − d_exact| per point, world units (0: H / 100)
    bool bruteForce = false;   ///< exact sums over all voxels instead of the tree (the measured baseline)
    double maxBytes = 0;       ///< refuse a grid whose peak (smoothedDistanceBytes, no level-set copy) exceeds
                               ///< this, bytes (0: no limit); grids of more than 2^31 points are refused whatever it is
};

struct SmoothedDistanceResult {
    openvdb::FloatGrid::Ptr grid;  ///< dense over the padded box, voxel size H, every value active and finite;
                                   ///< its background (read outside the box) is `background`
    double voxelSize = 0;          ///< H as used
    double background = 0;         ///< the value read outside the box: a sentinel for "far", not a distance: the
                                   ///< largest computed value (or 0) plus the box's diagonal, so it exceeds every
                                   ///< computed value and an outside point never reads as near the surface
    double tolerance = 0;          ///< the bound as used (0 for brute force)
    std::size_t points = 0;
    double meanTerms = 0;  ///< summed terms per point (N for brute force)
};

/// The grid smoothedDistanceGrid makes for a band and options: grid point k sits at H·(first + k) (world units).
struct DistanceGridShape {
    Vec3d first = Vec3d::Zero();  ///< the first point's index along each axis, units of H
    Vec3d count = Vec3d::Zero();  ///< points along each axis
    double voxelSize = 0;         ///< H as used, world units
    double points = 0;            ///< the product of count
};
/// Throws ParameterError on a non-finite padding or a grid voxel size that is not finite and > 0.
DistanceGridShape smoothedDistanceGridShape(const Band& band, const SmoothedDistanceOptions& options);

/// What smoothedDistanceGrid(band, options) allocates at its peak, bytes by part, counted before it allocates
/// (docs/memory.md#distance): the larger of the k-d tree's build (the tree, 32 B per voxel and its nodes, with the
/// top level's sorted copies, 36 B per voxel) and the evaluation (the tree, a float per grid point, the dense
/// OpenVDB grid's leaves and internal nodes); with `levelCopy`, also the command's copy of the grid beside it.
std::vector<std::pair<std::string, double>> smoothedDistanceBytes(const Band& band, const SmoothedDistanceOptions& options, bool levelCopy);

/// The smallest grid voxel size at which smoothedDistanceBytes(band, options, levelCopy) sums to at most `bytes`,
/// from options' own H up in steps of 2 % (the grid's leaves and nodes do not shrink as H⁻³, so no closed form
/// names it); 0 when none does: the k-d tree over the band's voxels alone is larger.
double smoothedDistanceGridVoxelSizeWithin(const Band& band, const SmoothedDistanceOptions& options, bool levelCopy, double bytes);

/// d_α (paper Eq. 31) on a grid covering the band's box plus padding; grid point k sits at H·k (world units).
/// \param band      the band (its μ), N voxels
/// \param options   α, the grid's voxel size H and padding, the tolerance of the truncated sum, the memory limit
/// \param progress  reports the grid points done; its interrupt stops the sum (Cancelled)
/// \return the grid of d_α and its figures (points, terms summed, the tolerance met)
/// \throws ParameterError for a bad α, H, padding or tolerance; MemoryLimitError when the grid and the k-d tree
///         would exceed options.maxBytes (before they are allocated); Error on an empty band; Cancelled when
///         interrupted
/// \par Complexity
///   A k-d tree over the band's voxels, O(N log N); then per grid point a query of the voxels within the tolerance's
///   reach, O(log N + the voxels summed). Memory smoothedDistanceBytes(band, options).
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel over grid points (TBB); the result is the same for
///   any thread count.
SmoothedDistanceResult smoothedDistanceGrid(const Band& band, const SmoothedDistanceOptions& options, const Progress& progress = {});

}  // namespace gpisvdb
