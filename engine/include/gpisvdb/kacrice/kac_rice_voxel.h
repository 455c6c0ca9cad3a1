#pragma once
// The voxel's own share of μ and T (docs/math.md#voxel-kac-rice): the expected surface area inside a cube of side h,
// and its tangent moment, over h³. The Gaussian (φ, ∇φ) at the cube's centre is linearised across the cube,
// φ(c + y) = φ₀ + g·y; given g, the level set φ = u is a plane of normal g/‖g‖ whose area inside the cube is h³ times
// the box spline of the cube's cross-sections, and φ₀ given g is Gaussian, so
//   μ_h = E_g[‖g‖ ρ(u − E[φ₀|g])],   T_h = E_g[ρ(u − E[φ₀|g]) (‖g‖ I − g gᵀ/‖g‖)],
// ρ the density of U(h|g_x|) + U(h|g_y|) + U(h|g_z|) + N(0, Var[φ₀|g]) (box_gaussian.h), g ~ N(∇γ, C_gg) by the QMC
// rule. tr T_h = 2 μ_h; as h → 0, μ_h → μ (paper Eq. 11). Unlike the point value, Σ μ_h h³ over the voxels that a
// surface crosses is that surface's expected area at any h (the cubes' cross-sections tile each plane exactly).
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

/// μ_h and T_h over the cube of side h (world units, > 0) centred where z was evaluated. density and meanGradient
/// are the point values of kacRice (p(u) and E[∇φ | φ = u] at the centre), so that normals do not depend on h.
/// A point with c₀₀ ≤ 0 gets μ = 0, T = 0, as in kacRice. The linearisation holds where γ is linear across the cube:
/// for the winding number, whose γ is about Φ(−d/s) across a surface, while h ≲ s/2 (band/default_band.h raises s).
SurfaceDensity kacRiceVoxel(const ValueGradient& z, double iso, double h, const QmcRule& rule);

/// Whether the mean surface γ = u, linearised at the centre, passes through the cube of side h centred there:
/// |u − γ| ≤ ½ h ‖∇γ‖₁.
bool meanSurfaceCrosses(const ValueGradient& z, double iso, double h);

}  // namespace gpisvdb
