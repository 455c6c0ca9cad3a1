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
        if (g->getName() == name) return g;
    throw InputError(path + ": no grid '" + name + "' (the file has: " + names() + ")");
}

openvdb::FloatGrid::Ptr VdbFile::floatGrid(const std::string& name) const {
    auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(grid(name));
    if (!g) throw InputError(path + ": grid '" + name + "' is not a float grid");
    return g;
}

double VdbFile::iso() const {
    const auto stored = metadata ? (*metadata)["iso"] : openvdb::Metadata::Ptr();
    const auto* value = stored ? dynamic_cast<const openvdb::DoubleMetadata*>(stored.get()) : nullptr;
    return value ? value->value() : 0.5;
}

}  // namespace gpisvdb::cli
