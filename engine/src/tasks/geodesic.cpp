#include "gpisvdb/tasks/geodesic.h"

#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/memory_estimate.h"
#include "gpisvdb/tasks/green.h"

namespace gpisvdb {

double geodesicMarchBytes(const Band& band) {
    std::size_t terms = 0;
    for (const VoxelStencil& st : band.stencil) terms += st.count;
    return fastMarchingBytes(band.size(), 2 * terms, fastMarchingFrontShare(band.size()));
}

GeodesicResult geodesicDistance(const Band& band, const std::vector<Vec3d>& sources, const std::vector<Vec3d>& targets,
                                const GeodesicOptions& options, const Progress& progress) {
    if (sources.empty()) throw ParameterError("the geodesic distance needs at least one source point");
    if (sources.size() > kMaxGeodesicPoints || targets.size() > kMaxGeodesicPoints)
        throw ParameterError("the geodesic distance takes at most " + numberText(double(kMaxGeodesicPoints)) +
                             " source points and as many targets, got " + std::to_string(sources.size()) + " sources and " +
                             std::to_string(targets.size()) + " targets");
    const double bytes = geodesicMarchBytes(band);
    if (options.maxBytes > 0 && bytes > options.maxBytes)
        throw MemoryLimitError("fast marching over " + std::to_string(band.size()) + " voxels needs about " + numberText(bytes / 1e9) +
                                   " GB beyond the band, more than the " + numberText(options.maxBytes / 1e9) +
                                   " GB allowed (GeodesicOptions::maxBytes): use a voxel size (BandOptions::voxelSize) of " +
                                   numberText(band.voxelSize * std::cbrt(bytes / options.maxBytes) * 1.1) + " or larger",
                               {"GeodesicOptions::maxBytes", "BandOptions::voxelSize"});
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
