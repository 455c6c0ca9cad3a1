#include "gpisvdb/output/write_vdb.h"

#include <cmath>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

template <class GridT, class Value>
typename GridT::Ptr channel(const Band& band, const std::string& name, const Value& value,
                            typename GridT::ValueType background = typename GridT::ValueType(0)) {
    auto grid = GridT::create(background);
    grid->setName(name);
    grid->setTransform(band.index->transform().copy());
    auto acc = grid->getAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) acc.setValue(band.coord[i], value(i));
    return grid;
}

}  // namespace

openvdb::GridPtrVec bandGrids(const Band& band, const std::vector<NamedChannel>& extra,
                              const std::vector<NamedVectorChannel>& vectors) {
    openvdb::initialize();
    openvdb::GridPtrVec grids;
    auto mu = channel<openvdb::FloatGrid>(band, "mu", [&](std::size_t i) { return band.mu[i]; });
    mu->setGridClass(openvdb::GRID_FOG_VOLUME);
    grids.push_back(mu);
    grids.push_back(channel<openvdb::FloatGrid>(band, "mean", [&](std::size_t i) { return band.mean[i]; }));
    grids.push_back(channel<openvdb::FloatGrid>(band, "stddev", [&](std::size_t i) { return band.stddev[i]; }));
    auto tDiag = channel<openvdb::Vec3SGrid>(band, "T_diag", [&](std::size_t i) {
        return openvdb::Vec3s(band.T[i][0], band.T[i][1], band.T[i][2]);
    });
    auto tOff = channel<openvdb::Vec3SGrid>(band, "T_offdiag", [&](std::size_t i) {
        return openvdb::Vec3s(band.T[i][3], band.T[i][4], band.T[i][5]);
    });
    tDiag->setVectorType(openvdb::VEC_INVARIANT);
    tOff->setVectorType(openvdb::VEC_INVARIANT);
    grids.push_back(tDiag);
    grids.push_back(tOff);
    auto normal = channel<openvdb::Vec3SGrid>(band, "normal", [&](std::size_t i) { return band.normal[i]; });
    normal->setVectorType(openvdb::VEC_COVARIANT_NORMALIZE);
    grids.push_back(normal);
    // Integer-valued, but a float grid: Debian's pyopenvdb cannot read a file holding an Int32Grid at all.
    grids.push_back(channel<openvdb::FloatGrid>(band, "stencil_width", [&](std::size_t i) { return float(band.stencil[i].width); }));
    for (const NamedChannel& c : extra) {
        if (!c.values || c.values->size() != band.size()) throw Error("channel '" + c.name + "' does not match the band");
        auto grid = channel<openvdb::FloatGrid>(band, c.name, [&](std::size_t i) { return (*c.values)[i]; }, c.background);
        auto acc = grid->getAccessor();
        for (std::size_t i = 0; i < band.size(); ++i)
            if (!std::isfinite((*c.values)[i])) acc.setValueOff(band.coord[i], c.background);
        grids.push_back(grid);
    }
    for (const NamedVectorChannel& c : vectors) {
        if (!c.values || c.values->size() != 3 * band.size()) throw Error("vector channel '" + c.name + "' does not match the band");
        const std::vector<float>& v = *c.values;
        auto grid = channel<openvdb::Vec3SGrid>(band, c.name, [&](std::size_t i) {
            return openvdb::Vec3s(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
        });
        grid->setVectorType(c.vectorType);
        grids.push_back(grid);
    }
    return grids;
}

openvdb::GridPtrVec sellingGrids(const Band& band) {
    openvdb::initialize();
    openvdb::GridPtrVec grids;
    for (std::size_t k = 0; k < 6; ++k) {
        grids.push_back(channel<openvdb::FloatGrid>(band, "selling_weight_" + std::to_string(k), [&](std::size_t i) {
            return int(k) < band.stencil[i].count ? band.stencil[i].weight[k] : 0.0f;
        }));
        auto offset = channel<openvdb::Vec3SGrid>(band, "selling_offset_" + std::to_string(k), [&](std::size_t i) {
            const VoxelStencil& st = band.stencil[i];
            if (int(k) >= st.count) return openvdb::Vec3s(0.0f);
            return openvdb::Vec3s(float(st.offset[k][0]), float(st.offset[k][1]), float(st.offset[k][2]));
        });
        // Index-space integers: a tool must not rotate or rescale them with the transform.
        offset->setVectorType(openvdb::VEC_INVARIANT);
        grids.push_back(offset);
    }
    return grids;
}

void writeVdb(const openvdb::GridPtrVec& grids, const std::string& path, const openvdb::MetaMap& metadata,
              const VdbWriteOptions& options) {
    openvdb::initialize();
    for (auto& g : grids) g->setSaveFloatAsHalf(options.halfFloat);
    try {
        openvdb::io::File file(path);
        file.setCompression(openvdb::io::COMPRESS_BLOSC);
        file.write(grids, metadata);
        file.close();
    } catch (const openvdb::Exception& e) {
        throw OutputError(path + ": cannot write the VDB file: " + e.what());
    }
}

void writeBandVdb(const Band& band, const std::string& path, const openvdb::MetaMap& metadata,
                  const std::vector<NamedChannel>& extra, const std::vector<NamedVectorChannel>& vectors,
                  const VdbWriteOptions& options) {
    openvdb::GridPtrVec grids = bandGrids(band, extra, vectors);
    if (options.sellingStencils) {
        const openvdb::GridPtrVec selling = sellingGrids(band);
        grids.insert(grids.end(), selling.begin(), selling.end());
    }
    writeVdb(grids, path, metadata, options);
}

}  // namespace gpisvdb
