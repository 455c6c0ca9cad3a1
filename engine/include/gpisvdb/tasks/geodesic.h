#pragma once
// Geodesic distance on the GPIS (paper Sec. 10.2, Eq. 28): U with ‖∇U‖_T = 1 from one or more source points by
// Hamiltonian fast marching, and the shortest path from each target point back to the nearest source.
// Since T ≈ μ P (P the tangent projector, tr T = 2μ), U is about the surface distance over √μ: it grows faster
// where the surface is uncertain (small μ) and paths keep to where μ is large, i.e. near the mean surface.
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/solve/fast_marching.h"
#include "gpisvdb/solve/geodesic_path.h"

namespace gpisvdb {

struct GeodesicOptions {
    bool stopAtTargets = false;  ///< end the march once every target is reached (faster; U is +∞ beyond)
    BacktrackOptions path;       ///< path integration
};

struct GeodesicResult {
    FastMarchingResult march;               ///< U by linear index (+∞ where not reached)
    std::vector<std::size_t> sourceIndex;   ///< band voxel nearest each source point
    std::vector<std::size_t> targetIndex;   ///< band voxel nearest each target point
    std::vector<GeodesicPath> paths;        ///< one per target, target → source
};

/// Sources and targets are world-space points, snapped to the nearest band voxel. Throws ParameterError without
/// a source or on a non-finite point.
GeodesicResult geodesicDistance(const Band& band, const std::vector<Vec3d>& sources,
                                const std::vector<Vec3d>& targets = {}, const GeodesicOptions& options = {},
                                const Progress& progress = {});

}  // namespace gpisvdb
