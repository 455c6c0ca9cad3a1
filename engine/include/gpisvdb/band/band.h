#pragma once
// The narrow band Ω = {x = h·k : μ(x) > η} (paper Sec. 8.2; docs/math.md#band): an OpenVDB index tree (active voxel →
// linear index, assigned in leaf order) and flat per-voxel channels. Operators run matrix-free over it.
#include <array>
#include <cstdint>
#include <openvdb/openvdb.h>
#include <vector>

#include "gpisvdb/core/types.h"

namespace gpisvdb {

/// One voxel's Selling stencil: T ≈ Σ_k weight_k e_k e_kᵀ, e_k integer offsets in index space.
struct VoxelStencil {
    std::array<float, 6> weight{};                       ///< λ_k ≥ 0 (world units⁻¹, like T)
    std::array<std::array<std::int8_t, 3>, 6> offset{};  ///< e_k
    std::uint8_t count = 0;                              ///< terms used (≤ 6)
    std::uint8_t width = 0;                              ///< max_k ‖e_k‖₁
};

struct Band {
    double voxelSize = 0;               ///< h, world units; voxel k has its centre at h·k
    double iso = 0.5;                   ///< u: μ and T describe the surface φ = u (BandOptions::iso)
    openvdb::Int32Grid::Ptr index;      ///< active voxels hold their linear index; background −1
    std::vector<openvdb::Coord> coord;  ///< index space coordinates, by linear index

    // Channels, by linear index (float storage; docs/band.md).
    std::vector<float> mu;                ///< μ, world units⁻¹
    std::vector<std::array<float, 6>> T;  ///< T as (xx, yy, zz, xy, xz, yz), world units⁻¹
    std::vector<float> mean;              ///< γ
    std::vector<float> stddev;            ///< √c₀₀
    std::vector<openvdb::Vec3f> normal;   ///< outward unit normal −m/‖m‖, m = E[∇φ | φ = u]
    std::vector<VoxelStencil> stencil;    ///< Selling decomposition of T (after regularisation)

    std::size_t size() const { return coord.size(); }
    /// Σ μ h³: the expected area of the GPIS iso-surface (paper Eq. 11), world units².
    double mass() const;
    /// Bytes held per band voxel by the index tree and the channels (measured from the containers).
    double bytesPerVoxel() const;
    /// Inclusive bounding box of the active voxels (index space).
    openvdb::CoordBBox bbox() const;
};

}  // namespace gpisvdb
