// Writes the seed corpus of fuzz_vdb (small .vdb files shaped like gpisvdb's): make_vdb_seeds DIR.
#include <openvdb/openvdb.h>

#include <cmath>
#include <string>

namespace {

template <class GridT>
typename GridT::Ptr grid(const std::string& name, typename GridT::ValueType v, double voxel) {
    auto g = GridT::create();
    g->setName(name);
    g->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    auto acc = g->getAccessor();
    for (int i = 0; i < 5; ++i)  // one leaf node: a few hundred bytes per grid
        for (int j = 0; j < 3; ++j) acc.setValue(openvdb::Coord(i, j, i * j % 8), v);
    return g;
}

void write(const std::string& path, const openvdb::GridPtrVec& grids, double iso, bool half, uint32_t compression) {
    openvdb::io::File f(path);
    f.setCompression(compression | openvdb::io::COMPRESS_ACTIVE_MASK);
    openvdb::MetaMap meta;
    if (iso == iso) meta.insertMeta("iso", openvdb::DoubleMetadata(iso));
    meta.insertMeta("model", openvdb::StringMetadata("winding"));
    for (const auto& g : grids) g->setSaveFloatAsHalf(half);
    f.write(grids, meta);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) return 2;
    openvdb::initialize();
    const std::string dir = argv[1];
    using openvdb::FloatGrid, openvdb::Vec3SGrid, openvdb::Vec3s;
    write(dir + "/band.vdb", {grid<FloatGrid>("mu", 1.f, 0.1), grid<FloatGrid>("mean", 0.5f, 0.1)}, 0.5, false, openvdb::io::COMPRESS_ZIP);
    write(dir + "/field.vdb", {grid<Vec3SGrid>("vel", Vec3s(1, 0, 0), 0.5)}, std::nan(""), false, openvdb::io::COMPRESS_ZIP);
    write(dir + "/two_fields.vdb",
          {grid<Vec3SGrid>("a", Vec3s(0, 1, 0), 1), grid<Vec3SGrid>("vel", Vec3s(0, 0, 1), 1), grid<FloatGrid>("mean", 0.f, 1)}, 0, false,
          openvdb::io::COMPRESS_NONE);
    write(dir + "/half.vdb", {grid<FloatGrid>("mean", 0.25f, 0.2), grid<Vec3SGrid>("vel", Vec3s(1, 2, 3), 0.2)}, 0.5, true,
          openvdb::io::COMPRESS_BLOSC);
    write(dir + "/empty.vdb", {}, 0.5, false, openvdb::io::COMPRESS_NONE);
    return 0;
}
