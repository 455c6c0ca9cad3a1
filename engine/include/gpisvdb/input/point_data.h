#pragma once
// Scalar data given at points, for regression on the shape: a CSV (or whitespace-separated) file of rows
// x,y,z,value[,noise] in world units, noise the standard deviation of the value (0 when absent: exact data).
// A first line that is not numeric is a header; lines starting with '#' and blank lines are skipped.
#include <string>
#include <vector>

#include "gpisvdb/core/types.h"

namespace gpisvdb {

struct PointData {
    std::vector<Vec3d> position;  ///< world units
    std::vector<double> value;
    std::vector<double> noise;  ///< standard deviation of each value (≥ 0), same units as the values
};

/// Throws InputError naming the file (and line) on a missing or empty file, a row of other than 4 or 5 numbers,
/// a non-finite number, or a negative noise.
PointData readPointData(const std::string& path);

}  // namespace gpisvdb
