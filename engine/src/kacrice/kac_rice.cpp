#include "gpisvdb/kacrice/kac_rice.h"

#include <cmath>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/simd_lanes.h"

namespace gpisvdb {

namespace {

/// The conditional Gaussian X ~ N(m, L Lᵀ) of ∇φ given φ = u, and p(u) (paper Eq. 4); false when μ = 0.
bool condition(const ValueGradient& z, double iso, SurfaceDensity& out, Mat3d& L) {
    const double c00 = z.cov(0, 0);
    if (!(c00 > 0)) return false;
    // === Condition ∇φ on φ = u (paper Eq. 4)
    const Vec3d cg0 = z.cov.block<3, 1>(1, 0);
    const double r = iso - z.mean[0];
    out.density = std::exp(-0.5 * r * r / c00) / std::sqrt(2.0 * M_PI * c00);
    out.meanGradient = z.mean.tail<3>() + cg0 * (r / c00);
    if (!(out.density > 0)) return false;
    Mat3d sigma = z.cov.block<3, 3>(1, 1) - cg0 * cg0.transpose() / c00;
    sigma = (0.5 * (sigma + sigma.transpose())).eval();
    // Σ = L Lᵀ. Cholesky where Σ is positive definite: its factor is unique and continuous in Σ, so inputs that
    // differ by rounding give μ and T that differ by rounding. (An eigen-decomposition is not: where eigenvalues
    // are equal, as at symmetric points, rounding rotates the eigenvectors, and with them the QMC points, changing
    // μ by the rule's error, ~1e-4.) Semi-definite Σ (rounding may leave tiny negatives): the eigen-decomposition.
    const Eigen::LLT<Mat3d> llt(sigma);
    if (llt.info() == Eigen::Success) {
        L = llt.matrixL();
        return true;
    }
    Eigen::SelfAdjointEigenSolver<Mat3d> eig(sigma);
    L = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    return true;
}

/// μ and T from the QMC sums Σ‖X‖ and Σ X Xᵀ/‖X‖ (paper Eq. 11, 16).
void finish(double norms, const Mat3d& outer, const QmcRule& rule, SurfaceDensity& out) {
    const double w = out.density / double(rule.size());
    out.mu = w * norms;
    out.T = w * (norms * Mat3d::Identity() - outer);
    out.T = (0.5 * (out.T + out.T.transpose())).eval();
}

// === Expectations in SIMD lanes: eight QMC points per step, one partial sum per lane, lanes summed in a fixed
// order, one clone per instruction set (GPISVDB_SIMD_CLONES, core/simd_lanes.h).
using simd::kLanes;
using simd::Lanes;
using simd::ULanes;

/// sums[0] = Σ‖X‖, sums[1..6] = Σ X Xᵀ/‖X‖ as (xx, yy, zz, xy, xz, yz), over X = m + L q for the rule's points.
/// kNewton: 1/‖X‖ by Newton's iteration instead of a square root and a division (see qmcSums below).
template <bool kNewton>
inline __attribute__((always_inline)) void qmcSumsBody(const double* m, const double (*L)[3], const double* q0, const double* q1,
                                                       const double* q2, const double* weight, std::size_t count, double* sums) {
    Lanes acc[7];
    for (auto& a : acc)
        for (int l = 0; l < kLanes; ++l) a[l] = 0;
    for (std::size_t i = 0; i < count; i += kLanes) {
        Lanes q[3], w, X[3];
        __builtin_memcpy(&q[0], q0 + i, sizeof(Lanes));
        __builtin_memcpy(&q[1], q1 + i, sizeof(Lanes));
        __builtin_memcpy(&q[2], q2 + i, sizeof(Lanes));
        __builtin_memcpy(&w, weight + i, sizeof(Lanes));
        for (int d = 0; d < 3; ++d) X[d] = m[d] + (L[d][0] * q[0] + L[d][1] * q[1] + L[d][2] * q[2]);
        const Lanes n2 = X[0] * X[0] + X[1] * X[1] + X[2] * X[2];
        Lanes n, inv;
        if constexpr (kNewton) {
            // y ≈ 1/√n2 from the exponent bits (relative error ≤ 3.5e-2), then four Newton steps, each squaring the
            // error (×1.5): 1.8e-3, 4.7e-6, 3.3e-11, then below rounding. Valid for every normal n2; lanes below
            // kTiny (X ≈ 0, whose terms are ≤ 1e-150 and the plain loop's ≤ that) and padding contribute 0.
            constexpr double kTiny = 1e-300;
            ULanes bits;
            __builtin_memcpy(&bits, &n2, sizeof(bits));
            const ULanes guess = 0x5FE6EB50C7B537A9ull - (bits >> 1);
            Lanes y;
            __builtin_memcpy(&y, &guess, sizeof(y));
            const Lanes half = 0.5 * n2;
            for (int k = 0; k < 4; ++k) y = y * (1.5 - half * y * y);
            const auto on = n2 > kTiny;  // a lane mask, not per-lane branches (which the compiler leaves scalar)
            n = on ? n2 * y : Lanes{};
            inv = on ? w * y : Lanes{};
        } else {
            for (int l = 0; l < kLanes; ++l) n[l] = __builtin_sqrt(n2[l]);
            // ‖X‖ I − X Xᵀ/‖X‖ → 0 as X → 0; padding lanes have weight 0.
            for (int l = 0; l < kLanes; ++l) inv[l] = n2[l] > 0 ? w[l] / n[l] : 0.0;
        }
        acc[0] += w * n;
        acc[1] += X[0] * X[0] * inv;
        acc[2] += X[1] * X[1] * inv;
        acc[3] += X[2] * X[2] * inv;
        acc[4] += X[0] * X[1] * inv;
        acc[5] += X[0] * X[2] * inv;
        acc[6] += X[1] * X[2] * inv;
    }
    for (int k = 0; k < 7; ++k) {
        double s = 0;
        for (int l = 0; l < kLanes; ++l) s += acc[k][l];
        sums[k] = s;
    }
}

GPISVDB_SIMD_CLONES void qmcSumsPortable(const double* m, const double (*L)[3], const double* q0, const double* q1, const double* q2,
                                         const double* weight, std::size_t count, double* sums) {
    qmcSumsBody<false>(m, L, q0, q1, q2, weight, count, sums);
}

#if defined(__GNUC__) && defined(__x86_64__)
__attribute__((target("avx512f,fma"))) void qmcSumsAvx512(const double* m, const double (*L)[3], const double* q0, const double* q1,
                                                          const double* q2, const double* weight, std::size_t count, double* sums) {
    qmcSumsBody<true>(m, L, q0, q1, q2, weight, count, sums);
}
#endif

/// With AVX-512 the Newton iteration makes the Kac–Rice stage 1.13–1.24× faster than the square root and the division
/// (docs/benchmarks.md#heap-reuse); with AVX2 or SSE2 it was slower, so those keep the square root. The sums agree to
/// rounding (tests: 1e-12 relative).
void qmcSums(const double* m, const double (*L)[3], const double* q0, const double* q1, const double* q2, const double* weight,
             std::size_t count, double* sums) {
#if defined(__GNUC__) && defined(__x86_64__)
    static const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("fma");
    if (avx512) return qmcSumsAvx512(m, L, q0, q1, q2, weight, count, sums);
#endif
    qmcSumsPortable(m, L, q0, q1, q2, weight, count, sums);
}

}  // namespace

SurfaceDensity kacRice(const ValueGradient& z, double iso, const QmcRule& rule) {
    SurfaceDensity out;
    Mat3d L;
    if (!condition(z, iso, out, L)) return out;
    // === Expectations by QMC (paper Sec. 8.3)
    const double m[3] = {out.meanGradient[0], out.meanGradient[1], out.meanGradient[2]};
    const double Lr[3][3] = {{L(0, 0), L(0, 1), L(0, 2)}, {L(1, 0), L(1, 1), L(1, 2)}, {L(2, 0), L(2, 1), L(2, 2)}};
    double sums[7];
    qmcSums(m, Lr, rule.coordinate(0).data(), rule.coordinate(1).data(), rule.coordinate(2).data(), rule.weight().data(),
            rule.weight().size(), sums);
    Mat3d outer;
    outer << sums[1], sums[4], sums[5], sums[4], sums[2], sums[6], sums[5], sums[6], sums[3];
    finish(sums[0], outer, rule, out);
    return out;
}

SurfaceDensity kacRiceReference(const ValueGradient& z, double iso, const QmcRule& rule) {
    SurfaceDensity out;
    Mat3d L;
    if (!condition(z, iso, out, L)) return out;
    double norms = 0;
    Mat3d outer = Mat3d::Zero();  // Σ X Xᵀ/‖X‖
    for (const Vec3d& q : rule.points()) {
        const Vec3d X = out.meanGradient + L * q;
        const double n = X.norm();
        if (!(n > 0)) continue;
        norms += n;
        outer.noalias() += (X / n) * X.transpose();
    }
    finish(norms, outer, rule, out);
    return out;
}

}  // namespace gpisvdb
