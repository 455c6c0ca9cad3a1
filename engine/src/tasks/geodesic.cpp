#include "gpisvdb/tasks/geodesic.h"

#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/green.h"

namespace gpisvdb {

GeodesicResult geodesicDistance(const Band& band, const std::vector<Vec3d>& sources, const std::vector<Vec3d>& targets,
                                const GeodesicOptions& options, const Progress& progress) {
    if (sources.empty()) throw ParameterError("the geodesic distance needs at least one source point");
    GeodesicResult r;
    // === Snap the points to band voxels
    for (const Vec3d& s : sources) r.sourceIndex.push_back(nearestBandVoxel(band, s));
    for (const Vec3d& t : targets) r.targetIndex.push_back(nearestBandVoxel(band, t));
    // === U by fast marching (Eq. 28), then one path per target
    FastMarchingOptions march;
    march.stopAtTargets = options.stopAtTargets;
    r.march = fastMarching(band, r.sourceIndex, r.targetIndex, march, progress);
    for (std::size_t t : r.targetIndex) {
        progress.checkInterrupt();
        r.paths.push_back(backtrack(band, r.march.distance, t, options.path));
    }
    return r;
}

}  // namespace gpisvdb
