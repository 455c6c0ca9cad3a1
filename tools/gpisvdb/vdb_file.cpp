#include "vdb_file.h"

#include <filesystem>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::cli {

VdbFile VdbFile::read(const std::string& path) {
    openvdb::initialize();
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path + ": no such file");
    VdbFile f;
    f.path = path;
    try {
        openvdb::io::File file(path);
        file.open();
        f.grids = file.getGrids();
        f.metadata = file.getMetadata();
        file.close();
    } catch (const openvdb::Exception& e) {
        throw InputError(path + ": cannot be read as an OpenVDB file (" + e.what() + ")");
    } catch (const std::exception& e) {  // a malformed file: lengths OpenVDB allocates (bad_alloc, length_error), I/O
        throw InputError(path + ": cannot be read as an OpenVDB file (" + e.what() + ")");
    }
    return f;
}

std::string VdbFile::names() const {
    std::string s;
    for (const auto& g : *grids) s += (s.empty() ? "" : ", ") + g->getName();
    return s.empty() ? "no grids" : s;
}

openvdb::GridBase::Ptr VdbFile::grid(const std::string& name) const {
    for (const auto& g : *grids)
        if (g->getName() == name) {
            // Read now, not at first use: OpenVDB opens files with delayed loading, and a grid read in the middle of
            // a stage would add to it what its estimate counts in the baseline (docs/memory.md#mesh)
            g->baseTree().readNonresidentBuffers();
            return g;
        }
    throw InputError(path + ": no grid '" + name + "' (the file has: " + names() + ")");
}

openvdb::FloatGrid::Ptr VdbFile::floatGrid(const std::string& name) const {
    auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(grid(name));
    if (!g) throw InputError(path + ": grid '" + name + "' is not a float grid");
    return g;
}

openvdb::Vec3SGrid::Ptr VdbFile::vectorGrid(const std::string& name) const {
    openvdb::Vec3SGrid::Ptr field;
    std::string vectors;
    int count = 0;
    for (const auto& g : *grids) {
        auto v = openvdb::gridPtrCast<openvdb::Vec3SGrid>(g);
        if (!v) continue;
        ++count;
        vectors += (vectors.empty() ? "" : ", ") + g->getName();
        if (name.empty() ? !field : g->getName() == name) field = v;
    }
    if (!name.empty() && !field)
        throw InputError(path + ": no vector grid named '" + name + "' (vector grids: " + (vectors.empty() ? "none" : vectors) + ")");
    if (!field) throw InputError(path + ": holds no float vector (Vec3s) grid");
    if (name.empty() && count > 1) throw InputError(path + ": holds several vector grids (" + vectors + "): name one as " + path + ":NAME");
    return field;
}

std::pair<std::string, std::string> VdbFile::splitSpec(const std::string& spec) {
    const auto colon = spec.rfind(':');
    if (colon != std::string::npos && colon + 1 < spec.size() && spec.find(".vdb", colon) == std::string::npos)
        return {spec.substr(0, colon), spec.substr(colon + 1)};
    return {spec, std::string()};
}

double VdbFile::iso() const {
    const auto stored = metadata ? (*metadata)["iso"] : openvdb::Metadata::Ptr();
    const auto* value = stored ? dynamic_cast<const openvdb::DoubleMetadata*>(stored.get()) : nullptr;
    return value ? value->value() : 0.5;
}

}  // namespace gpisvdb::cli
