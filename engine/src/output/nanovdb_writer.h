#pragma once
// Writing grids as NanoVDB (docs/band.md#nanovdb): the file format GPU renderers load directly.
#include <fstream>
#include <openvdb/openvdb.h>
#include <string>

namespace gpisvdb {

/// A NanoVDB file written one grid at a time: each grid converted by NanoVDB's OpenToNanoVDB and appended as its
/// own uncompressed segment (nanovdb::io::readGrids reads them all back). Float grids become Fp16 with halfFloat,
/// Vec3f grids stay 32-bit. The .vdb's file metadata has no place in NanoVDB: names, classes and transforms carry.
class NanoVdbStreamWriter {
public:
    /// Writes `file`; errors name `shownPath` (the file's final name when `file` is a temporary).
    NanoVdbStreamWriter(const std::string& file, std::string shownPath, bool halfFloat);
    /// Throws Error for a grid type other than float or Vec3f.
    void write(const openvdb::GridBase::ConstPtr& grid);
    void close();

private:
    std::string path_;
    bool halfFloat_ = false;
    std::ofstream file_;
};

}  // namespace gpisvdb
