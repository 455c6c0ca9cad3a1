#pragma once
// The regularized Newton potential ρ(r) = erf(r / (√2 s)) / r (paper Eq. 6; docs/math.md#gpis) and its
// derivatives up to order 4, exact from r = 0 to the far field.
//
// ρ is a smooth function of t = r², ρ = G(t), so every Cartesian derivative is a combination of
//   F_k = 2^k G^(k)(t)   (F_1 = f′/r, F_2 = (f″ − f′/r)/r², F_3 = (1/r) dF_2/dr, ...):
//   ∇ρ      = F_1 y
//   D²ρ     = F_1 I + F_2 y yᵀ
//   D³ρ_ijk = F_2 (δ_ij y_k + δ_ik y_j + δ_jk y_i) + F_3 y_i y_j y_k
//   D⁴ρ     = F_2 (δδ, 3 terms) + F_3 (δ y y, 6 terms) + F_4 y y y y
// with y = x − p in world units. Below a·r < 2 (a = 1/(√2 s)) the F_k come from their power series
// in t, above it from the closed forms in erf and exp; both agree to rounding at the switch.
#include "gpisvdb/core/types.h"

namespace gpisvdb {

struct RadialDerivatives {
    double F0 = 0, F1 = 0, F2 = 0, F3 = 0, F4 = 0;  ///< F0 = ρ itself
};

class RegularizedKernel {
public:
    /// s: smoothing length (world units, > 0).
    explicit RegularizedKernel(double s);

    double smoothing() const { return s_; }
    /// All F_k at squared distance t = r² (world units²).
    RadialDerivatives at(double t) const;
    /// r² beyond which at() uses the pure Newton terms (erf = 1, no Gaussian term): F_k = c_k r^-(2k+1).
    double newtonDistance2() const { return tFar_; }
    /// r² below which at() sums the power series; between the two, the closed forms in erf(a r) and exp(−a² r²).
    double seriesDistance2() const { return tSwitch_; }
    /// a = 1/(√2 s) and c = 2a/√π of the closed forms.
    double erfScale() const { return a_; }
    double gaussianFactor() const { return c_; }
    /// Terms of the power series below seriesDistance2(): G^(k)(t) = c Σ_{m < kSeriesTerms} (−a² t)^m / (m! (2m+2k+1)).
    static constexpr int kSeriesTerms = 34;  // 4^34/34! < 1e-18: below double rounding at a·r = 2
    /// The series' constants: inverse[m][k] = 1/(2m + 2k + 1), next[m] = 1/(m + 1) (the SIMD packets multiply by
    /// it where at() divides).
    struct Series {
        double inverse[kSeriesTerms][5];
        double next[kSeriesTerms];
    };
    static const Series& series();

    /// D²ρ at y.
    static Mat3d hessian(const RadialDerivatives& F, const Vec3d& y);
    /// (D³ρ · w)_jl = Σ_m D³ρ_jlm w_m at y (symmetric 3×3).
    static Mat3d thirdContracted(const RadialDerivatives& F, const Vec3d& y, const Vec3d& w);

private:
    double s_;
    double a_;        // 1 / (√2 s)
    double a2_;       // a²
    double c_;        // 2a/√π, the leading factor of erf(a r)
    double tSwitch_;  // r² below which the series is used
    double tFar_;     // r² beyond which erf = 1 and the Gaussian terms vanish in double
};

}  // namespace gpisvdb
