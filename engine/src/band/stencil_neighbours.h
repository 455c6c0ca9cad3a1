#pragma once
// The band voxels each voxel's Selling stencil reaches, resolved once through the index tree (shared by the
// matrix-free Laplacian and fast marching).
#include <cstdint>
#include <vector>

#include "gpisvdb/band/band.h"

namespace gpisvdb::detail {

constexpr int kStencilSlots = 12;  // 6 terms × 2 signs

/// Linear index of x_i ± h e_k at [12 i + 2 k + s] (s = 0: +e_k, s = 1: −e_k); −1 outside the band or beyond the
/// voxel's term count.
std::vector<std::int32_t> stencilNeighbours(const Band& band);

/// The same for voxels [first, last) only, into out (resized to 12 (last − first); slot 12 (i − first) + 2 k + s).
void stencilNeighbours(const Band& band, std::size_t first, std::size_t last, std::vector<std::int32_t>& out);

}  // namespace gpisvdb::detail
