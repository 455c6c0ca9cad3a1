#pragma once
// Writing shortest paths as polylines (docs/geodesic.md): VTK XML PolyData (.vtp: lines, point data `geodesic` = U,
// cell data `length`), Wavefront OBJ (.obj: `v` and `l` records) or JSON (.json: points, U, lengths).
// World units throughout.
#include <string>
#include <vector>

#include "gpisvdb/solve/geodesic_path.h"

namespace gpisvdb {

enum class PathFormat { Vtp, Obj, Json };
/// The format named by a path's extension; throws OutputError otherwise.
PathFormat pathFormatOf(const std::string& path);

/// Reads the polylines of a .vtp file (as written by writePaths; any VTK XML PolyData lines), world units.
/// Throws InputError.
std::vector<std::vector<Vec3d>> readPolylines(const std::string& path);

/// Writes the polylines (a path of one point is written as a single-vertex line). Throws OutputError.
void writePaths(const std::vector<GeodesicPath>& paths, const std::string& path, PathFormat format);

}  // namespace gpisvdb
