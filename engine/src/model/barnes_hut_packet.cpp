// Barnes–Hut for a packet of nearby points (docs/model.md#packets): one traversal shared by kPacket points, every
// expansion computed for all of them at once in SIMD lanes. A point keeps exactly the nodes evaluate(x) would use
// (the same tests on the same numbers) in the same order; only the arithmetic of each term is arranged
// differently, so results agree with the reference path to rounding.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#if defined(__x86_64__)
#include <immintrin.h>
#endif
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "contributions.h"
#include "gpisvdb/model/barnes_hut_gpis.h"

namespace gpisvdb {

namespace {

// Helpers are inlined into the traversal so that each of its clones (below) compiles them for its own instruction set.
#define GPISVDB_LANES_INLINE __attribute__((always_inline)) inline
#pragma GCC diagnostic ignored "-Wpsabi"  // Lanes never cross a call: every function taking them is inlined

constexpr int kLanes = BarnesHutGpis::kPacket;
// One double per point of the packet. GCC/Clang vector extensions: the compiler maps the 8 lanes to whatever the
// target has (4 SSE2, 2 AVX or 1 AVX-512 instruction per operation).
typedef double Lanes __attribute__((vector_size(kLanes * sizeof(double))));
using LaneMask = std::uint32_t;  // bit l: lane l
constexpr LaneMask kAllLanes = (1u << kLanes) - 1;

GPISVDB_LANES_INLINE Lanes splat(double v) {
    Lanes r;
    for (int l = 0; l < kLanes; ++l) r[l] = v;
    return r;
}

/// 1 in the lanes of `mask`, 0 elsewhere: terms are multiplied by it (every term is finite in every lane).
GPISVDB_LANES_INLINE Lanes select(LaneMask mask) {
    Lanes r;
    for (int l = 0; l < kLanes; ++l) r[l] = (mask >> l) & 1u ? 1.0 : 0.0;
    return r;
}

struct LaneVec3 {
    Lanes v[3];
    const Lanes& operator[](int i) const { return v[i]; }
    Lanes& operator[](int i) { return v[i]; }
};

GPISVDB_LANES_INLINE Lanes dot(const LaneVec3& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

struct LaneKernel {
    Lanes F1, F2, F3, F4;
};

// === erf and exp for 8 lanes at once: glibc's vector math library (libmvec), at the widest width the CPU has,
// chosen once. Elsewhere (other compilers or architectures) a plain loop over the scalar functions.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
extern "C" {
__m128d _ZGVbN2v_erf(__m128d);
__m128d _ZGVbN2v_exp(__m128d);
__m256d _ZGVdN4v_erf(__m256d);
__m256d _ZGVdN4v_exp(__m256d);
__m512d _ZGVeN8v_erf(__m512d);
__m512d _ZGVeN8v_exp(__m512d);
}

void erfExpSse(const double* x, const double* y, double* ex, double* ey) {
    for (int k = 0; k < kLanes; k += 2) {
        _mm_storeu_pd(ex + k, _ZGVbN2v_erf(_mm_loadu_pd(x + k)));
        _mm_storeu_pd(ey + k, _ZGVbN2v_exp(_mm_loadu_pd(y + k)));
    }
}
__attribute__((target("avx2"))) void erfExpAvx2(const double* x, const double* y, double* ex, double* ey) {
    for (int k = 0; k < kLanes; k += 4) {
        _mm256_storeu_pd(ex + k, _ZGVdN4v_erf(_mm256_loadu_pd(x + k)));
        _mm256_storeu_pd(ey + k, _ZGVdN4v_exp(_mm256_loadu_pd(y + k)));
    }
}
__attribute__((target("avx512f"))) void erfExpAvx512(const double* x, const double* y, double* ex, double* ey) {
    _mm512_storeu_pd(ex, _ZGVeN8v_erf(_mm512_loadu_pd(x)));
    _mm512_storeu_pd(ey, _ZGVeN8v_exp(_mm512_loadu_pd(y)));
}
using ErfExp = void (*)(const double*, const double*, double*, double*);
const ErfExp erfExp = [] {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) return ErfExp(erfExpAvx512);
    if (__builtin_cpu_supports("avx2")) return ErfExp(erfExpAvx2);
    return ErfExp(erfExpSse);
}();
#else
void erfExp(const double* x, const double* y, double* ex, double* ey) {
    for (int k = 0; k < kLanes; ++k) ex[k] = std::erf(x[k]), ey[k] = std::exp(y[k]);
}
#endif

/// F_1…F_4 per lane: RegularizedKernel::at's formulas (series, closed forms, pure Newton terms), computed in lanes.
GPISVDB_LANES_INLINE LaneKernel kernelAt(const RegularizedKernel& kernel, const Lanes& t) {
    LaneKernel F;
    bool newton = true, series = false, closed = false;
    for (int l = 0; l < kLanes; ++l) {
        newton = newton && t[l] > kernel.newtonDistance2();
        series = series || t[l] < kernel.seriesDistance2();
        closed = closed || !(t[l] < kernel.seriesDistance2());
    }
    const double a = kernel.erfScale(), a2 = a * a, a4 = a2 * a2, a6 = a4 * a2, c = kernel.gaussianFactor();
    if (closed) {
        // 1/r and 1/r² from one square root and one division (r = 0 happens only in series lanes, replaced below)
        Lanes r;
        for (int l = 0; l < kLanes; ++l) r[l] = std::sqrt(t[l]);
        const Lanes ir = 1.0 / r, u = ir * ir;
        const Lanes u2 = u * u, u3 = u2 * u, u4 = u3 * u;
        if (newton) {
            // Every lane beyond the Gaussian's reach: the pure Newton terms, rounded exactly as the closed forms
            // below round them with erf = 1 and g = 0, so that a point's result never depends on its packet-mates.
            F.F1 = -ir * u;
            F.F2 = 3.0 * ir * u2;
            F.F3 = -15.0 * ir * u3;
            F.F4 = 105.0 * ir * u4;
            return F;
        }
        // === Closed forms: F_k = c_k erf(ar) r^-(2k+1) + g P_k(r), g = (2a/√π) exp(−a²r²) (kernel.h)
        double ar[kLanes], mt[kLanes], erfs[kLanes], exps[kLanes];
        for (int l = 0; l < kLanes; ++l) ar[l] = a * r[l], mt[l] = -a2 * t[l];
        erfExp(ar, mt, erfs, exps);
        Lanes E, g;
        for (int l = 0; l < kLanes; ++l) {
            const bool far = t[l] > kernel.newtonDistance2();  // as at(): erf = 1 and no Gaussian term there
            E[l] = far ? 1.0 : erfs[l];
            g[l] = far ? 0.0 : c * exps[l];
        }
        const Lanes Eir = E * ir;
        F.F1 = -Eir * u + g * u;
        F.F2 = 3.0 * Eir * u2 - g * (3.0 * u2 + 2.0 * a2 * u);
        F.F3 = -15.0 * Eir * u3 + g * (15.0 * u3 + 10.0 * a2 * u2 + 4.0 * a4 * u);
        F.F4 = 105.0 * Eir * u4 - g * (105.0 * u4 + 70.0 * a2 * u3 + 28.0 * a4 * u2 + 8.0 * a6 * u);
    }
    if (series) {
        // === Series (a lane within ~3s of the point): F_k = c (−2a²)^k Σ_m (−a²t)^m / (m! (2m+2k+1)), in lanes
        const RegularizedKernel::Series& series = RegularizedKernel::series();
        Lanes sum[4] = {splat(0), splat(0), splat(0), splat(0)}, term = splat(1.0);
        const Lanes x = -a2 * t;
        for (int m = 0; m < RegularizedKernel::kSeriesTerms; ++m) {
            for (int k = 0; k < 4; ++k) sum[k] += term * series.inverse[m][k + 1];
            term *= x * series.next[m];
        }
        const double s1 = -2.0 * a2 * c, s2 = -2.0 * a2 * s1, s3 = -2.0 * a2 * s2, s4 = -2.0 * a2 * s3;
        for (int l = 0; l < kLanes; ++l)
            if (t[l] < kernel.seriesDistance2())
                F.F1[l] = s1 * sum[0][l], F.F2[l] = s2 * sum[1][l], F.F3[l] = s3 * sum[2][l], F.F4[l] = s4 * sum[3][l];
    }
    return F;
}

/// The symmetric 4×4 accumulators: the mean (γ, ∇γ) and the upper triangle of the covariance.
struct LaneSums {
    Lanes mean[4];
    Lanes cov[4][4];  // only a ≤ b is used
    LaneSums() {
        for (auto& m : mean) m = splat(0);
        for (auto& row : cov)
            for (auto& c : row) c = splat(0);
    }
};

/// The mean's second-order far field of one node (addFarMean), times `on`.
GPISVDB_LANES_INLINE void farMean(const BarnesHutGpis::MeanMoments& mm, const LaneVec3& y, const LaneKernel& F, const Lanes& on, LaneSums& s) {
    const Mat3d& M1 = mm.m1;
    const Vec3d& tr = mm.m2trace;
    const Vec3d& um = mm.m2mixed;
    LaneVec3 P, Q;
    for (int i = 0; i < 3; ++i) Q[i] = splat(0);
    for (int n = 0; n < 3; ++n) {
        Lanes v[3];
        for (int i = 0; i < 3; ++i) v[i] = mm.m2[n](i, 0) * y[0] + mm.m2[n](i, 1) * y[1] + mm.m2[n](i, 2) * y[2];
        P[n] = y[0] * v[0] + y[1] * v[1] + y[2] * v[2];
        for (int i = 0; i < 3; ++i) Q[i] += y[n] * v[i];
    }
    const Lanes Y3 = y[0] * P[0] + y[1] * P[1] + y[2] * P[2];
    const Lanes ty = dot(y, tr), uy = dot(y, um), yw0 = dot(y, mm.w0);
    Lanes M1y[3], M1Ty[3];
    for (int i = 0; i < 3; ++i) {
        M1y[i] = M1(i, 0) * y[0] + M1(i, 1) * y[1] + M1(i, 2) * y[2];
        M1Ty[i] = M1(0, i) * y[0] + M1(1, i) * y[1] + M1(2, i) * y[2];
    }
    const Lanes yM1y = y[0] * M1y[0] + y[1] * M1y[1] + y[2] * M1y[2];
    const double trM1 = M1.trace();
    s.mean[0] += on * (F.F1 * yw0 - (F.F1 * trM1 + F.F2 * yM1y) + 0.5 * (F.F2 * (ty + 2 * uy) + F.F3 * Y3));
    for (int k = 0; k < 3; ++k) {
        const Lanes d2w0 = F.F1 * mm.w0[k] + F.F2 * yw0 * y[k];
        const Lanes c3 = F.F2 * (M1y[k] + M1Ty[k] + trM1 * y[k]) + F.F3 * yM1y * y[k];
        const Lanes d4m2 = F.F2 * (2 * um[k] + tr[k]) + F.F3 * (2 * Q[k] + P[k] + (ty + 2 * uy) * y[k]) + F.F4 * Y3 * y[k];
        s.mean[1 + k] += on * (d2w0 - c3 + 0.5 * d4m2);
    }
}

/// v = M y and returns yᵀ M y, per lane.
GPISVDB_LANES_INLINE Lanes quadratic(const double (&M)[3][3], const LaneVec3& y, Lanes (&v)[3]) {
    for (int i = 0; i < 3; ++i) v[i] = M[i][0] * y[0] + M[i][1] * y[1] + M[i][2] * y[2];
    return y[0] * v[0] + y[1] * v[1] + y[2] * v[2];
}

/// The covariance's first-order far field of one node (addFarCovariance), times `on`, in closed form
/// (docs/model.md#packets). Both noise terms have the shape E(y; M) = coefficients(F, t) × {τ = tr M, m = yᵀMy,
/// v = My, M, y, δ}: position noise with M = W = Σ σ² w wᵀ, normal noise with M = Σ Σ'. The first order is
/// −Σ_l ∂_l E(y; M_l) with M_l = B_l = Σ σ² δ_l w wᵀ (resp. C_l = Σ δ_l Σ'); ∂_l acts on y and on F_k (∂_l F_k =
/// F_{k+1} y_l), and contracts over l into T1 = y·τ_l, T2 = y·m_l, T3 = u·y (u_j = Σ_l (M_l)_jl), Σ_l y_l M_l and
/// Σ_l y_l M_l y. About 350 lane operations instead of the ≈ 1 400 of forming Q_m, K and their products.
GPISVDB_LANES_INLINE void farCovariance(const BarnesHutGpis::CovarianceMoments& cm, const LaneVec3& y, const Lanes& t,
                                        const LaneKernel& F, const Lanes& on, LaneSums& s) {
    // Every term is quadratic in (F1…F4): masking them masks the terms.
    const Lanes a = on * F.F1, b = on * F.F2, c = on * F.F3, d = on * F.F4;
    // === The node's constants: B_l(m,n) = posB[n](l,m), C_l = nrmC[l]
    double B[3][3][3], C[3][3][3], tauB[3], uB[3], uC[3];  // (the normal noise's τ has a zero coefficient)
    for (int l = 0; l < 3; ++l)
        for (int m = 0; m < 3; ++m)
            for (int n = 0; n < 3; ++n) B[l][m][n] = cm.posB[n](l, m), C[l][m][n] = cm.nrmC[l](m, n);
    for (int l = 0; l < 3; ++l) {
        tauB[l] = B[l][0][0] + B[l][1][1] + B[l][2][2];
        uB[l] = B[0][l][0] + B[1][l][1] + B[2][l][2];
        uC[l] = C[0][l][0] + C[1][l][1] + C[2][l][2];
    }
    const double tauW = cm.posW.trace();
    // === Per lane: v = My and m = yᵀMy for W, Σ Σ', every B_l and C_l; their contractions over l
    double Wm[3][3], Sm[3][3];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Wm[i][j] = cm.posW(i, j), Sm[i][j] = cm.nrmS(i, j);
    Lanes vW[3], vS[3], vB[3][3], vC[3][3], mB[3], mC[3];
    const Lanes mW = quadratic(Wm, y, vW), mS = quadratic(Sm, y, vS);
    for (int l = 0; l < 3; ++l) mB[l] = quadratic(B[l], y, vB[l]), mC[l] = quadratic(C[l], y, vC[l]);
    const Lanes T1B = y[0] * tauB[0] + y[1] * tauB[1] + y[2] * tauB[2];
    const Lanes T2B = y[0] * mB[0] + y[1] * mB[1] + y[2] * mB[2], T2C = y[0] * mC[0] + y[1] * mC[1] + y[2] * mC[2];
    const Lanes T3B = y[0] * uB[0] + y[1] * uB[1] + y[2] * uB[2], T3C = y[0] * uC[0] + y[1] * uC[1] + y[2] * uC[2];
    Lanes VyB[3], VyC[3];  // Σ_l y_l M_l y
    for (int i = 0; i < 3; ++i)
        VyB[i] = y[0] * vB[0][i] + y[1] * vB[1][i] + y[2] * vB[2][i], VyC[i] = y[0] * vC[0][i] + y[1] * vC[1][i] + y[2] * vC[2][i];
    // === Coefficients of E (pos: position noise, nrm: normal noise) and of their derivatives ∂/∂t·2
    const Lanes aa = a * a, ab = a * b, bb = b * b, ac = a * c, bc = b * c, bt = b * t, ct = c * t, dt = d * t;
    const Lanes alpha2 = 2.0 * ab + bb * t;           // pos (0,0) · m
    const Lanes beta2 = 2.0 * bb + c * (a + bt);      // pos (0,i) · m y_i
    const Lanes beta3 = b * (2.0 * a + bt);           // pos (0,i) · v_i
    const Lanes gamma2 = c * (4.0 * b + ct);          // pos (i,j) · m y_i y_j
    const Lanes gamma3 = b * (3.0 * b + ct);          // pos (i,j) · (y_i v_j + v_i y_j)
    const Lanes dA2 = 4.0 * bb + 2.0 * ac + 2.0 * b * ct;  // = d beta3
    const Lanes dB1 = bb + ac;                        // = d(ab)
    const Lanes dB2 = 7.0 * bc + a * d + c * ct + b * dt;
    const Lanes dG1 = 2.0 * bc;                       // = d(b²)
    const Lanes dG2 = 6.0 * c * c + 4.0 * b * d + 2.0 * c * dt;
    const Lanes dG3 = 8.0 * bc + c * ct + b * dt;
    const Lanes dG4 = 2.0 * b * ct + 2.0 * bb;        // = d(b² t)
    // === Row 0
    s.cov[0][0] += aa * tauW + alpha2 * mW + aa * mS -
                   (2.0 * ab * T1B + dA2 * T2B + 2.0 * alpha2 * T3B + 2.0 * ab * T2C + 2.0 * aa * T3C);
    const Lanes cy = ab * tauW + beta2 * mW + ab * mS - (dB1 * T1B + dB2 * T2B + 2.0 * beta2 * T3B + dB1 * T2C + 2.0 * ab * T3C);
    for (int i = 0; i < 3; ++i)
        s.cov[0][1 + i] += cy * y[i] + beta3 * vW[i] + aa * vS[i] -
                           (ab * tauB[i] + beta2 * mB[i] + dA2 * VyB[i] + beta3 * uB[i] + ab * mC[i] + 2.0 * ab * VyC[i] + aa * uC[i]);
    // === Gradient block: cYY y_i y_j + (y_i R_j + R_i y_j) + matrix terms + δ_ij cD
    const Lanes cYY = bb * tauW + gamma2 * mW + bb * mS - (dG1 * T1B + dG2 * T2B + 2.0 * gamma2 * T3B + dG1 * T2C + 2.0 * bb * T3C);
    Lanes R[3];
    for (int i = 0; i < 3; ++i)
        R[i] = gamma3 * vW[i] + ab * vS[i] -
               (bb * tauB[i] + gamma2 * mB[i] + bb * mC[i] + dG3 * VyB[i] + gamma3 * uB[i] + dB1 * VyC[i] + ab * uC[i]);
    const Lanes cD = bb * mW - (dG1 * T2B + 2.0 * bb * T3B);
    const Lanes btt = bb * t, ab2 = 2.0 * ab;
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j) {
            Lanes myB = y[0] * B[0][i][j] + y[1] * B[1][i][j] + y[2] * B[2][i][j];
            Lanes myC = y[0] * C[0][i][j] + y[1] * C[1][i][j] + y[2] * C[2][i][j];
            Lanes v = cYY * y[i] * y[j] + y[i] * R[j] + R[i] * y[j] + btt * Wm[i][j] + aa * Sm[i][j] -
                      gamma3 * (vB[i][j] + vB[j][i]) - ab * (vC[i][j] + vC[j][i]) - dG4 * myB - ab2 * myC;
            if (i == j) v += cD;
            s.cov[1 + i][1 + j] += v;
        }
}

/// One sample's exact share (addMean, addPositionNoise, addNormalNoise); `mean`/`cov` select the lanes that want it.
/// The 4×4 covariance is written out in closed form (docs/model.md#packets): with p = y·w, q = Σ'y, Q = y·q,
///   var·J Jᵀ + K Σ' Kᵀ = coefficients (scalars per lane) times y, w, q and Σ' entries,
/// about 150 lane operations instead of the ≈ 340 of forming J and K and multiplying them out.
GPISVDB_LANES_INLINE void sample(const Vec3d& w, double var, const Sym3& N, const LaneVec3& y, const Lanes& t, const LaneKernel& F,
                                 const Lanes& mean, const Lanes& cov, bool anyMean, bool anyCov, LaneSums& s) {
    const Lanes p = dot(y, w);
    if (anyMean) {  // (∇ρ·w, D²ρ w) = (F1 p, F1 w + F2 p y)
        const Lanes a = mean * F.F1, bp = mean * F.F2 * p;
        s.mean[0] += a * p;
        for (int k = 0; k < 3; ++k) s.mean[1 + k] += a * w[k] + bp * y[k];
    }
    if (!anyCov) return;
    // Every covariance term is quadratic in (F1, F2, F3): masking them masks the terms.
    const Lanes a = cov * F.F1, b = cov * F.F2, c = cov * F.F3;
    const double Sm[3][3] = {{N.xx, N.xy, N.xz}, {N.xy, N.yy, N.yz}, {N.xz, N.yz, N.zz}};
    Lanes q[3];
    for (int i = 0; i < 3; ++i) q[i] = Sm[i][0] * y[0] + Sm[i][1] * y[1] + Sm[i][2] * y[2];
    const Lanes Q = y[0] * q[0] + y[1] * q[1] + y[2] * q[2];
    const double ww = w.squaredNorm();
    const Lanes p2 = p * p, aa = a * a, ab = a * b, bb = b * b, bt = b * t, vbp = var * b * p;
    // === Row 0: (0,0) = var (a² ww + p² (2ab + b² t)) + a² Q; (0,i) = αy y_i + αw w_i + a² q_i
    s.cov[0][0] += var * (aa * ww + p2 * (2.0 * ab + bb * t)) + aa * Q;
    const Lanes alphaY = var * (ab * ww + p2 * (2.0 * bb + c * (a + bt))) + ab * Q;
    const Lanes alphaW = vbp * (2.0 * a + bt);
    for (int i = 0; i < 3; ++i) s.cov[0][1 + i] += alphaY * y[i] + alphaW * w[i] + aa * q[i];
    // === Gradient block: (i,j) = βyy y_i y_j + βyw (y_i w_j + w_i y_j) + βww w_i w_j + ab (y_i q_j + q_i y_j)
    //                              + a² Σ'_ij + δ_ij var b² p²
    const Lanes betaYY = var * (bb * ww + p2 * c * (4.0 * b + c * t)) + bb * Q;
    const Lanes betaYW = vbp * (3.0 * b + c * t);
    const Lanes betaWW = var * bb * t;
    const Lanes betaD = var * bb * p2;
    for (int i = 0; i < 3; ++i) {
        const Lanes A = betaYY * y[i] + betaYW * w[i] + ab * q[i];
        const Lanes B = betaYW * y[i] + betaWW * w[i];
        const Lanes C = ab * y[i];
        for (int j = i; j < 3; ++j) {
            Lanes v = A * y[j] + B * w[j] + C * q[j] + aa * Sm[i][j];
            if (i == j) v += betaD;
            s.cov[1 + i][1 + j] += v;
        }
    }
}


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
    return __builtin_shufflevector(first, second, k, k, k, k, k, k, k, k, 16 + k, 16 + k, 16 + k, 16 + k, 16 + k, 16 + k,
                                   16 + k, 16 + k);
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
GPISVDB_LANES_INLINE void samplePair(const PairLanes& first, const PairLanes& second, const PairVec3& y,
                                     const PairLanes& t, const PairKernel& F, const PairLanes& mean, const PairLanes& cov,
                                     bool anyMean, bool anyCov, PairSums& s) {
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
/// gradient block ×1/s²).
GPISVDB_LANES_INLINE void nearField(const NearKernel& kernel, const std::vector<Vec3d>& position,
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
            y[d] = __builtin_shufflevector(__builtin_convertvector(yi, HalfLanes), __builtin_convertvector(yj, HalfLanes), 0, 1,
                                           2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
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

// One clone of the traversal per instruction set, chosen once at load time (GCC function multi-versioning):
// the same binary runs everywhere and uses AVX-512 or AVX2 where the CPU has them. The AVX-512 and AVX2 clones
// contract multiply-adds into FMA (≈ 9 % faster) and erf and exp come from libmvec's variant for the CPU, so results
// may differ between CPUs in the last bits (as libm's scalar exp already does between CPUs with and without FMA);
// on one CPU they never depend on the thread count.
#ifdef GPISVDB_PACKET_CLONES
// defined by the build (empty: one clone, for comparisons)
#elif defined(__SANITIZE_THREAD__)
// ThreadSanitizer instruments the clones' ifunc resolver, which the loader runs before the sanitizer's runtime is
// set up (the executable crashed at load): one clone there (the same code, at the baseline instruction set).
#define GPISVDB_PACKET_CLONES
#elif defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define GPISVDB_PACKET_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define GPISVDB_PACKET_CLONES
#endif

/// The packet traversal, on plain arrays: x[d][l] coordinate d of lane l; out: mean[4][kLanes], cov[4][4][kLanes]
/// (upper triangle), unnormalised.
struct PacketTraversal {
    GPISVDB_PACKET_CLONES static void run(const BarnesHutGpis& bh, const double (*xs)[kLanes], double (*meanOut)[kLanes],
                                          double (*covOut)[4][kLanes]);
};

void PacketTraversal::run(const BarnesHutGpis& bh, const double (*xs)[kLanes], double (*meanOut)[kLanes],
                          double (*covOut)[4][kLanes]) {
    const auto& nodes_ = bh.nodes_;
    const auto& meanMoments_ = bh.meanMoments_;
    const auto& covMoments_ = bh.covMoments_;
    const auto& samples_ = bh.samples_;
    const auto& kernel_ = bh.kernel_;
    const auto& options_ = bh.options_;
    LaneVec3 x;
    for (int d = 0; d < 3; ++d)
        for (int l = 0; l < kLanes; ++l) x[d][l] = xs[d][l];

    const NearKernel near = nearKernel(kernel_);
    LaneSums sums;
    // Stack entries: node, and per part (mean, covariance) the lanes an ancestor already summed.
    struct Entry {
        std::uint32_t node;
        LaneMask doneMean, doneCov;
    };
    std::array<Entry, 8 * BarnesHutGpis::kMaxDepth + 8> stack;
    int top = 0;
    stack[top++] = {0u, 0u, 0u};
    const double betaMean2 = options_.beta * options_.beta;
    const double covBeta2 = 4.0 * options_.beta * options_.beta, relaxFrom = options_.covarianceRelax * kernel_.smoothing();
    const double relaxFrom2 = relaxFrom * relaxFrom, relaxNumerator = covBeta2 * relaxFrom;
    while (top > 0) {
        Entry e = stack[--top];
        const BarnesHutGpis::Node& node = nodes_[e.node];
        LaneVec3 y;
        for (int d = 0; d < 3; ++d) y[d] = x[d] - node.centre[d];
        const Lanes d2 = y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
        const double r2 = node.radius * node.radius;
        // === The opening tests, per lane, exactly as evaluate(x) (covarianceBeta2's formula, in lanes)
        Lanes root, cb2;
        for (int l = 0; l < kLanes; ++l) root[l] = std::sqrt(d2[l]);
        const Lanes relaxed = relaxNumerator / root;
        for (int l = 0; l < kLanes; ++l) cb2[l] = d2[l] <= relaxFrom2 ? covBeta2 : std::max(4.0, relaxed[l]);
        LaneMask farMeanLanes = 0, farCovLanes = 0;
        for (int l = 0; l < kLanes; ++l) {
            const LaneMask bit = 1u << l;
            if (!(e.doneMean & bit) && d2[l] > betaMean2 * r2) farMeanLanes |= bit;
            if (!(e.doneCov & bit) && d2[l] > cb2[l] * r2) farCovLanes |= bit;
        }
        if (farMeanLanes | farCovLanes) {
            const LaneKernel F = kernelAt(kernel_, d2);
            if (farMeanLanes) farMean(meanMoments_[e.node], y, F, select(farMeanLanes), sums);
            if (farCovLanes) farCovariance(covMoments_[e.node], y, d2, F, select(farCovLanes), sums);
            e.doneMean |= farMeanLanes;
            e.doneCov |= farCovLanes;
        }
        if (e.doneMean == kAllLanes && e.doneCov == kAllLanes) continue;
        if (node.childCount == 0) {
            const LaneMask wantMean = kAllLanes & ~e.doneMean, wantCov = kAllLanes & ~e.doneCov;
            if (options_.floatNearField) {
                nearField(near, samples_.position, bh.nearSamples_.data(), node.begin, node.end, x, wantMean, wantCov, sums);
                continue;
            }
            const Lanes onMean = select(wantMean), onCov = select(wantCov);
            for (std::uint32_t i = node.begin; i < node.end; ++i) {
                LaneVec3 yi;
                for (int d = 0; d < 3; ++d) yi[d] = x[d] - samples_.position[i][d];
                const Lanes ti = yi[0] * yi[0] + yi[1] * yi[1] + yi[2] * yi[2];
                const LaneKernel F = kernelAt(kernel_, ti);
                sample(samples_.normal[i], samples_.positionVariance[i], samples_.normalCovariance[i], yi, ti, F, onMean, onCov,
                       wantMean != 0, wantCov != 0, sums);
            }
            continue;
        }
        for (int c = node.childCount - 1; c >= 0; --c)
            stack[top++] = {node.firstChild + std::uint32_t(c), e.doneMean, e.doneCov};
    }
    for (int a = 0; a < 4; ++a)
        for (int l = 0; l < kLanes; ++l) {
            meanOut[a][l] = sums.mean[a][l];
            for (int b = a; b < 4; ++b) covOut[a][b][l] = sums.cov[a][b][l];
        }
}

void BarnesHutGpis::evaluatePacket(const Vec3d* xs, int count, ValueGradient* out) const {
    if (count < 1 || count > kLanes) throw Error("BarnesHutGpis::evaluatePacket: 1 to kPacket points");
    double x[3][kLanes], mean[4][kLanes], cov[4][4][kLanes];
    for (int l = 0; l < kLanes; ++l)
        for (int d = 0; d < 3; ++d) x[d][l] = xs[std::min(l, count - 1)][d];  // spare lanes repeat the last point
    PacketTraversal::run(*this, x, mean, cov);
    for (int l = 0; l < count; ++l) {
        ValueGradient& o = out[l];
        for (int a = 0; a < 4; ++a) {
            o.mean[a] = mean[a][l];
            for (int b = a; b < 4; ++b) o.cov(a, b) = o.cov(b, a) = cov[a][b][l];
        }
        detail::finish(o);
    }
}

namespace {

/// Interleaves the bits of three 21-bit integers: nearby points get nearby keys.
std::uint64_t morton(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
    auto spread = [](std::uint64_t v) {
        v &= 0x1fffff;
        v = (v | v << 32) & 0x1f00000000ffffULL;
        v = (v | v << 16) & 0x1f0000ff0000ffULL;
        v = (v | v << 8) & 0x100f00f00f00f00fULL;
        v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
        v = (v | v << 2) & 0x1249249249249249ULL;
        return v;
    };
    return spread(a) | spread(b) << 1 | spread(c) << 2;
}

}  // namespace

std::vector<ValueGradient> BarnesHutGpis::evaluate(const std::vector<Vec3d>& xs, const Progress& progress) const {
    std::vector<ValueGradient> out(xs.size());
    if (xs.empty()) return out;
    // === Order the points along a Morton curve so that a packet holds neighbours (they open the same nodes)
    Vec3d lo = xs[0], hi = xs[0];
    for (const Vec3d& p : xs) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const double extent = std::max((hi - lo).maxCoeff(), 1e-300);
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(xs.size());
    tbb::parallel_for(std::size_t(0), xs.size(), [&](std::size_t i) {
        const Vec3d q = ((xs[i] - lo) / extent * double(0x1fffff)).cwiseMax(0.0);
        keyed[i] = {morton(std::uint64_t(q.x()), std::uint64_t(q.y()), std::uint64_t(q.z())), std::uint32_t(i)};
    });
    std::sort(keyed.begin(), keyed.end());
    // === Packets, in parallel; a packet's results depend only on its points
    const std::size_t packets = (xs.size() + kLanes - 1) / kLanes;
    constexpr std::size_t kBlock = 1024;  // packets between progress reports
    for (std::size_t b = 0; b < packets; b += kBlock) {
        progress.checkInterrupt();
        progress.update("evaluate", double(b) / double(packets));
        const std::size_t e = std::min(packets, b + kBlock);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(b, e, 2), [&](const tbb::blocked_range<std::size_t>& r) {
            for (std::size_t k = r.begin(); k != r.end(); ++k) {
                progress.checkInterruptAt(k, 32);
                const std::size_t first = k * kLanes;
                const int count = int(std::min<std::size_t>(kLanes, xs.size() - first));
                Vec3d pts[kLanes];
                ValueGradient res[kLanes];
                for (int l = 0; l < count; ++l) pts[l] = xs[keyed[first + std::size_t(l)].second];
                evaluatePacket(pts, count, res);
                for (int l = 0; l < count; ++l) out[keyed[first + std::size_t(l)].second] = res[l];
            }
        });
    }
    progress.update("evaluate", 1.0);
    return out;
}

}  // namespace gpisvdb
