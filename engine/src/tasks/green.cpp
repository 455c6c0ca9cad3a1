#include "gpisvdb/tasks/green.h"

#include <limits>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

std::size_t nearestBandVoxel(const Band& band, const Vec3d& point) {
    if (band.size() == 0) throw InputError("the band is empty");
    if (!point.allFinite()) throw ParameterError("a source or target point must be three finite numbers");
    const double h = band.voxelSize;
    std::size_t best = 0;
    double bestD2 = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < band.size(); ++i) {
        const Vec3d x = h * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z());
        const double d2 = (x - point).squaredNorm();
        if (d2 < bestD2) bestD2 = d2, best = i;
    }
    return best;
}

GreenResult greensFunction(const Band& band, const SymmetricOperator& L, const Vec3d& source, const PcgOptions& options,
                           const Progress& progress) {
    GreenResult r;
    r.sourceIndex = nearestBandVoxel(band, source);
    // === L f = M δ_y = e_y
    std::vector<float> rhs(band.size(), 0.0f);
    rhs[r.sourceIndex] = 1.0f;
    r.solver = solvePcg(L, rhs, r.values, options, progress);
    return r;
}

}  // namespace gpisvdb
