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

/// The most source points, and separately target points, one call accepts (each target costs a path).
constexpr std::size_t kMaxGeodesicPoints = 1000000;
/// Bytes a march over the band allocates beside it, before it allocates (docs/memory.md): fastMarchingBytes with the
/// table's entries bounded by the band's stencil terms (2 per term; those leaving the band are not stored) and
/// the front's share from fastMarchingFrontShare. Measured 62–66 B per voxel on 1–8 M-voxel boxes.
double geodesicMarchBytes(const Band& band);

struct GeodesicOptions {
    bool stopAtTargets = false;  ///< end the march once every target is reached (faster; U is +∞ beyond)
    BacktrackOptions path;       ///< path integration
    double maxBytes = 0;         ///< refuse a march needing more memory than this, bytes (geodesicMarchBytes; 0: no limit)
};

struct GeodesicResult {
    FastMarchingResult march;              ///< U by linear index (+∞ where not reached)
    std::vector<std::size_t> sourceIndex;  ///< band voxel nearest each source point
    std::vector<std::size_t> targetIndex;  ///< band voxel nearest each target point
    std::vector<GeodesicPath> paths;       ///< one per target, target → source
};

/// Sources and targets are world-space points, snapped to the nearest band voxel. Throws ParameterError without
/// a source, on a non-finite point, on more than kMaxGeodesicPoints sources or targets, or when the march would
/// need more than options.maxBytes — all before any work.
GeodesicResult geodesicDistance(const Band& band, const std::vector<Vec3d>& sources, const std::vector<Vec3d>& targets = {},
                                const GeodesicOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
