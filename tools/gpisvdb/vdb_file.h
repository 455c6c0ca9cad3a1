#pragma once
// Reading a .vdb written by gpisvdb (mesh, render, sample, hodge --field): all its grids and metadata, with errors
// that name the file and the grids it has.
#include <openvdb/openvdb.h>
#include <string>
#include <utility>

namespace gpisvdb::cli {

struct VdbFile {
    std::string path;
    openvdb::GridPtrVecPtr grids;
    openvdb::MetaMap::Ptr metadata;

    /// Throws InputError when the file is missing or not an OpenVDB file.
    static VdbFile read(const std::string& path);
    /// The grid called `name`, its values read in; throws InputError naming the grids the file has.
    openvdb::GridBase::Ptr grid(const std::string& name) const;
    /// The float grid called `name`; throws InputError when missing or of another type.
    openvdb::FloatGrid::Ptr floatGrid(const std::string& name) const;
    /// The float vector (Vec3s) grid called `name`, or the only one when `name` is empty; throws InputError when
    /// there is none, no such one, or (unnamed) several.
    openvdb::Vec3SGrid::Ptr vectorGrid(const std::string& name) const;
    /// "mu, mean, stddev, …"
    std::string names() const;
    /// "FILE.vdb:GRID" → {"FILE.vdb", "GRID"}; "FILE.vdb" (or a colon inside the path) → {"FILE.vdb", ""}.
    static std::pair<std::string, std::string> splitSpec(const std::string& spec);
    /// The level the band was built at (metadata 'iso'; 0.5, the winding model's, when absent).
    double iso() const;
};

}  // namespace gpisvdb::cli
