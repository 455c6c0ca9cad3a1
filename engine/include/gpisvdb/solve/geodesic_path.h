#pragma once
// Shortest paths on a band from a fast-marching distance U (paper Sec. 10.2; docs/math.md#paths): backtracking from a
// target along the upwind geodesic flow
//     V(x) = Σ_k λ_k max(0, U(x) − U(x ± h e_k)) (±e_k)   (the sign of the smaller neighbour of each term),
// the upwind form of −T∇U, down to a voxel where U = 0 (a source).
#include <cstddef>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/core/types.h"

namespace gpisvdb {

struct BacktrackOptions {
    double step = 0.25;        ///< integration step, voxels (index space)
    std::size_t maxSteps = 0;  ///< step cap; 0: 64 × the band's bounding-box extents summed, over `step`
};

struct GeodesicPath {
    std::vector<Vec3d> points;   ///< world units, from the target voxel's centre to the source voxel's centre
    std::vector<double> values;  ///< U at each point (trilinear over the band voxels U reached)
    double length = 0;           ///< Euclidean length of the polyline, world units
    double distance = 0;         ///< U at the target voxel, world units × T^(−1/2)
    std::size_t source = 0;      ///< the source voxel it ends at (linear index; valid when reachedSource)
    bool reachedSource = false;  ///< false: the target was not reached by the march, or the step cap was hit
};

/// Integrates ẋ = V/‖V‖ (V trilinear between voxel centres; Heun steps of `step` voxels, halved while U does
/// not decrease) from the target voxel until a voxel with U = 0 is a corner of the current cell, then ends at
/// that voxel's centre. Where the interpolated flow cannot descend, it moves to the lowest-U voxel near it, so
/// U decreases strictly at every point. Throws ParameterError when `U` does not match the band or `target` is
/// not a band voxel.
GeodesicPath backtrack(const Band& band, const std::vector<double>& U, std::size_t target, const BacktrackOptions& options = {});

}  // namespace gpisvdb
