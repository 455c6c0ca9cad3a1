#pragma once
// Level lines of a grid on an axis-aligned plane (marching squares), for pictures of sections: the mean surface's
// and each plausible surface's trace on a slice (docs/uncertainty.md#sections).
#include <openvdb/openvdb.h>
#include <vector>

#include "gpisvdb/core/types.h"

namespace gpisvdb {

/// A plane through a grid: axis 0, 1, 2 (x, y, z) at world coordinate `value`.
struct SliceSpec {
    int axis = 2;
    double value = 0;
};

/// The line {grid = level} on the layer of voxel centres nearest the plane (index space: the layer's coordinate along
/// the axis is the plane's, rounded): marching squares over the squares of four voxel centres that are all active,
/// linear along each edge, a saddle resolved by the square's mean. Segments (two points each) in world units, on the
/// layer (their coordinate along the axis is the layer's). Inactive voxels end the line: it is drawn only where the
/// grid has values. Empty when the layer has no crossing.
std::vector<std::vector<Vec3d>> sliceContour(const openvdb::FloatGrid& grid, const SliceSpec& slice, double level);

}  // namespace gpisvdb
