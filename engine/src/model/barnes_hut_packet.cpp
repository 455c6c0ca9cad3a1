// Barnes–Hut for a packet of nearby points (docs/model.md#packets): one traversal shared by kPacket points, every
// expansion computed for all of them at once in SIMD lanes. A point keeps exactly the nodes evaluate(x) would use
// (the same tests on the same numbers) in the same order; only the arithmetic of each term is arranged
// differently, so results agree with the reference path to rounding.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
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

/// F_1…F_4 per lane: RegularizedKernel::at's formulas, the closed forms computed in lanes.
GPISVDB_LANES_INLINE LaneKernel kernelAt(const RegularizedKernel& kernel, const Lanes& t) {
    LaneKernel F;
    bool newton = true, series = false;
    for (int l = 0; l < kLanes; ++l) {
        newton = newton && t[l] > kernel.newtonDistance2();
        series = series || t[l] < kernel.seriesDistance2();
    }
    if (series) {  // a lane within ~3s of the point: the series, one lane at a time
        for (int l = 0; l < kLanes; ++l) {
            const RadialDerivatives f = kernel.at(t[l]);
            F.F1[l] = f.F1, F.F2[l] = f.F2, F.F3[l] = f.F3, F.F4[l] = f.F4;
        }
        return F;
    }
    Lanes r;
    for (int l = 0; l < kLanes; ++l) r[l] = std::sqrt(t[l]);
    const Lanes ir = 1.0 / r, u = 1.0 / t;
    if (newton) {
        // Every lane beyond the Gaussian's reach: the pure Newton terms.
        F.F1 = -ir * u;
        F.F2 = 3.0 * ir * u * u;
        F.F3 = -15.0 * ir * u * u * u;
        F.F4 = 105.0 * ir * u * u * u * u;
        return F;
    }
    // === Closed forms: F_k = c_k erf(ar) r^-(2k+1) + g P_k(r), g = (2a/√π) exp(−a²r²) (kernel.h)
    const double a = kernel.erfScale(), a2 = a * a, a4 = a2 * a2, a6 = a4 * a2, c = kernel.gaussianFactor();
    double ar[kLanes], mt[kLanes], erfs[kLanes], exps[kLanes];
    for (int l = 0; l < kLanes; ++l) ar[l] = a * r[l], mt[l] = -a2 * t[l];
    erfExp(ar, mt, erfs, exps);
    Lanes E, g;
    for (int l = 0; l < kLanes; ++l) {
        const bool far = t[l] > kernel.newtonDistance2();  // as at(): erf = 1 and no Gaussian term there
        E[l] = far ? 1.0 : erfs[l];
        g[l] = far ? 0.0 : c * exps[l];
    }
    const Lanes Eir = E * ir, u2 = u * u, u3 = u2 * u, u4 = u3 * u;
    F.F1 = -Eir * u + g * u;
    F.F2 = 3.0 * Eir * u2 - g * (3.0 * u2 + 2.0 * a2 * u);
    F.F3 = -15.0 * Eir * u3 + g * (15.0 * u3 + 10.0 * a2 * u2 + 4.0 * a4 * u);
    F.F4 = 105.0 * Eir * u4 - g * (105.0 * u4 + 70.0 * a2 * u3 + 28.0 * a4 * u2 + 8.0 * a6 * u);
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

/// D²ρ(y) as a symmetric 3×3 per lane.
GPISVDB_LANES_INLINE void hessian(const LaneKernel& F, const LaneVec3& y, Lanes D2[3][3]) {
    for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j) {
            D2[i][j] = F.F2 * y[i] * y[j];
            if (i == j) D2[i][j] += F.F1;
            D2[j][i] = D2[i][j];
        }
}

/// (D³ρ : X)_k for a 3×3 X (as contract3 in barnes_hut_gpis.cpp).
GPISVDB_LANES_INLINE void contract3(const LaneKernel& F, const LaneVec3& y, const Mat3d& X, Lanes out[3]) {
    const double tr = X.trace();
    Lanes Xy[3], XTy[3];
    for (int i = 0; i < 3; ++i) {
        Xy[i] = X(i, 0) * y[0] + X(i, 1) * y[1] + X(i, 2) * y[2];
        XTy[i] = X(0, i) * y[0] + X(1, i) * y[1] + X(2, i) * y[2];
    }
    const Lanes yXy = y[0] * Xy[0] + y[1] * Xy[1] + y[2] * Xy[2];
    for (int k = 0; k < 3; ++k) out[k] = F.F2 * (Xy[k] + XTy[k] + tr * y[k]) + F.F3 * yXy * y[k];
}

/// (D⁴ρ : X)_jk for a 3×3 X (as contract4 in barnes_hut_gpis.cpp).
GPISVDB_LANES_INLINE void contract4(const LaneKernel& F, const LaneVec3& y, const Mat3d& X, Lanes out[3][3]) {
    const double tr = X.trace();
    const Mat3d Xs = X + X.transpose();
    Lanes z[3];
    for (int i = 0; i < 3; ++i) z[i] = Xs(i, 0) * y[0] + Xs(i, 1) * y[1] + Xs(i, 2) * y[2];
    const Lanes yXy = 0.5 * (y[0] * z[0] + y[1] * z[1] + y[2] * z[2]);
    for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) {
            out[j][k] = F.F2 * Xs(j, k) + F.F3 * (z[j] * y[k] + y[j] * z[k] + tr * y[j] * y[k]) + F.F4 * yXy * y[j] * y[k];
            if (j == k) out[j][k] += F.F2 * tr + F.F3 * yXy;
        }
}

/// Q_m = J(y, e_m) = [D²ρ e_m; D³ρ·e_m] (4×3), for m = 0, 1, 2.
GPISVDB_LANES_INLINE void qMatrices(const LaneKernel& F, const LaneVec3& y, const Lanes D2[3][3], Lanes Q[3][4][3]) {
    for (int m = 0; m < 3; ++m) {
        for (int j = 0; j < 3; ++j) Q[m][0][j] = D2[j][m];
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                Lanes v = F.F3 * y[m] * y[i] * y[j];
                if (j == m) v += F.F2 * y[i];
                if (i == m) v += F.F2 * y[j];
                if (i == j) v += F.F2 * y[m];
                Q[m][1 + i][j] = v;
            }
    }
}

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

/// The covariance's first-order far field of one node (addFarCovariance), times `on`.
GPISVDB_LANES_INLINE void farCovariance(const BarnesHutGpis::CovarianceMoments& cm, const LaneVec3& y, const LaneKernel& F, const Lanes& on,
                   LaneSums& s) {
    Lanes D2[3][3], Q[3][4][3];
    hessian(F, y, D2);
    qMatrices(F, y, D2, Q);
    // === Position noise: S = Σ_m Q_m (½ Σ_n W_mn Q_n − R_m)ᵀ, R_m = [D³ρ : B_m ; D⁴ρ : B_m]
    Lanes S[4][4];
    for (auto& row : S)
        for (auto& v : row) v = splat(0);
    for (int m = 0; m < 3; ++m) {
        Lanes A[4][3];  // ½ W Q − R
        contract3(F, y, cm.posB[m], A[0]);
        Lanes R4[3][3];
        contract4(F, y, cm.posB[m], R4);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) A[1 + i][j] = R4[i][j];
        for (int a = 0; a < 4; ++a)
            for (int j = 0; j < 3; ++j) {
                const Lanes wq = cm.posW(m, 0) * Q[0][a][j] + cm.posW(m, 1) * Q[1][a][j] + cm.posW(m, 2) * Q[2][a][j];
                A[a][j] = 0.5 * wq - A[a][j];
            }
        for (int a = 0; a < 4; ++a)
            for (int b = 0; b < 4; ++b) S[a][b] += Q[m][a][0] * A[b][0] + Q[m][a][1] * A[b][1] + Q[m][a][2] * A[b][2];
    }
    // === Normal noise: U = V Kᵀ, V = ½ K Σ' − Σ_l Q_l C_l, K = [∇ρᵀ; D²ρ]
    Lanes K[4][3];
    for (int j = 0; j < 3; ++j) K[0][j] = F.F1 * y[j];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) K[1 + i][j] = D2[i][j];
    for (int a = 0; a < 4; ++a) {
        Lanes V[3];
        for (int k = 0; k < 3; ++k) {
            Lanes v = 0.5 * (K[a][0] * cm.nrmS(0, k) + K[a][1] * cm.nrmS(1, k) + K[a][2] * cm.nrmS(2, k));
            for (int l = 0; l < 3; ++l)
                v -= Q[l][a][0] * cm.nrmC[l](0, k) + Q[l][a][1] * cm.nrmC[l](1, k) + Q[l][a][2] * cm.nrmC[l](2, k);
            V[k] = v;
        }
        for (int b = 0; b < 4; ++b) S[a][b] += V[0] * K[b][0] + V[1] * K[b][1] + V[2] * K[b][2];
    }
    for (int a = 0; a < 4; ++a)
        for (int b = a; b < 4; ++b) s.cov[a][b] += on * (S[a][b] + S[b][a]);
}

/// One sample's exact share (addMean, addPositionNoise, addNormalNoise); `mean`/`cov` select the lanes that want it.
GPISVDB_LANES_INLINE void sample(const Vec3d& w, double var, const Sym3& N, const LaneVec3& y, const LaneKernel& F, const Lanes& mean,
            const Lanes& cov, bool anyMean, bool anyCov, LaneSums& s) {
    const Lanes yw = dot(y, w);
    if (anyMean) {
        s.mean[0] += mean * (F.F1 * yw);
        for (int k = 0; k < 3; ++k) s.mean[1 + k] += mean * (F.F1 * w[k] + F.F2 * yw * y[k]);
    }
    if (!anyCov) return;
    // Position noise: var · J Jᵀ, J = [(D²ρ w)ᵀ; D³ρ·w].
    Lanes J[4][3];
    for (int j = 0; j < 3; ++j) J[0][j] = F.F1 * w[j] + F.F2 * yw * y[j];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            Lanes v = F.F2 * (y[i] * w[j] + w[i] * y[j]) + F.F3 * yw * y[i] * y[j];
            if (i == j) v += F.F2 * yw;
            J[1 + i][j] = v;
        }
    // Normal noise: K Σ' Kᵀ, K = [∇ρᵀ; D²ρ].
    Lanes K[4][3];
    for (int j = 0; j < 3; ++j) K[0][j] = F.F1 * y[j];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            K[1 + i][j] = F.F2 * y[i] * y[j];
            if (i == j) K[1 + i][j] += F.F1;
        }
    const double Sm[3][3] = {{N.xx, N.xy, N.xz}, {N.xy, N.yy, N.yz}, {N.xz, N.yz, N.zz}};
    Lanes KS[4][3];
    for (int a = 0; a < 4; ++a)
        for (int k = 0; k < 3; ++k) KS[a][k] = K[a][0] * Sm[0][k] + K[a][1] * Sm[1][k] + K[a][2] * Sm[2][k];
    for (int a = 0; a < 4; ++a)
        for (int b = a; b < 4; ++b) {
            const Lanes jj = J[a][0] * J[b][0] + J[a][1] * J[b][1] + J[a][2] * J[b][2];
            const Lanes kk = KS[a][0] * K[b][0] + KS[a][1] * K[b][1] + KS[a][2] * K[b][2];
            s.cov[a][b] += cov * (var * jj + kk);
        }
}

}  // namespace

// One clone of the traversal per instruction set, chosen once at load time (GCC function multi-versioning):
// the same binary runs everywhere and uses AVX-512 or AVX2 where the CPU has them. The lanes' own arithmetic is the
// same IEEE operations in every clone (no FMA contraction: the file is built with -ffp-contract=off); erf and exp
// come from libmvec's variant for the CPU, which may differ from another's in the last bit (as libm's scalar exp
// already does between CPUs with and without FMA).
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
            if (farCovLanes) farCovariance(covMoments_[e.node], y, F, select(farCovLanes), sums);
            e.doneMean |= farMeanLanes;
            e.doneCov |= farCovLanes;
        }
        if (e.doneMean == kAllLanes && e.doneCov == kAllLanes) continue;
        if (node.childCount == 0) {
            const LaneMask wantMean = kAllLanes & ~e.doneMean, wantCov = kAllLanes & ~e.doneCov;
            const Lanes onMean = select(wantMean), onCov = select(wantCov);
            for (std::uint32_t i = node.begin; i < node.end; ++i) {
                LaneVec3 yi;
                for (int d = 0; d < 3; ++d) yi[d] = x[d] - samples_.position[i][d];
                const LaneKernel F = kernelAt(kernel_, yi[0] * yi[0] + yi[1] * yi[1] + yi[2] * yi[2]);
                sample(samples_.normal[i], samples_.positionVariance[i], samples_.normalCovariance[i], yi, F, onMean, onCov,
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
