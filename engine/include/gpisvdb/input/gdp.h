#pragma once
// Gaussian dipoles (.gdp), the input format of the paper's own implementation (docs/guide.md#gdp). Text: a header
// "3 N" (dimension, dipoles), then per dipole its position p (3 numbers, world units), its vector area w (the
// area-weighted normal, 3 numbers, world units²) and the 6×6 covariance of (p, w), row-major (36 numbers); white
// space of any kind separates the numbers. After the dipoles only comment lines ('#') may follow; "# length_scale L"
// gives ℓ (writeGdp adds it; readers that stop after the N dipoles, as the paper's does, never see it).
//
// gpisvdb's model takes a sample's position noise isotropic and independent of its normal's (docs/math.md#samples):
// a dipole's covariance must be [[v I, 0], [0, Σ']] with v > 0 and Σ' positive semi-definite, each to a relative
// 1e-6. readInput reads a .gdp as an oriented cloud with its own v_i, w_i (area |w_i|), Σ'_i and, where given, ℓ,
// and refuses a dipole whose covariance is otherwise, naming the part the model does not carry.
#include <string>

#include "gpisvdb/input/samples.h"

namespace gpisvdb {

/// Writes the samples as .gdp to `path` (the caller renames it into place): covariance [[v_i I, 0], [0, Σ'_i]], then
/// "# length_scale ℓ"; every number in the shortest form that reads back as the same double (read again, the samples
/// are the same to the bit). Throws Error when the samples' arrays differ in
/// length, OutputError when the file cannot be written.
void writeGdp(const Samples& samples, const std::string& path);

}  // namespace gpisvdb
