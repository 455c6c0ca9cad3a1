#include "nanovdb_writer.h"

#include <nanovdb/util/IO.h>
#include <nanovdb/util/OpenToNanoVDB.h>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/write_vdb.h"

namespace gpisvdb {

bool isNanoVdbPath(const std::string& path) {
    const std::string ext = ".nvdb";
    return path.size() >= ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0;
}

NanoVdbStreamWriter::NanoVdbStreamWriter(const std::string& file, std::string shownPath, bool halfFloat)
    : path_(std::move(shownPath)), halfFloat_(halfFloat) {
    file_.open(file, std::ios_base::out | std::ios_base::binary | std::ios_base::trunc);
    if (file_.fail()) throw OutputError(path_ + ": cannot open the NanoVDB file for writing");
}

void NanoVdbStreamWriter::write(const openvdb::GridBase::ConstPtr& grid) {
    nanovdb::GridHandle<nanovdb::HostBuffer> handle;
    if (auto f = openvdb::GridBase::constGrid<openvdb::FloatGrid>(grid)) {
        handle =
            halfFloat_ ? nanovdb::openToNanoVDB<nanovdb::HostBuffer, openvdb::FloatTree, nanovdb::Fp16>(*f) : nanovdb::openToNanoVDB(*f);
    } else if (auto v = openvdb::GridBase::constGrid<openvdb::Vec3SGrid>(grid)) {
        handle = nanovdb::openToNanoVDB(*v);
    } else {
        throw Error(path_ + ": grid '" + grid->getName() + "' is of type " + grid->type() +
                    "; the NanoVDB writer takes float and Vec3f grids");
    }
    nanovdb::io::writeGrid(file_, handle, nanovdb::io::Codec::NONE);
    if (file_.fail()) throw OutputError(path_ + ": cannot write the NanoVDB file (disk full?)");
}

void NanoVdbStreamWriter::close() {
    file_.close();
    if (file_.fail()) throw OutputError(path_ + ": cannot write the NanoVDB file (disk full?)");
}

}  // namespace gpisvdb
