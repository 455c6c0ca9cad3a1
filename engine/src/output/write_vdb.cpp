#include "gpisvdb/output/write_vdb.h"

#include <algorithm>
#include <cmath>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr double kHalfMax = 65504.0;  // the largest finite half float

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

/// Counts the active values of `grid` that are not finite (or, for half-float storage, beyond ±65504, which a
/// half stores as ±∞), and the largest magnitude among the finite ones; `first` gets the first offender's voxel.
template <class GridT, class Magnitude>
std::size_t countBad(const GridT& grid, bool half, Magnitude magnitude, openvdb::Coord& first) {
    std::size_t bad = 0;
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        const double m = magnitude(*it);
        if (std::isfinite(m) && (!half || m <= kHalfMax)) continue;
        if (!bad) first = it.getCoord();
        ++bad;
    }
    return bad;
}

/// The largest |component|; NaN when any component is NaN (std::max would drop it).
double vecMagnitude(const openvdb::Vec3s& x) {
    double m = 0;
    for (int k = 0; k < 3; ++k) {
        if (std::isnan(x[k])) return std::nan("");
        m = std::max(m, std::abs(double(x[k])));
    }
    return m;
}

/// Refuses to write a grid with a non-finite active value or background (or one a half cannot hold): a tool
/// would read inf or NaN as data, or a half file would turn large values into inf.
void checkFiniteGrids(const openvdb::GridPtrVec& grids, bool half) {
    for (const auto& g : grids) {
        openvdb::Coord first;
        std::size_t bad = 0;
        double background = 0;
        if (auto f = openvdb::GridBase::grid<openvdb::FloatGrid>(g)) {
            bad = countBad(*f, half, [](float v) { return std::abs(double(v)); }, first);
            background = std::abs(double(f->background()));
        } else if (auto v = openvdb::GridBase::grid<openvdb::Vec3SGrid>(g)) {
            bad = countBad(*v, half, vecMagnitude, first);
            background = vecMagnitude(v->background());
        } else {
            continue;
        }
        const bool badBackground = !std::isfinite(background) || (half && background > kHalfMax);
        if (!bad && !badBackground) continue;
        const std::string where = bad ? std::to_string(bad) + " active values (the first at voxel " + std::to_string(first.x()) +
                                            "," + std::to_string(first.y()) + "," + std::to_string(first.z()) + ")"
                                      : std::string("its background value");
        if (half)
            throw ParameterError("grid '" + g->getName() + "': " + where + " are not finite or beyond the half-float range ±65504 "
                                 "(VdbWriteOptions::halfFloat): not written; store full floats",
                                 {"VdbWriteOptions::halfFloat"});
        throw Error("grid '" + g->getName() + "': " + where + " are not finite (inf or NaN): not written");
    }
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
        auto acc = grid->getAccessor();  // like scalar channels: a non-finite vector is left inactive
        for (std::size_t i = 0; i < band.size(); ++i)
            if (!(std::isfinite(v[3 * i]) && std::isfinite(v[3 * i + 1]) && std::isfinite(v[3 * i + 2])))
                acc.setValueOff(band.coord[i], openvdb::Vec3s(0.0f));
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
    checkFiniteGrids(grids, options.halfFloat);
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
