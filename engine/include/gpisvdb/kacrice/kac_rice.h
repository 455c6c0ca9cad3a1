#pragma once
// The Kac–Rice surface density μ and tangent-plane tensor T at one point (paper Eq. 4, 11, 16; docs/math.md#kac-rice).
// Condition ∇φ on φ = u: X ~ N(m, Σ), m = ∇γ + c_g0 (u − γ)/c₀₀, Σ = C_gg − c_g0 c_g0ᵀ/c₀₀. Then
//   μ = p(u) E‖X‖,   T = p(u) E[‖X‖ I − X Xᵀ/‖X‖]   (tr T = 2μ exactly, T symmetric PSD),
// with p the density of φ(x) ~ N(γ, c₀₀) at u and the expectations by the QMC rule, X_k = m + L z_k, Σ = L Lᵀ.
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

struct SurfaceDensity {
    double mu = 0;                       ///< μ, world units⁻¹ (area per volume)
    Mat3d T = Mat3d::Zero();             ///< T, world units⁻¹
    double density = 0;                  ///< p_φ(x)(u), the value density of φ at the iso-value
    Vec3d meanGradient = Vec3d::Zero();  ///< m = E[∇φ | φ = u], world units⁻¹ (points into γ > u)
};

/// μ and T from the Gaussian (φ, ∇φ) at a point. A point with c₀₀ ≤ 0 (no uncertainty left) or whose density
/// underflows gets μ = 0, T = 0.
/// The expectations run over the rule in SIMD lanes (8 points at a time, the same result on every CPU).
SurfaceDensity kacRice(const ValueGradient& z, double iso, const QmcRule& rule);

/// The same with a plain loop over the rule's points: the reference the tests compare kacRice against.
SurfaceDensity kacRiceReference(const ValueGradient& z, double iso, const QmcRule& rule);

}  // namespace gpisvdb
