#pragma once
// Writing a band as an OpenVDB file (docs/band.md, "The .vdb file"): float32 grids, Blosc compression, the voxel size and origin in
// each grid's transform (voxel k is centred at h·k), so the file opens in place in Houdini and Blender.
// Only float and Vec3f grids are written: an unregistered type (Mat3s) makes the whole file unreadable to
// vdb_print and pyopenvdb, and Debian's pyopenvdb refuses a file with an Int32Grid too.
#include <openvdb/openvdb.h>
#include <string>
#include <vector>

#include "gpisvdb/band/band.h"

namespace gpisvdb {

/// A task's scalar result over the band, by linear index. Non-finite values (voxels a task did not reach) are
/// left inactive at the grid's background: VFX tools and samplers never meet inf or NaN.
struct NamedChannel {
    std::string name;
    const std::vector<float>* values = nullptr;
    float background = 0;  ///< value of inactive voxels (outside the band, or non-finite)
};

/// A task's vector result over the band: 3 floats per voxel (interleaved), world units. `vectorType` tells Houdini
/// and Blender how the vectors transform (openvdb::VEC_CONTRAVARIANT_RELATIVE for displacements and velocities).
struct NamedVectorChannel {
    std::string name;
    const std::vector<float>* values = nullptr;
    openvdb::VecType vectorType = openvdb::VEC_CONTRAVARIANT_RELATIVE;
};

struct VdbWriteOptions {
    bool halfFloat = false;        ///< store float and vec3 grids as 16-bit halves (half the file; ~3 significant digits)
    bool sellingStencils = false;  ///< also write each voxel's Selling decomposition (sellingGrids), ~96 bytes per voxel
    /// Name of the occupancy fog volume P(φ > u) (occupancyGrid); "density" is what Blender's Principled Volume and
    /// Houdini's volume display read without set-up. Empty: not written.
    std::string occupancyName = "density";
    /// Write NanoVDB instead of OpenVDB (docs/band.md#nanovdb): one uncompressed segment per grid, float grids as
    /// Fp16 with halfFloat; names, classes and transforms carry, the file metadata has no place there.
    bool nanoVdb = false;
};

/// Whether `path` names a NanoVDB file (it ends in ".nvdb"): how the front ends choose VdbWriteOptions::nanoVdb.
bool isNanoVdbPath(const std::string& path);

/// The band's own grids' names, in file order, the occupancy's aside: mu … stencil_width.
const std::vector<std::string>& bandGridNames();

/// Grids: mu (fog volume), mean, stddev, T_diag (xx, yy, zz), T_offdiag (xy, xz, yz), normal (outward unit),
/// stencil_width (max ‖e‖₁, as float), the occupancy (options.occupancyName, fog volume), then `extra`, then
/// `vectors`. Every grid's creator is "gpisvdb VERSION". Throws Error when a channel does not match the band, and
/// ParameterError when the occupancy's name is another grid's.
openvdb::GridPtrVec bandGrids(const Band& band, const std::vector<NamedChannel>& extra = {},
                              const std::vector<NamedVectorChannel>& vectors = {}, const VdbWriteOptions& options = {});

/// Each voxel's Selling decomposition T ≈ Σ_k λ_k e_k e_kᵀ (k = 0..5), enough to rebuild L from the file alone
/// (docs/band.md#rebuilding-l-from-the-file): float grids selling_weight_0..5 (λ_k, world units⁻¹; 0 for unused
/// terms) and Vec3f grids selling_offset_0..5 (e_k in index space, integer components, exact also in half floats).
/// Every grid is active on exactly the band's voxels, like mu.
openvdb::GridPtrVec sellingGrids(const Band& band);

/// Writes grids with Blosc compression and the file metadata (NanoVDB with options.nanoVdb), each grid's creator
/// set to "gpisvdb VERSION". Throws OutputError when the file cannot be written.
/// Never writes inf or NaN: a float or Vec3f grid with a non-finite active value or background throws Error
/// (naming the grid and the first voxel), and with options.halfFloat one beyond ±65504 (a half's largest
/// finite value) throws ParameterError naming VdbWriteOptions::halfFloat. Nothing is written then.
void writeVdb(const openvdb::GridPtrVec& grids, const std::string& path, const openvdb::MetaMap& metadata,
              const VdbWriteOptions& options = {});

/// bandGrids (and sellingGrids when options.sellingStencils), then writeVdb. Throws Error when the band's channels
/// were released by releaseSpilledChannels (write it with its SpilledBandGrids instead).
void writeBandVdb(const Band& band, const std::string& path, const openvdb::MetaMap& metadata, const std::vector<NamedChannel>& extra = {},
                  const std::vector<NamedVectorChannel>& vectors = {}, const VdbWriteOptions& options = {});

/// The band's own grids (mu … stencil_width, as bandGrids makes them) written ahead of a long stage into a side
/// file, so that the channels only those grids read — mean, stddev, T and normal, 44 B per voxel — can be freed for
/// the stage (releaseSpilledChannels; docs/memory.md#spill). writeBandVdb(band, spilled, …) then copies them back
/// one at a time into the final file: the same grids, values and order as writing from memory.
class SpilledBandGrids {
public:
    /// Writes the side file `sidePath` (Blosc; half floats when options.halfFloat, as the final file will have
    /// them). Throws as writeBandVdb does; leaves no side file then.
    SpilledBandGrids(const Band& band, std::string sidePath, const VdbWriteOptions& options = {});
    ~SpilledBandGrids();  ///< removes the side file
    SpilledBandGrids(const SpilledBandGrids&) = delete;
    SpilledBandGrids& operator=(const SpilledBandGrids&) = delete;
    const std::string& path() const { return path_; }
    const std::vector<std::string>& names() const { return names_; }  ///< the grids it holds, in file order
    bool halfFloat() const { return halfFloat_; }
    const std::string& occupancyName() const { return occupancyName_; }

private:
    std::string path_;
    std::vector<std::string> names_;
    bool halfFloat_ = false;
    std::string occupancyName_;
};

/// Bytes releaseSpilledChannels would free: the capacity of mean, stddev, T and normal.
double spillableChannelBytes(const Band& band);

/// Frees mean, stddev, T and normal (their grids are in a SpilledBandGrids): what a Green's function solve and the
/// writer of a spilled band no longer read. μ, the stencils, the coordinates and the index stay.
void releaseSpilledChannels(Band& band);

/// writeBandVdb for a band whose own grids were spilled: those copied from `spilled`'s side file, one at a time,
/// then `extra`, `vectors` and (options.sellingStencils) the Selling grids from memory. Throws Error when `spilled`
/// was written with another options.halfFloat.
void writeBandVdb(const Band& band, const SpilledBandGrids& spilled, const std::string& path, const openvdb::MetaMap& metadata,
                  const std::vector<NamedChannel>& extra = {}, const std::vector<NamedVectorChannel>& vectors = {},
                  const VdbWriteOptions& options = {});

}  // namespace gpisvdb
