#pragma once
// Column values of μ and T (docs/math.md#column-values): a voxel's μ and T are their means along its three
// axis-parallel segments through the centre, weighted by n_a² (n the direction of ∇γ there; Σ n_a² = 1), by Kac–Rice
// (kac_rice.h) at Gauss points on the Gaussian (φ, ∇φ) interpolated between the centre and its face neighbours. Down a
// column of voxels along one axis the segments tile the line, so their sum is ∫ μ dt, the expected area per unit
// cross-section over |n_a|, wherever the surface falls between centres: the expected area no longer depends on the
// lattice's offset once h ≫ μ's width, as the centres' values do.
//
// The mean and its gradient are interpolated in the model's MeanScale: for the winding number, whose mean across a
// surface is ≈ Φ(−d/s), in the probit scale ψ = Φ⁻¹(γ), ∇ψ = ∇γ / φ(ψ), where that profile is linear, so that a
// crossing between two centres lands where it is and with the gradient it has there; the covariance linearly.
#include <array>

#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

/// The Gaussian at fraction λ ∈ [0, 1] of the way from a to b. Probit scale: where both means lie in (10⁻⁹, 1 − 10⁻⁹),
/// ψ and ∇ψ linearly, mapped back by γ = Φ(ψ), ∇γ = φ(ψ) ∇ψ; elsewhere, and in the linear scale, the mean linearly.
/// The covariance linearly in both.
ValueGradient interpolateGaussian(const ValueGradient& a, const ValueGradient& b, double lambda, MeanScale scale);

/// A voxel's Gaussian and its six face neighbours' (−x, +x, −y, +y, −z, +z), at centres h apart.
struct ColumnGaussians {
    const ValueGradient* centre = nullptr;
    std::array<const ValueGradient*, 6> neighbour{};
};

/// μ and T of the voxel, the means along its three segments (6 Gauss–Legendre points per half segment). density
/// and meanGradient are the centre's point values (normals do not depend on h). Points whose value density at u is
/// below e⁻⁴⁰ of its peak are skipped (they add < 10⁻¹⁷ of it).
SurfaceDensity kacRiceColumn(const ColumnGaussians& z, double iso, MeanScale scale, const QmcRule& rule);

}  // namespace gpisvdb
