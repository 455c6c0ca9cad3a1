// Barnes–Hut for a packet of nearby points (docs/model.md#packets): one traversal shared by kPacket points, every
// expansion computed for all of them at once in SIMD lanes. A point keeps exactly the nodes evaluate(x) would use
// (the same tests on the same numbers) in the same order; only the arithmetic of each term is arranged
// differently, so results agree with the reference path to rounding.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "contributions.h"
#include "core/morton.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "packet_lanes.h"
#include "packet_near_field.h"

namespace gpisvdb {

namespace {

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

/// The mean's second-order far field of one node (addFarMean), times `on`.
GPISVDB_LANES_INLINE void farMean(const BarnesHutGpis::MeanMoments& mm, const LaneVec3& y, const LaneKernel& F, const Lanes& on,
                                  LaneSums& s) {
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
GPISVDB_LANES_INLINE void farCovariance(const BarnesHutGpis::CovarianceMoments& cm, const LaneVec3& y, const Lanes& t, const LaneKernel& F,
                                        const Lanes& on, LaneSums& s) {
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
    const Lanes alpha2 = 2.0 * ab + bb * t;                // pos (0,0) · m
    const Lanes beta2 = 2.0 * bb + c * (a + bt);           // pos (0,i) · m y_i
    const Lanes beta3 = b * (2.0 * a + bt);                // pos (0,i) · v_i
    const Lanes gamma2 = c * (4.0 * b + ct);               // pos (i,j) · m y_i y_j
    const Lanes gamma3 = b * (3.0 * b + ct);               // pos (i,j) · (y_i v_j + v_i y_j)
    const Lanes dA2 = 4.0 * bb + 2.0 * ac + 2.0 * b * ct;  // = d beta3
    const Lanes dB1 = bb + ac;                             // = d(ab)
    const Lanes dB2 = 7.0 * bc + a * d + c * ct + b * dt;
    const Lanes dG1 = 2.0 * bc;  // = d(b²)
    const Lanes dG2 = 6.0 * c * c + 4.0 * b * d + 2.0 * c * dt;
    const Lanes dG3 = 8.0 * bc + c * ct + b * dt;
    const Lanes dG4 = 2.0 * b * ct + 2.0 * bb;  // = d(b² t)
    // === Row 0
    s.cov[0][0] += aa * tauW + alpha2 * mW + aa * mS - (2.0 * ab * T1B + dA2 * T2B + 2.0 * alpha2 * T3B + 2.0 * ab * T2C + 2.0 * aa * T3C);
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
            Lanes v = cYY * y[i] * y[j] + y[i] * R[j] + R[i] * y[j] + btt * Wm[i][j] + aa * Sm[i][j] - gamma3 * (vB[i][j] + vB[j][i]) -
                      ab * (vC[i][j] + vC[j][i]) - dG4 * myB - ab2 * myC;
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

}  // namespace

// (GPISVDB_SIMD_CLONES, in core/simd_lanes.h: one clone of the traversal per instruction set.)
/// The packet traversal, on plain arrays: x[d][l] coordinate d of lane l; out: mean[4][kLanes], cov[4][4][kLanes]
/// (upper triangle), unnormalised.
struct PacketTraversal {
    /// From the given roots (the tree's root: evaluate(x)'s nodes; a cell's roots: the rest of its points' nodes).
    GPISVDB_SIMD_CLONES static void run(const BarnesHutGpis& bh, const BarnesHutGpis::Root* roots, std::size_t rootCount,
                                        const double (*xs)[kLanes], double (*meanOut)[kLanes], double (*covOut)[4][kLanes]);
    /// The far expansions of the listed nodes (mean, covariance) at every lane, whatever the opening tests say.
    GPISVDB_SIMD_CLONES static void far(const BarnesHutGpis& bh, const std::uint32_t* meanNodes, std::size_t meanCount,
                                        const std::uint32_t* covNodes, std::size_t covCount, const double (*xs)[kLanes],
                                        double (*meanOut)[kLanes], double (*covOut)[4][kLanes]);
};

namespace {

GPISVDB_LANES_INLINE void store(const LaneSums& sums, double (*meanOut)[kLanes], double (*covOut)[4][kLanes]) {
    for (int a = 0; a < 4; ++a)
        for (int l = 0; l < kLanes; ++l) {
            meanOut[a][l] = sums.mean[a][l];
            for (int b = a; b < 4; ++b) covOut[a][b][l] = sums.cov[a][b][l];
        }
}

}  // namespace

void PacketTraversal::far(const BarnesHutGpis& bh, const std::uint32_t* meanNodes, std::size_t meanCount, const std::uint32_t* covNodes,
                          std::size_t covCount, const double (*xs)[kLanes], double (*meanOut)[kLanes], double (*covOut)[4][kLanes]) {
    LaneVec3 x;
    for (int d = 0; d < 3; ++d)
        for (int l = 0; l < kLanes; ++l) x[d][l] = xs[d][l];
    LaneSums sums;
    const Lanes all = splat(1.0);
    auto at = [&](std::uint32_t node, LaneVec3& y, Lanes& d2) {
        for (int d = 0; d < 3; ++d) y[d] = x[d] - bh.nodes_[node].centre[d];
        d2 = y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
        return kernelAt(bh.kernel_, d2);
    };
    for (std::size_t k = 0; k < meanCount; ++k) {
        LaneVec3 y;
        Lanes d2;
        const LaneKernel F = at(meanNodes[k], y, d2);
        farMean(bh.meanMoments_[meanNodes[k]], y, F, all, sums);
    }
    for (std::size_t k = 0; k < covCount; ++k) {
        LaneVec3 y;
        Lanes d2;
        const LaneKernel F = at(covNodes[k], y, d2);
        farCovariance(bh.covMoments_[covNodes[k]], y, d2, F, all, sums);
    }
    store(sums, meanOut, covOut);
}

void PacketTraversal::run(const BarnesHutGpis& bh, const BarnesHutGpis::Root* roots, std::size_t rootCount, const double (*xs)[kLanes],
                          double (*meanOut)[kLanes], double (*covOut)[4][kLanes]) {
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
    std::size_t nextRoot = 0;
    const double betaMean2 = options_.beta * options_.beta;
    const double covBeta2 = bh.covarianceRatio2(), covFloor2 = std::min(4.0, covBeta2);
    const double relaxFrom = options_.covarianceRelax * kernel_.smoothing();
    const double relaxFrom2 = relaxFrom * relaxFrom, relaxNumerator = covBeta2 * relaxFrom;
    while (top > 0 || nextRoot < rootCount) {
        if (top == 0) {  // the next root, once the previous one's subtree is done (the stack stays within its bound)
            const BarnesHutGpis::Root& r = roots[nextRoot++];
            stack[top++] = {r.node, r.doneMean ? kAllLanes : 0u, r.doneCov ? kAllLanes : 0u};
        }
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
        for (int l = 0; l < kLanes; ++l) cb2[l] = d2[l] <= relaxFrom2 ? covBeta2 : std::max(covFloor2, relaxed[l]);
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
        for (int c = node.childCount - 1; c >= 0; --c) stack[top++] = {node.firstChild + std::uint32_t(c), e.doneMean, e.doneCov};
    }
    store(sums, meanOut, covOut);
}

void BarnesHutGpis::traversePacket(const Root* roots, std::size_t rootCount, const double (*xs)[kPacket], double (*mean)[kPacket],
                                   double (*cov)[4][kPacket]) const {
    PacketTraversal::run(*this, roots, rootCount, xs, mean, cov);
}

void BarnesHutGpis::farPacket(const std::uint32_t* meanNodes, std::size_t meanCount, const std::uint32_t* covNodes, std::size_t covCount,
                              const double (*xs)[kPacket], double (*mean)[kPacket], double (*cov)[4][kPacket]) const {
    PacketTraversal::far(*this, meanNodes, meanCount, covNodes, covCount, xs, mean, cov);
}

void BarnesHutGpis::evaluatePacket(const Vec3d* xs, int count, ValueGradient* out) const {
    if (count < 1 || count > kLanes) throw Error("BarnesHutGpis::evaluatePacket: 1 to kPacket points");
    double x[3][kLanes], mean[4][kLanes], cov[4][4][kLanes];
    for (int l = 0; l < kLanes; ++l)
        for (int d = 0; d < 3; ++d) x[d][l] = xs[std::min(l, count - 1)][d];  // spare lanes repeat the last point
    const Root root;
    traversePacket(&root, 1, x, mean, cov);
    for (int l = 0; l < count; ++l) {
        ValueGradient& o = out[l];
        for (int a = 0; a < 4; ++a) {
            o.mean[a] = mean[a][l];
            for (int b = a; b < 4; ++b) o.cov(a, b) = o.cov(b, a) = cov[a][b][l];
        }
        detail::finish(o);
    }
}

std::vector<ValueGradient> BarnesHutGpis::evaluate(const std::vector<Vec3d>& xs, const Progress& progress) const {
    std::vector<ValueGradient> out(xs.size());
    if (xs.empty()) return out;
    // === Order the points along a Morton curve so that a packet holds neighbours (they open the same nodes)
    const auto keyed = detail::mortonSorted(xs);
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
