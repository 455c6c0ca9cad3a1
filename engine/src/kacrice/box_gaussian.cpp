#include "gpisvdb/kacrice/box_gaussian.h"

#include <algorithm>
#include <cmath>

#include "core/simd_lanes.h"
#include "core/vector_math.h"

namespace gpisvdb {

namespace {

/// Beyond this many standard deviations Φ is 0 or 1 and the Gaussian's density 0 (to 1e-15 relative).
constexpr double kTail = 8.0;

/// The k-th antiderivative (k = 0, 1, 2) of the CDF of N(0, s²) at x, vanishing at −∞:
///   F0 = Φ(z), F1 = s (z Φ(z) + ϕ(z)), F2 = s² ((z² + 1) Φ(z) + z ϕ(z)) / 2,  z = x/s;
/// s = 0 gives the step and its antiderivatives (H(x), max(x, 0), max(x, 0)²/2).
double cdfAntiderivative(int k, double x, double s) {
    const double z = s > 0 ? x / s : (x > 0 ? 2 * kTail : -2 * kTail);
    if (z <= -kTail) return 0.0;
    if (z >= kTail) return k == 0 ? 1.0 : k == 1 ? x : 0.5 * (x * x + s * s);
    const double Phi = 0.5 * std::erfc(-z * M_SQRT1_2), phi = std::exp(-0.5 * z * z) * (0.5 * M_2_SQRTPI * M_SQRT1_2);
    if (k == 0) return Phi;
    if (k == 1) return s * (z * Phi + phi);
    return 0.5 * s * s * ((z * z + 1.0) * Phi + z * phi);
}

}  // namespace

double boxGaussianDensity(double x, double a, double b, double c, double s) {
    double w[3] = {std::abs(a), std::abs(b), std::abs(c)};
    s = std::abs(s);
    const double scale = std::sqrt(s * s + (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) / 12.0);
    if (!(scale > 0)) return 0.0;
    const double half = 0.5 * (w[0] + w[1] + w[2]);
    if (std::abs(x) >= half + kTail * s && (s > 0 || std::abs(x) > half)) return 0.0;
    // === Widths too small to matter are point masses: the divided differences below would only add rounding.
    int k = 0;
    for (double wi : w)
        if (wi >= 1e-4 * scale) w[k++] = wi;
    if (k == 0) return std::exp(-0.5 * (x / s) * (x / s)) / (s * std::sqrt(2.0 * M_PI));
    // === The k-fold divided difference of F_{k−1} over the box's 2^k corners: the density of U + N(0, s²) is the
    // convolution of the uniforms' densities (1/w on [−w/2, w/2]) with the Gaussian's, F_{k−1} its k-th
    // antiderivative.
    double sum = 0;
    for (int corner = 0; corner < (1 << k); ++corner) {
        double shift = 0, sign = 1;
        for (int i = 0; i < k; ++i) {
            const bool plus = corner >> i & 1;
            shift += plus ? 0.5 * w[i] : -0.5 * w[i];
            if (!plus) sign = -sign;
        }
        sum += sign * cdfAntiderivative(k - 1, x + shift, s);
    }
    double width = 1;
    for (int i = 0; i < k; ++i) width *= w[i];
    return std::max(0.0, sum / width);
}

namespace {
/// A sum's 8 corners, one lane each: corner k adds ±a/2 (bit 0), ±b/2 (bit 1), ±c/2 (bit 2).
using Corners = gpisvdb::simd::Lanes;
constexpr Corners kSignA = {-1, 1, -1, 1, -1, 1, -1, 1}, kSignB = {-1, -1, 1, 1, -1, -1, 1, 1}, kSignC = {-1, -1, -1, -1, 1, 1, 1, 1};
/// (−1)^(3 − the corner's plus signs): the third divided difference's weights.
constexpr Corners kDifference = kSignA * kSignB * kSignC;
}  // namespace

GPISVDB_SIMD_CLONES void boxGaussianDensities(std::size_t n, const double* x, const double* a, const double* b, const double* c, double s,
                                              double* out) {
    s = std::abs(s);
    if (!(s > 0)) {
        for (std::size_t i = 0; i < n; ++i) out[i] = boxGaussianDensity(x[i], a[i], b[i], c[i], s);
        return;
    }
    // === Sums whose three widths all count (nearly all, where g has no vanishing component): the third divided
    // difference of F2 over the box's 8 corners in lanes. Unclamped, erf saturates to ±1 and exp underflows to 0 in
    // the tails, where F2's formula then reads 0 or (y² + s²)/2 exactly. The others (a width below 1e-4 of the
    // scale) go through boxGaussianDensity.
    const double inv = 1.0 / s, norm = 0.5 * M_2_SQRTPI * M_SQRT1_2;  // 1/√(2π)
    for (std::size_t i = 0; i < n; ++i) {
        const double wa = std::abs(a[i]), wb = std::abs(b[i]), wc = std::abs(c[i]);
        const double scale = std::sqrt(s * s + (wa * wa + wb * wb + wc * wc) / 12.0);
        if (std::min({wa, wb, wc}) < 1e-4 * scale) {
            out[i] = boxGaussianDensity(x[i], a[i], b[i], c[i], s);
            continue;
        }
        const Corners z = (x[i] + 0.5 * (wa * kSignA + wb * kSignB + wc * kSignC)) * inv;
        Corners args = z * M_SQRT1_2, halfSquares = -0.5 * z * z, erfs, exps;
        erfExp8(reinterpret_cast<const double*>(&args), reinterpret_cast<const double*>(&halfSquares), reinterpret_cast<double*>(&erfs),
                reinterpret_cast<double*>(&exps));
        const Corners F = kDifference * ((z * z + 1.0) * (0.5 + 0.5 * erfs) + z * (norm * exps));
        double sum = 0;
        for (int k = 0; k < 8; ++k) sum += F[k];
        out[i] = std::max(0.0, 0.5 * s * s * sum / (wa * wb * wc));
    }
}

double boxGaussianDensityReference(double x, double a, double b, double c, double s, int n) {
    const double w[3] = {std::abs(a), std::abs(b), std::abs(c)};
    double sum = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int l = 0; l < n; ++l) {
                const double y = x - w[0] * ((i + 0.5) / n - 0.5) - w[1] * ((j + 0.5) / n - 0.5) - w[2] * ((l + 0.5) / n - 0.5);
                sum += std::exp(-0.5 * (y / s) * (y / s));
            }
    return sum / (double(n) * n * n * s * std::sqrt(2.0 * M_PI));
}

}  // namespace gpisvdb
