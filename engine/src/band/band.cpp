#include "gpisvdb/band/band.h"

namespace gpisvdb {

double Band::mass() const {
    double m = 0;
    for (float v : mu) m += v;
    return m * voxelSize * voxelSize * voxelSize;
}

double Band::bytesPerVoxel() const {
    if (coord.empty()) return 0;
    const std::size_t tree = index ? index->tree().memUsage() : 0;
    const std::size_t channels = coord.capacity() * sizeof(openvdb::Coord) + mu.capacity() * sizeof(float) + T.capacity() * sizeof(T[0]) +
                                 mean.capacity() * sizeof(float) + stddev.capacity() * sizeof(float) +
                                 normal.capacity() * sizeof(openvdb::Vec3f) + stencil.capacity() * sizeof(VoxelStencil);
    return double(tree + channels) / double(coord.size());
}

openvdb::CoordBBox Band::bbox() const {
    openvdb::CoordBBox b;
    for (const auto& c : coord) b.expand(c);
    return b;
}

}  // namespace gpisvdb
