#pragma once
// The adaptive-stencil Laplacian L and the mass M of a band (paper Eq. 22, 24; DESIGN §3.7).
//   E_h(u) = h^(d−2) Σ_x Σ_k λ_k(x) [(u(x+he_k) − u(x))² + (u(x−he_k) − u(x))²] / 2,   uᵀ L u = E_h(u),
// so each edge (x, x+he) carries h (λ^e(x) + λ^e(x+he))/2 (d = 3), and an edge leaving the band adds to the
// diagonal only (u = 0 outside: homogeneous Dirichlet). M = h³ diag(μ). L is assembled once, symmetric by
// construction, in compressed rows of float values (the PCG's storage) and applied in parallel.
#include <Eigen/SparseCore>
#include <vector>

#include "gpisvdb/band/band.h"

namespace gpisvdb {

using SparseMatrixF = Eigen::SparseMatrix<float, Eigen::RowMajor, int>;

/// L over the band's voxels (linear index order). Deterministic for any thread count.
SparseMatrixF assembleLaplacian(const Band& band);

/// M's diagonal, h³ μ (world units², so uᵀ M v → ∫ u v dμ).
std::vector<float> massDiagonal(const Band& band);

/// out = A u, parallel over rows, each row summed in double in a fixed order.
void multiply(const SparseMatrixF& A, const std::vector<float>& u, std::vector<float>& out);

}  // namespace gpisvdb
