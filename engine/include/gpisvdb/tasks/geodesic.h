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

/// The geodesic distance U from the sources over the band, and the shortest path from each target back to them.
/// \param band      the band (its T and Selling stencils), N voxels
/// \param sources   source points, world units, each snapped to the nearest band voxel (U = 0 there)
/// \param targets   target points, world units, snapped alike; one path each
/// \param options   whether to stop once every target is reached, the paths' integration, the memory limit
/// \param progress  reports the march's accepted voxels; its interrupt stops it (Cancelled)
/// \return U by linear index (+∞ where not reached), the snapped indices, one path per target
/// \throws ParameterError without a source, on a non-finite point or more than kMaxGeodesicPoints sources or targets;
///         MemoryLimitError when the march would need more than options.maxBytes (all before any work); InputError
///         on an empty band; Cancelled when interrupted
/// \par Complexity
///   Snapping O(N) per point; the march O(N log N) (a heap over the front, ≤ 6 Selling terms per voxel); each path
///   O(its length in voxels). Memory beside the band: geodesicMarchBytes(band), measured 62–66 B per voxel.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. The march runs on one thread (its per-voxel table is set up in parallel); the
///   result is the same for any thread count.
GeodesicResult geodesicDistance(const Band& band, const std::vector<Vec3d>& sources, const std::vector<Vec3d>& targets = {},
                                const GeodesicOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
