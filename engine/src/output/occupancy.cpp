#include "gpisvdb/output/occupancy.h"

#include <algorithm>
#include <cmath>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

double insideProbability(double mean, double stddev, double iso) {
    if (!(stddev > 0)) return mean > iso ? 1.0 : 0.0;
    return 0.5 * std::erfc(-(mean - iso) / stddev * M_SQRT1_2);
}

double insideProbability(const ValueGradient& z, double iso) {
    return insideProbability(z.mean[0], std::sqrt(std::max(z.cov(0, 0), 0.0)), iso);
}

openvdb::FloatGrid::Ptr occupancyGrid(const Band& band, const std::string& name) {
    if (band.mean.size() != band.size() || band.stddev.size() != band.size())
        throw Error("occupancy: the band's mean and stddev channels are missing (released after a spill?)");
    // === The enclosed region: the sign of u − γ carried from the band to the inactive values around it
    auto side = openvdb::FloatGrid::create(1.0f);
    {
        auto acc = side->getAccessor();
        for (std::size_t i = 0; i < band.size(); ++i) acc.setValue(band.coord[i], float(band.iso) - band.mean[i]);
    }
    openvdb::tools::signedFloodFill(side->tree());

    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName(name);
    grid->setTransform(band.index->transform().copy());
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->setIsInWorldSpace(true);
    // The fill stays within the band's box: an open surface's sign, carried across empty space, would otherwise
    // fill whole internal nodes (4096³ voxels) on one side of it.
    const openvdb::CoordBBox box = band.bbox();
    for (auto it = side->tree().cbeginValueOff(); it; ++it) {
        if (!(*it < 0)) continue;
        openvdb::CoordBBox b;
        it.getBoundingBox(b);
        b.intersect(box);
        if (!b.empty()) grid->tree().fill(b, 1.0f, /*active=*/true);
    }
    side.reset();
    // === P(φ > u) on the band's voxels
    {
        auto acc = grid->getAccessor();
        for (std::size_t i = 0; i < band.size(); ++i)
            acc.setValueOn(band.coord[i], float(insideProbability(band.mean[i], band.stddev[i], band.iso)));
    }
    openvdb::tools::prune(grid->tree());
    return grid;
}

}  // namespace gpisvdb
