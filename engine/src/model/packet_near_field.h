#pragma once
// The packets' near field in float lanes (docs/model.md#near-float): a leaf's samples summed exactly, two samples ×
// the packet's points per instruction, in units of the smoothing s. An implementation header of
// barnes_hut_packet.cpp, its only includer (see packet_lanes.h).
#include <algorithm>
#include <cstring>
#include <vector>

#include "packet_lanes.h"

namespace gpisvdb {

namespace {

// === The near field in float: two samples × the packet's points in one instruction (docs/model.md#packets)
// A leaf's samples are summed exactly, and they dominate the cost (≈ 1 000 per packet against ≈ 360 far nodes). In
// units of the smoothing s (ŷ = y/s, ŵ = w/s², …) every quantity is of order one, so float holds them at any
// scale of the input; a leaf's terms are summed in float (≤ 16 per lane), then added to the double sums.
constexpr int kPairLanes = 2 * kLanes;
static_assert(sizeof(BarnesHutGpis::NearSample) == 10 * sizeof(float), "a record is the 10 floats field<k> reads");
typedef float PairLanes __attribute__((vector_size(kPairLanes * sizeof(float))));
typedef float HalfLanes __attribute__((vector_size(kLanes * sizeof(float))));

GPISVDB_LANES_INLINE PairLanes pairSplat(float v) {
    PairLanes r;
    for (int l = 0; l < kPairLanes; ++l) r[l] = v;
    return r;
}

/// Two samples' records (BarnesHutGpis::NearSample, 10 floats, loaded 16 at a time): field k of the first in lanes
/// 0…7, of the second in 8…15, in one permutation (building it lane by lane cost 18 % of the traversal, measured).
template <int k>
GPISVDB_LANES_INLINE PairLanes field(const PairLanes& first, const PairLanes& second) {
    return __builtin_shufflevector(first, second, k, k, k, k, k, k, k, k, 16 + k, 16 + k, 16 + k, 16 + k, 16 + k, 16 + k, 16 + k, 16 + k);
}

/// The smallest and largest lane, by halving (a reduction the compiler would not reorder on its own).
GPISVDB_LANES_INLINE PairLanes lanewiseMin(const PairLanes& a, const PairLanes& b) { return a < b ? a : b; }
GPISVDB_LANES_INLINE PairLanes lanewiseMax(const PairLanes& a, const PairLanes& b) { return a > b ? a : b; }
GPISVDB_LANES_INLINE void range(const PairLanes& v, float& lo, float& hi) {
    PairLanes mn = lanewiseMin(v, __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7));
    PairLanes mx = lanewiseMax(v, __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7));
    mn = lanewiseMin(mn, __builtin_shufflevector(mn, mn, 4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11));
    mx = lanewiseMax(mx, __builtin_shufflevector(mx, mx, 4, 5, 6, 7, 0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11));
    mn = lanewiseMin(mn, __builtin_shufflevector(mn, mn, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13));
    mx = lanewiseMax(mx, __builtin_shufflevector(mx, mx, 2, 3, 0, 1, 6, 7, 4, 5, 10, 11, 8, 9, 14, 15, 12, 13));
    lo = std::min(mn[0], mn[1]);
    hi = std::max(mx[0], mx[1]);
}

/// The two halves of p added, in double.
GPISVDB_LANES_INLINE Lanes halvesSum(const PairLanes& p) {
    const HalfLanes lo = __builtin_shufflevector(p, p, 0, 1, 2, 3, 4, 5, 6, 7);
    const HalfLanes hi = __builtin_shufflevector(p, p, 8, 9, 10, 11, 12, 13, 14, 15);
    return __builtin_convertvector(lo, Lanes) + __builtin_convertvector(hi, Lanes);
}

struct PairVec3 {
    PairLanes v[3];
    const PairLanes& operator[](int i) const { return v[i]; }
    PairLanes& operator[](int i) { return v[i]; }
};

struct PairKernel {
    PairLanes F1, F2, F3, F4;
};

// erf and exp for 16 floats: libmvec's float variants at the CPU's width, as erfExp above.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
extern "C" {
__m128 _ZGVbN4v_erff(__m128);
__m128 _ZGVbN4v_expf(__m128);
__m256 _ZGVdN8v_erff(__m256);
__m256 _ZGVdN8v_expf(__m256);
__m512 _ZGVeN16v_erff(__m512);
__m512 _ZGVeN16v_expf(__m512);
}

void erfExpFloatSse(const float* x, const float* y, float* ex, float* ey) {
    for (int k = 0; k < kPairLanes; k += 4) {
        _mm_storeu_ps(ex + k, _ZGVbN4v_erff(_mm_loadu_ps(x + k)));
        _mm_storeu_ps(ey + k, _ZGVbN4v_expf(_mm_loadu_ps(y + k)));
    }
}
__attribute__((target("avx2"))) void erfExpFloatAvx2(const float* x, const float* y, float* ex, float* ey) {
    for (int k = 0; k < kPairLanes; k += 8) {
        _mm256_storeu_ps(ex + k, _ZGVdN8v_erff(_mm256_loadu_ps(x + k)));
        _mm256_storeu_ps(ey + k, _ZGVdN8v_expf(_mm256_loadu_ps(y + k)));
    }
}
__attribute__((target("avx512f"))) void erfExpFloatAvx512(const float* x, const float* y, float* ex, float* ey) {
    _mm512_storeu_ps(ex, _ZGVeN16v_erff(_mm512_loadu_ps(x)));
    _mm512_storeu_ps(ey, _ZGVeN16v_expf(_mm512_loadu_ps(y)));
}
using ErfExpFloat = void (*)(const float*, const float*, float*, float*);
const ErfExpFloat erfExpFloat = [] {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) return ErfExpFloat(erfExpFloatAvx512);
    if (__builtin_cpu_supports("avx2")) return ErfExpFloat(erfExpFloatAvx2);
    return ErfExpFloat(erfExpFloatSse);
}();
#else
void erfExpFloat(const float* x, const float* y, float* ex, float* ey) {
    for (int k = 0; k < kPairLanes; ++k) ex[k] = std::erf(x[k]), ey[k] = std::exp(y[k]);
}
#endif

/// The kernel in units of s (a = 1/√2) for float lanes. The series stops at a·r = 1.6, not 2 as in double: in float
/// its cancellation costs more there than the closed forms' (both ≤ 2e-6 relative at the switch, measured against
/// 40-digit values; ≤ 1.5e-5 for F4 at a·r = 2), and 16 terms reach float's rounding (the first one left out is at
/// most 2.56^16/(16!·35) ≈ 5e-9).
constexpr float kPairSwitchAR = 1.6f;
/// |ŷ| beyond which a lane is clamped: t̂ = 3e18 and every F̂_k and term stay finite in float (an exact leaf is
/// within a few dozen s of the lanes that want it).
constexpr double kFloatReach = 1e9;
constexpr int kPairSeriesTerms = 16;
struct PairSeries {
    float inverse[kPairSeriesTerms][4];  ///< 1/(2m + 2k + 3), for F_{k+1}
    float next[kPairSeriesTerms];        ///< 1/(m + 1)
};
constexpr PairSeries makePairSeries() {
    PairSeries s{};
    for (int m = 0; m < kPairSeriesTerms; ++m) {
        for (int k = 0; k < 4; ++k) s.inverse[m][k] = 1.0f / float(2 * m + 2 * k + 3);
        s.next[m] = 1.0f / float(m + 1);
    }
    return s;
}
constexpr PairSeries kPairSeries = makePairSeries();

struct NearKernel {
    float a, a2, c;          ///< erf's scale 1/√2, its square, and the Gaussian's factor 2a/√π, in units of s
    float series2, newton2;  ///< r̂² below which the series is summed, beyond which erf = 1 and exp = 0
    double inverseS;         ///< 1/s, world units⁻¹
};

NearKernel nearKernel(const RegularizedKernel& kernel) {
    const double s = kernel.smoothing(), a = kernel.erfScale() * s;
    NearKernel k;
    k.a = float(a);
    k.a2 = float(a * a);
    k.c = float(kernel.gaussianFactor() * s);
    k.series2 = float((kPairSwitchAR / a) * (kPairSwitchAR / a));
    k.newton2 = float(kernel.newtonDistance2() / (s * s));
    k.inverseS = 1.0 / s;
    return k;
}

/// F̂_1…F̂_4 per float lane (F_k = s^−(2k+1) F̂_k): kernelAt's structure, the same rule per lane (a lane's value never
/// depends on the others').
GPISVDB_LANES_INLINE PairKernel kernelAtPair(const NearKernel& kernel, const PairLanes& t) {
    PairKernel F{};
    float tMin, tMax;  // t is never NaN: a sum of squares of finite differences
    range(t, tMin, tMax);
    const bool newton = tMin > kernel.newton2, series = tMin < kernel.series2, closed = !(tMax < kernel.series2);
    const float a2 = kernel.a2, a4 = a2 * a2, a6 = a4 * a2;
    if (closed) {
        PairLanes r;
        for (int l = 0; l < kPairLanes; ++l) r[l] = std::sqrt(t[l]);
        const PairLanes ir = 1.0f / r, u = ir * ir;
        const PairLanes u2 = u * u, u3 = u2 * u, u4 = u3 * u;
        if (newton) {
            F.F1 = -ir * u;
            F.F2 = 3.0f * ir * u2;
            F.F3 = -15.0f * ir * u3;
            F.F4 = 105.0f * ir * u4;
            return F;
        }
        float ar[kPairLanes], mt[kPairLanes], erfs[kPairLanes], exps[kPairLanes];
        for (int l = 0; l < kPairLanes; ++l) ar[l] = kernel.a * r[l], mt[l] = -a2 * t[l];
        erfExpFloat(ar, mt, erfs, exps);
        PairLanes erfLanes, expLanes;
        std::memcpy(&erfLanes, erfs, sizeof erfLanes);
        std::memcpy(&expLanes, exps, sizeof expLanes);
        const auto far = t > kernel.newton2;
        const PairLanes E = far ? pairSplat(1.0f) : erfLanes;
        const PairLanes g = far ? pairSplat(0.0f) : kernel.c * expLanes;
        const PairLanes Eir = E * ir;
        F.F1 = -Eir * u + g * u;
        F.F2 = 3.0f * Eir * u2 - g * (3.0f * u2 + 2.0f * a2 * u);
        F.F3 = -15.0f * Eir * u3 + g * (15.0f * u3 + 10.0f * a2 * u2 + 4.0f * a4 * u);
        F.F4 = 105.0f * Eir * u4 - g * (105.0f * u4 + 70.0f * a2 * u3 + 28.0f * a4 * u2 + 8.0f * a6 * u);
    }
    if (series) {
        PairLanes sum[4] = {pairSplat(0), pairSplat(0), pairSplat(0), pairSplat(0)}, term = pairSplat(1.0f);
        const PairLanes x = -a2 * t;
        for (int m = 0; m < kPairSeriesTerms; ++m) {
            for (int k = 0; k < 4; ++k) sum[k] += term * kPairSeries.inverse[m][k];
            term *= x * kPairSeries.next[m];
        }
        const float s1 = -2.0f * a2 * kernel.c, s2 = -2.0f * a2 * s1, s3 = -2.0f * a2 * s2, s4 = -2.0f * a2 * s3;
        const auto near = t < kernel.series2;
        F.F1 = near ? s1 * sum[0] : F.F1;
        F.F2 = near ? s2 * sum[1] : F.F2;
        F.F3 = near ? s3 * sum[2] : F.F3;
        F.F4 = near ? s4 * sum[3] : F.F4;
    }
    return F;
}

/// A leaf's sums in float, in units of s: the mean and the covariance's upper triangle.
struct PairSums {
    PairLanes mean[4];
    PairLanes cov[4][4];
};

/// Two samples' exact shares (sample(), in float lanes, units of s): lanes 0…7 sample i, 8…15 sample j, whose
/// records are loaded in `first` and `second`.
GPISVDB_LANES_INLINE void samplePair(const PairLanes& first, const PairLanes& second, const PairVec3& y, const PairLanes& t,
                                     const PairKernel& F, const PairLanes& mean, const PairLanes& cov, bool anyMean, bool anyCov,
                                     PairSums& s) {
    const PairLanes w[3] = {field<0>(first, second), field<1>(first, second), field<2>(first, second)};
    const PairLanes p = y[0] * w[0] + y[1] * w[1] + y[2] * w[2];
    if (anyMean) {
        const PairLanes a = mean * F.F1, bp = mean * F.F2 * p;
        s.mean[0] += a * p;
        for (int k = 0; k < 3; ++k) s.mean[1 + k] += a * w[k] + bp * y[k];
    }
    if (!anyCov) return;
    const PairLanes a = cov * F.F1, b = cov * F.F2, c = cov * F.F3;
    const PairLanes var = field<3>(first, second);
    // Σ' in units of s⁴: xx, xy, xz, yy, yz, zz
    const PairLanes N[6] = {field<4>(first, second), field<5>(first, second), field<6>(first, second),
                            field<7>(first, second), field<8>(first, second), field<9>(first, second)};
    const PairLanes Sm[3][3] = {{N[0], N[1], N[2]}, {N[1], N[3], N[4]}, {N[2], N[4], N[5]}};
    PairLanes q[3];
    for (int i = 0; i < 3; ++i) q[i] = Sm[i][0] * y[0] + Sm[i][1] * y[1] + Sm[i][2] * y[2];
    const PairLanes Q = y[0] * q[0] + y[1] * q[1] + y[2] * q[2];
    const PairLanes ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    const PairLanes p2 = p * p, aa = a * a, ab = a * b, bb = b * b, bt = b * t, vbp = var * b * p;
    s.cov[0][0] += var * (aa * ww + p2 * (2.0f * ab + bb * t)) + aa * Q;
    const PairLanes alphaY = var * (ab * ww + p2 * (2.0f * bb + c * (a + bt))) + ab * Q;
    const PairLanes alphaW = vbp * (2.0f * a + bt);
    for (int i = 0; i < 3; ++i) s.cov[0][1 + i] += alphaY * y[i] + alphaW * w[i] + aa * q[i];
    const PairLanes betaYY = var * (bb * ww + p2 * c * (4.0f * b + c * t)) + bb * Q;
    const PairLanes betaYW = vbp * (3.0f * b + c * t);
    const PairLanes betaWW = var * bb * t;
    const PairLanes betaD = var * bb * p2;
    for (int i = 0; i < 3; ++i) {
        const PairLanes A = betaYY * y[i] + betaYW * w[i] + ab * q[i];
        const PairLanes B = betaYW * y[i] + betaWW * w[i];
        const PairLanes C = ab * y[i];
        for (int j = i; j < 3; ++j) {
            PairLanes v = A * y[j] + B * w[j] + C * q[j] + aa * Sm[i][j];
            if (i == j) v += betaD;
            s.cov[1 + i][1 + j] += v;
        }
    }
}

/// A leaf's samples [begin, end), summed exactly for the lanes of wantMean / wantCov, in float two samples at a
/// time; added to the double sums in world units (the mean's gradient and the covariance's gradient row ×1/s, its
/// gradient block ×1/s²). Out of line, with clones of its own, so that a profile shows the near field apart from the
/// traversal (docs/benchmarks.md#near-field-floor); the band is no slower for it (measured there).
__attribute__((noinline)) GPISVDB_SIMD_CLONES void nearField(const NearKernel& kernel, const std::vector<Vec3d>& position,
                                                             const BarnesHutGpis::NearSample* near, std::uint32_t begin, std::uint32_t end,
                                                             const LaneVec3& x, LaneMask wantMean, LaneMask wantCov, LaneSums& sums) {
    PairSums ps;
    for (auto& m : ps.mean) m = pairSplat(0);
    for (auto& row : ps.cov)
        for (auto& c : row) c = pairSplat(0);
    const bool anyMean = wantMean != 0, anyCov = wantCov != 0;
    PairLanes onMean, onCov;
    for (int l = 0; l < kLanes; ++l) {
        onMean[l] = onMean[kLanes + l] = (wantMean >> l) & 1u ? 1.0f : 0.0f;
        onCov[l] = onCov[kLanes + l] = (wantCov >> l) & 1u ? 1.0f : 0.0f;
    }
    for (std::uint32_t i = begin; i < end; i += 2) {
        // An odd leaf's last sample pairs with itself, its second copy masked off.
        const bool two = i + 1 < end;
        const std::uint32_t j = two ? i + 1 : i;
        PairVec3 y;
        for (int d = 0; d < 3; ++d) {
            // Clamped where float would overflow: only a lane this leaf is far from gets there (masked off), and its
            // terms must stay finite so that 0 × term is 0, not NaN in a packet-mate's sum
            Lanes yi = (x[d] - position[i][d]) * kernel.inverseS, yj = (x[d] - position[j][d]) * kernel.inverseS;
            yi = yi > kFloatReach ? kFloatReach : yi < -kFloatReach ? -kFloatReach : yi;
            yj = yj > kFloatReach ? kFloatReach : yj < -kFloatReach ? -kFloatReach : yj;
            y[d] = __builtin_shufflevector(__builtin_convertvector(yi, HalfLanes), __builtin_convertvector(yj, HalfLanes), 0, 1, 2, 3, 4, 5,
                                           6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        }
        const PairLanes t = y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
        const PairKernel F = kernelAtPair(kernel, t);
        PairLanes keep = pairSplat(1.0f), first, second;
        if (!two)
            for (int l = kLanes; l < kPairLanes; ++l) keep[l] = 0.0f;
        std::memcpy(&first, &near[i], sizeof first);  // the record and the next's first 6 floats (padded at the end)
        std::memcpy(&second, &near[j], sizeof second);
        samplePair(first, second, y, t, F, onMean * keep, onCov * keep, anyMean, anyCov, ps);
    }
    const double is = kernel.inverseS, is2 = is * is;
    if (anyMean) {
        sums.mean[0] += halvesSum(ps.mean[0]);
        for (int k = 1; k < 4; ++k) sums.mean[k] += is * halvesSum(ps.mean[k]);
    }
    if (anyCov) {
        sums.cov[0][0] += halvesSum(ps.cov[0][0]);
        for (int k = 1; k < 4; ++k) sums.cov[0][k] += is * halvesSum(ps.cov[0][k]);
        for (int i = 1; i < 4; ++i)
            for (int j = i; j < 4; ++j) sums.cov[i][j] += is2 * halvesSum(ps.cov[i][j]);
    }
}

}  // namespace

}  // namespace gpisvdb
