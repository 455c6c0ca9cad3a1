#pragma once
// The band voxels each voxel's Selling stencil reaches, resolved once through the index tree: what the stages after
// the band (the matrix-free Laplacian, fast marching, the aggregation multigrid) walk instead of the tree.
#include <cstdint>
#include <vector>

#include "gpisvdb/band/band.h"

namespace gpisvdb {

constexpr int kStencilSlots = 12;  // 6 terms × 2 signs

/// Linear index of x_i ± h e_k at [12 i + 2 k + s] (s = 0: +e_k, s = 1: −e_k; e_k the voxel's k-th Selling offset,
/// index space); −1 outside the band or beyond the voxel's term count. Parallel; 48 B per voxel.
std::vector<std::int32_t> stencilNeighbours(const Band& band);

/// The same for voxels [first, last) only, into out (resized to 12 (last − first); slot 12 (i − first) + 2 k + s).
void stencilNeighbours(const Band& band, std::size_t first, std::size_t last, std::vector<std::int32_t>& out);

}  // namespace gpisvdb
