#pragma once
// Occupancy: the probability P(φ(x) > u) that a point lies inside the GPIS's surface, and its fog volume for
// renderers (docs/uncertainty.md#occupancy).
#include <openvdb/openvdb.h>
#include <string>

#include "gpisvdb/band/band.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

/// P(φ > u) for φ ~ N(mean, stddev²): Φ((mean − u) / stddev); a step at mean = u when stddev = 0. The inside has
/// the larger φ in both models (the winding number is 1 inside; the regression GPIS's labels are +1 inside).
double insideProbability(double mean, double stddev, double iso);
/// The same from a model's value: mean γ and standard deviation √c₀₀.
double insideProbability(const ValueGradient& z, double iso);

/// A fog volume of P(φ > band.iso): each band voxel holds its probability, and the region the band encloses (the
/// inactive side of u − γ where γ > u, found by OpenVDB's signed flood fill, clipped to the band's bounding box)
/// is filled with active tiles of 1, so that a renderer shows a solid whose edge blurs with the uncertainty.
/// Outside: inactive, 0. Class fog volume; values are probabilities (unitless, is_local_space false).
openvdb::FloatGrid::Ptr occupancyGrid(const Band& band, const std::string& name);

}  // namespace gpisvdb
