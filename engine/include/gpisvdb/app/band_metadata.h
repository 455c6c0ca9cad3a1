#pragma once
// A band's .vdb metadata (docs/band.md, "The .vdb file"), the same from every front end: how the band was made
// (provenance, the model's settings and what they resolved to, the band's options as used) and what it measured.
#include <openvdb/openvdb.h>

#include <string>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/model/load_model.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/stencil/resolution.h"

namespace gpisvdb::app {

/// What only the front end knows of a band's making.
struct BandProvenance {
    std::string commandLine;  ///< the command as given ("python: gpisvdb.band" from Python)
    std::string input;        ///< the input file's path ("numpy" for arrays)
    std::string labelsPath;   ///< regression: the label file given; empty: labels generated or given as an array
};

/// The file's metadata. modelOptions: the model's settings as asked; model: what they resolved to (σ, s, the
/// training labels); options: the band's, voxel size resolved; budgeted: the band-voxel budget set the voxel size.
openvdb::MetaMap bandMetadata(const BandProvenance& provenance, const ModelOptions& modelOptions, const LoadedModel& model,
                              const BandOptions& options, const Resolution& resolution, bool budgeted, const BandResult& result,
                              const VdbWriteOptions& vdb);

}  // namespace gpisvdb::app
