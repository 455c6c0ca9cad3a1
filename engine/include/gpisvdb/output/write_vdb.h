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
};

/// Grids: mu (fog volume), mean, stddev, T_diag (xx, yy, zz), T_offdiag (xy, xz, yz), normal (outward unit),
/// stencil_width (max ‖e‖₁, as float), then `extra`, then `vectors`. Throws Error when a channel does not match
/// the band.
openvdb::GridPtrVec bandGrids(const Band& band, const std::vector<NamedChannel>& extra = {},
                              const std::vector<NamedVectorChannel>& vectors = {});

/// Each voxel's Selling decomposition T ≈ Σ_k λ_k e_k e_kᵀ (k = 0..5), enough to rebuild L from the file alone
/// (docs/band.md#rebuilding-l-from-the-file): float grids selling_weight_0..5 (λ_k, world units⁻¹; 0 for unused
/// terms) and Vec3f grids selling_offset_0..5 (e_k in index space, integer components, exact also in half floats).
/// Every grid is active on exactly the band's voxels, like mu.
openvdb::GridPtrVec sellingGrids(const Band& band);

/// Writes grids with Blosc compression and the file metadata. Throws OutputError when the file cannot be written.
/// Never writes inf or NaN: a float or Vec3f grid with a non-finite active value or background throws Error
/// (naming the grid and the first voxel), and with options.halfFloat one beyond ±65504 (a half's largest
/// finite value) throws ParameterError naming VdbWriteOptions::halfFloat. Nothing is written then.
void writeVdb(const openvdb::GridPtrVec& grids, const std::string& path, const openvdb::MetaMap& metadata,
              const VdbWriteOptions& options = {});

/// bandGrids (and sellingGrids when options.sellingStencils), then writeVdb.
void writeBandVdb(const Band& band, const std::string& path, const openvdb::MetaMap& metadata,
                  const std::vector<NamedChannel>& extra = {}, const std::vector<NamedVectorChannel>& vectors = {},
                  const VdbWriteOptions& options = {});

}  // namespace gpisvdb
