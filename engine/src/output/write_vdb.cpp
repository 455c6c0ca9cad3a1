#include "gpisvdb/output/write_vdb.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <openvdb/io/Archive.h>
#include <openvdb/io/File.h>
#include <openvdb/io/GridDescriptor.h>
#include <openvdb/io/io.h>
#include <set>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/occupancy.h"
#include "nanovdb_writer.h"

namespace gpisvdb {

namespace {

constexpr double kHalfMax = 65504.0;  // the largest finite half float
const char* const kCreator = "gpisvdb " GPISVDB_VERSION;

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
void checkFiniteGrid(const openvdb::GridBase::ConstPtr& g, bool half) {
    openvdb::Coord first;
    std::size_t bad = 0;
    double background = 0;
    if (auto f = openvdb::GridBase::constGrid<openvdb::FloatGrid>(g)) {
        bad = countBad(
            *f, half, [](float v) { return std::abs(double(v)); }, first);
        background = std::abs(double(f->background()));
    } else if (auto v = openvdb::GridBase::constGrid<openvdb::Vec3SGrid>(g)) {
        bad = countBad(*v, half, vecMagnitude, first);
        background = vecMagnitude(v->background());
    } else {
        return;
    }
    const bool badBackground = !std::isfinite(background) || (half && background > kHalfMax);
    if (!bad && !badBackground) return;
    const std::string where = bad ? std::to_string(bad) + " active values (the first at voxel " + std::to_string(first.x()) + "," +
                                        std::to_string(first.y()) + "," + std::to_string(first.z()) + ")"
                                  : std::string("its background value");
    if (half)
        throw ParameterError("grid '" + g->getName() + "': " + where +
                                 " are not finite or beyond the half-float range ±65504 "
                                 "(VdbWriteOptions::halfFloat): not written; store full floats",
                             {"VdbWriteOptions::halfFloat"});
    throw Error("grid '" + g->getName() + "': " + where + " are not finite (inf or NaN): not written");
}

/// Makes one grid when called; the band's writer makes, checks and writes them one at a time.
using GridMaker = std::function<openvdb::GridBase::Ptr()>;

/// The occupancy's name must not be another grid's: a file with two grids of one name reads as either.
void checkOccupancyName(const VdbWriteOptions& options, const std::vector<NamedChannel>& extra,
                        const std::vector<NamedVectorChannel>& vectors) {
    const std::string& name = options.occupancyName;
    if (name.empty()) return;
    bool taken = std::find(bandGridNames().begin(), bandGridNames().end(), name) != bandGridNames().end();
    for (const NamedChannel& c : extra) taken = taken || c.name == name;
    for (const NamedVectorChannel& c : vectors) taken = taken || c.name == name;
    if (taken)
        throw ParameterError("the occupancy grid's name '" + name +
                                 "' (VdbWriteOptions::occupancyName) is "
                                 "another grid's: choose another",
                             {"VdbWriteOptions::occupancyName"});
}

/// The band's own grids: mu, mean, stddev, T_diag, T_offdiag, normal, stencil_width, and the occupancy unless
/// options.occupancyName is empty.
std::vector<GridMaker> ownGridMakers(const Band& band, const VdbWriteOptions& options) {
    if (band.mean.size() != band.size() || band.stddev.size() != band.size() || band.T.size() != band.size() ||
        band.normal.size() != band.size())
        throw Error("the band's channels were released after a spill: write it with its SpilledBandGrids");
    std::vector<GridMaker> makers;
    makers.push_back([&band] {
        auto mu = channel<openvdb::FloatGrid>(band, "mu", [&](std::size_t i) { return band.mu[i]; });
        mu->setGridClass(openvdb::GRID_FOG_VOLUME);
        return mu;
    });
    makers.push_back([&band] { return channel<openvdb::FloatGrid>(band, "mean", [&](std::size_t i) { return band.mean[i]; }); });
    makers.push_back([&band] { return channel<openvdb::FloatGrid>(band, "stddev", [&](std::size_t i) { return band.stddev[i]; }); });
    for (const int part : {0, 3}) {  // T_diag (xx, yy, zz), T_offdiag (xy, xz, yz)
        makers.push_back([&band, part] {
            auto t = channel<openvdb::Vec3SGrid>(band, part == 0 ? "T_diag" : "T_offdiag", [&](std::size_t i) {
                return openvdb::Vec3s(band.T[i][std::size_t(part)], band.T[i][std::size_t(part + 1)], band.T[i][std::size_t(part + 2)]);
            });
            t->setVectorType(openvdb::VEC_INVARIANT);
            return t;
        });
    }
    makers.push_back([&band] {
        auto normal = channel<openvdb::Vec3SGrid>(band, "normal", [&](std::size_t i) { return band.normal[i]; });
        normal->setVectorType(openvdb::VEC_COVARIANT_NORMALIZE);
        return normal;
    });
    // Integer-valued, but a float grid: Debian's pyopenvdb cannot read a file holding an Int32Grid at all.
    makers.push_back([&band] {
        return channel<openvdb::FloatGrid>(band, "stencil_width", [&](std::size_t i) { return float(band.stencil[i].width); });
    });
    if (!options.occupancyName.empty()) {
        makers.push_back([&band, name = options.occupancyName]() -> openvdb::GridBase::Ptr {
            auto grid = occupancyGrid(band, name);
            grid->insertMeta("units", openvdb::StringMetadata("probability"));
            return grid;
        });
    }
    return makers;
}

/// A task's channels over the band: `extra` as float grids, then `vectors` as Vec3f grids.
std::vector<GridMaker> channelGridMakers(const Band& band, const std::vector<NamedChannel>& extra,
                                         const std::vector<NamedVectorChannel>& vectors) {
    for (const NamedChannel& c : extra)
        if (!c.values || c.values->size() != band.size()) throw Error("channel '" + c.name + "' does not match the band");
    for (const NamedVectorChannel& c : vectors)
        if (!c.values || c.values->size() != 3 * band.size()) throw Error("vector channel '" + c.name + "' does not match the band");
    std::vector<GridMaker> makers;
    for (const NamedChannel& c : extra) {
        makers.push_back([&band, &c] {
            auto grid = channel<openvdb::FloatGrid>(
                band, c.name, [&](std::size_t i) { return (*c.values)[i]; }, c.background);
            auto acc = grid->getAccessor();
            for (std::size_t i = 0; i < band.size(); ++i)
                if (!std::isfinite((*c.values)[i])) acc.setValueOff(band.coord[i], c.background);
            return grid;
        });
    }
    for (const NamedVectorChannel& c : vectors) {
        makers.push_back([&band, &c] {
            const std::vector<float>& v = *c.values;
            auto grid = channel<openvdb::Vec3SGrid>(band, c.name,
                                                    [&](std::size_t i) { return openvdb::Vec3s(v[3 * i], v[3 * i + 1], v[3 * i + 2]); });
            grid->setVectorType(c.vectorType);
            auto acc = grid->getAccessor();  // like scalar channels: a non-finite vector is left inactive
            for (std::size_t i = 0; i < band.size(); ++i)
                if (!(std::isfinite(v[3 * i]) && std::isfinite(v[3 * i + 1]) && std::isfinite(v[3 * i + 2])))
                    acc.setValueOff(band.coord[i], openvdb::Vec3s(0.0f));
            return grid;
        });
    }
    return makers;
}

std::vector<GridMaker> bandGridMakers(const Band& band, const std::vector<NamedChannel>& extra,
                                      const std::vector<NamedVectorChannel>& vectors, const VdbWriteOptions& options) {
    std::vector<GridMaker> makers = channelGridMakers(band, extra, vectors);  // checked before the band's grids are made
    checkOccupancyName(options, extra, vectors);
    std::vector<GridMaker> own = ownGridMakers(band, options);
    makers.insert(makers.begin(), own.begin(), own.end());
    return makers;
}

std::vector<GridMaker> sellingGridMakers(const Band& band) {
    std::vector<GridMaker> makers;
    for (std::size_t k = 0; k < 6; ++k) {
        makers.push_back([&band, k] {
            return channel<openvdb::FloatGrid>(band, "selling_weight_" + std::to_string(k), [&](std::size_t i) {
                return int(k) < band.stencil[i].count ? band.stencil[i].weight[k] : 0.0f;
            });
        });
        makers.push_back([&band, k] {
            auto offset = channel<openvdb::Vec3SGrid>(band, "selling_offset_" + std::to_string(k), [&](std::size_t i) {
                const VoxelStencil& st = band.stencil[i];
                if (int(k) >= st.count) return openvdb::Vec3s(0.0f);
                return openvdb::Vec3s(float(st.offset[k][0]), float(st.offset[k][1]), float(st.offset[k][2]));
            });
            // Index-space integers: a tool must not rotate or rescale them with the transform.
            offset->setVectorType(openvdb::VEC_INVARIANT);
            return offset;
        });
    }
    return makers;
}

/// An OpenVDB file written one grid at a time, through the library's own Archive (header, file metadata, grid
/// count, then each grid with its descriptor and offsets, as io::File::write lays them out): only the grid being
/// written is in memory, not all of them.
class GridStreamWriter : private openvdb::io::Archive {
public:
    /// Writes `file`; errors name `shownPath` (the file's final name when `file` is a temporary).
    GridStreamWriter(const std::string& file, const std::string& shownPath, const openvdb::MetaMap& metadata, std::size_t gridCount)
        : path_(shownPath) {
        file_.open(file, std::ios_base::out | std::ios_base::binary | std::ios_base::trunc);
        if (file_.fail()) throw OutputError(shownPath + ": cannot open the VDB file for writing");
        setCompression(openvdb::io::COMPRESS_BLOSC);
        openvdb::io::setStreamMetadataPtr(file_, streamMetadata_, /*transfer=*/false);
        openvdb::io::setDataCompression(file_, compression());
        openvdb::io::setWriteGridStatsMetadata(file_, isGridStatsMetadataEnabled());
        writeHeader(file_, /*seekable=*/true);
        metadata.writeMeta(file_);
        const std::int32_t count = std::int32_t(gridCount);
        file_.write(reinterpret_cast<const char*>(&count), sizeof(count));
        remaining_ = gridCount;
    }

    void write(const openvdb::GridBase::ConstPtr& grid) {
        if (remaining_ == 0 || !names_.insert(grid->getName()).second)
            throw Error("GridStreamWriter: more grids than announced, or a grid name used twice");
        openvdb::io::GridDescriptor descriptor(grid->getName(), grid->type(), grid->saveFloatAsHalf());
        writeGrid(descriptor, grid, file_, /*seekable=*/true);
        --remaining_;
    }

    void close() {
        if (remaining_ != 0) throw Error("GridStreamWriter: fewer grids written than announced");
        file_.close();
        if (file_.fail()) throw OutputError(path_ + ": cannot write the VDB file (disk full?)");
    }

private:
    std::string path_;
    openvdb::io::StreamMetadata::Ptr streamMetadata_ = std::make_shared<openvdb::io::StreamMetadata>();
    std::ofstream file_;
    std::set<std::string> names_;
    std::size_t remaining_ = 0;
};

/// Makes, checks and writes the grids one at a time into a sibling temporary file, renamed to `path` at the end:
/// a grid that fails its check (or any error) leaves no file behind and `path` untouched. Returns the grids' names
/// in file order.
std::vector<std::string> writeGridsStreaming(const std::vector<GridMaker>& makers, const std::string& path,
                                             const openvdb::MetaMap& metadata, const VdbWriteOptions& options) {
    openvdb::initialize();
    std::vector<std::string> names;
    const std::string temp = path + ".part" + std::to_string(::getpid());
    try {
        const bool nano = options.nanoVdb;
        std::unique_ptr<GridStreamWriter> vdb;
        std::unique_ptr<NanoVdbStreamWriter> nvdb;
        if (nano) nvdb = std::make_unique<NanoVdbStreamWriter>(temp, path, options.halfFloat);
        else vdb = std::make_unique<GridStreamWriter>(temp, path, metadata, makers.size());
        for (const GridMaker& make : makers) {
            openvdb::GridBase::Ptr grid = make();
            checkFiniteGrid(grid, options.halfFloat);
            grid->setSaveFloatAsHalf(options.halfFloat);
            grid->setCreator(kCreator);
            if (nano) nvdb->write(grid);
            else vdb->write(grid);
            names.push_back(grid->getName());
        }
        if (nano) nvdb->close();
        else vdb->close();
    } catch (const openvdb::Exception& e) {
        std::remove(temp.c_str());
        throw OutputError(path + ": cannot write the VDB file: " + e.what());
    } catch (...) {
        std::remove(temp.c_str());
        throw;
    }
    if (std::rename(temp.c_str(), path.c_str()) != 0) {
        std::remove(temp.c_str());
        throw OutputError(path + ": cannot write the VDB file (rename from " + temp + " failed)");
    }
    return names;
}

}  // namespace

const std::vector<std::string>& bandGridNames() {
    static const std::vector<std::string> names{"mu", "mean", "stddev", "T_diag", "T_offdiag", "normal", "stencil_width"};
    return names;
}

openvdb::GridPtrVec bandGrids(const Band& band, const std::vector<NamedChannel>& extra, const std::vector<NamedVectorChannel>& vectors,
                              const VdbWriteOptions& options) {
    openvdb::initialize();
    openvdb::GridPtrVec grids;
    for (const GridMaker& make : bandGridMakers(band, extra, vectors, options)) {
        grids.push_back(make());
        grids.back()->setCreator(kCreator);
    }
    return grids;
}

openvdb::GridPtrVec sellingGrids(const Band& band) {
    openvdb::initialize();
    openvdb::GridPtrVec grids;
    for (const GridMaker& make : sellingGridMakers(band)) grids.push_back(make());
    return grids;
}

void writeVdb(const openvdb::GridPtrVec& grids, const std::string& path, const openvdb::MetaMap& metadata, const VdbWriteOptions& options) {
    openvdb::initialize();
    if (options.nanoVdb) {  // the streaming writer checks and labels each grid itself
        std::vector<GridMaker> makers;
        for (const auto& g : grids) makers.push_back([g] { return g; });
        writeGridsStreaming(makers, path, metadata, options);
        return;
    }
    for (const auto& g : grids) checkFiniteGrid(g, options.halfFloat);
    for (auto& g : grids) {
        g->setSaveFloatAsHalf(options.halfFloat);
        g->setCreator(kCreator);
    }
    try {
        openvdb::io::File file(path);
        file.setCompression(openvdb::io::COMPRESS_BLOSC);
        file.write(grids, metadata);
        file.close();
    } catch (const openvdb::Exception& e) {
        throw OutputError(path + ": cannot write the VDB file: " + e.what());
    }
}

void writeBandVdb(const Band& band, const std::string& path, const openvdb::MetaMap& metadata, const std::vector<NamedChannel>& extra,
                  const std::vector<NamedVectorChannel>& vectors, const VdbWriteOptions& options) {
    std::vector<GridMaker> makers = bandGridMakers(band, extra, vectors, options);
    if (options.sellingStencils) {
        std::vector<GridMaker> selling = sellingGridMakers(band);
        makers.insert(makers.end(), selling.begin(), selling.end());
    }
    writeGridsStreaming(makers, path, metadata, options);
}

SpilledBandGrids::SpilledBandGrids(const Band& band, std::string sidePath, const VdbWriteOptions& options)
    : path_(std::move(sidePath)), halfFloat_(options.halfFloat), occupancyName_(options.occupancyName) {
    checkOccupancyName(options, {}, {});
    const std::vector<GridMaker> makers = ownGridMakers(band, options);
    VdbWriteOptions side = options;
    side.nanoVdb = false;  // read back by OpenVDB
    names_ = writeGridsStreaming(makers, path_, openvdb::MetaMap(), side);
}

SpilledBandGrids::~SpilledBandGrids() { std::remove(path_.c_str()); }

double spillableChannelBytes(const Band& band) {
    return double(band.mean.capacity() * sizeof(float) + band.stddev.capacity() * sizeof(float) + band.T.capacity() * sizeof(band.T[0]) +
                  band.normal.capacity() * sizeof(openvdb::Vec3f));
}

void releaseSpilledChannels(Band& band) {
    std::vector<float>().swap(band.mean);
    std::vector<float>().swap(band.stddev);
    std::vector<std::array<float, 6>>().swap(band.T);
    std::vector<openvdb::Vec3f>().swap(band.normal);
}

void writeBandVdb(const Band& band, const SpilledBandGrids& spilled, const std::string& path, const openvdb::MetaMap& metadata,
                  const std::vector<NamedChannel>& extra, const std::vector<NamedVectorChannel>& vectors, const VdbWriteOptions& options) {
    if (spilled.halfFloat() != options.halfFloat || spilled.occupancyName() != options.occupancyName)
        throw Error("the band's grids were spilled with another half-float setting or occupancy name than the file is written with");
    openvdb::initialize();
    std::vector<GridMaker> makers = channelGridMakers(band, extra, vectors);
    checkOccupancyName(options, extra, vectors);
    auto side = std::make_shared<openvdb::io::File>(spilled.path());
    try {
        side->open(/*delayLoad=*/false);
    } catch (const openvdb::Exception& e) {
        throw OutputError(spilled.path() + ": cannot read the band's spilled grids back: " + e.what());
    }
    std::vector<GridMaker> own;
    for (const std::string& name : spilled.names()) own.push_back([side, name] { return side->readGrid(name); });
    makers.insert(makers.begin(), own.begin(), own.end());
    if (options.sellingStencils) {
        std::vector<GridMaker> selling = sellingGridMakers(band);
        makers.insert(makers.end(), selling.begin(), selling.end());
    }
    writeGridsStreaming(makers, path, metadata, options);
}

}  // namespace gpisvdb
