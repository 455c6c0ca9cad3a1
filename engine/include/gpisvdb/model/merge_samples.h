#pragma once
// Samples merged into Gaussian dipoles at the analysis scale (docs/math.md#merging): on a dense scan the kernel's
// smoothing s spans many samples, and a band voxel's Barnes–Hut traversal meets every one of them near the surface
// (docs/benchmarks.md#scan-model). Merging the samples of each cubic cell of width c ≪ s into one dipole keeps the
// model's mean and covariance to O((c/s)²) while the model's cost per voxel stops growing with the density.
#include <cstddef>

#include "gpisvdb/input/samples.h"

namespace gpisvdb {

/// The samples of each cell of a cubic lattice of width `cell` (world units, > 0, anchored at the world origin) as one
/// dipole: its vector area the sum W = Σ w_i, its position the |w|-weighted centroid, its normals' covariance the sum
/// Σ Σ'_i (independent noises add), and its position variance v = Σ |w_i|² v_i / |W|², so that the position noise's
/// share of φ's variance, v·|H W|² with H the kernel's Hessian, keeps its size Σ v_i |H w_i|² where the w_i are
/// parallel (the cell is small against the surface's curvature radius). A cell whose vector areas nearly cancel
/// (|W| < 1e-6 Σ|w_i|, two sheets closer than `cell`) takes v = Σ |w_i|² v_i / (Σ|w_i|)². A cell of one sample keeps
/// it unchanged. The dipoles come in the order of their cells' first samples, so the result does not depend on the
/// thread count. ℓ is kept (it describes the input's spacing, which the defaults follow).
/// \param samples  the samples, world units, their arrays of equal length
/// \param cell     the cells' width c, world units (> 0)
/// \return at most samples.size() dipoles, with the samples' ℓ
/// \throws ParameterError when `cell` is not finite and > 0, or so small that a coordinate over it passes 4.5e15 (the
///         cells' integer indices)
/// \par Complexity
///   O(n) for n samples: one pass through a hash map of the cells; extra memory while it runs about 250 B per cell
///   (the map's entry and the cell's sums) beside the dipoles it returns (104 B each).
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. One thread.
Samples mergeSamples(const Samples& samples, double cell);

}  // namespace gpisvdb
