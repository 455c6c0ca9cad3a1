#include "gpisvdb/model/barnes_hut_gpis.h"

#include <array>
#include <cmath>
#include <Eigen/Eigenvalues>

#include "contributions.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb {

BarnesHutGpis::BarnesHutGpis(const Samples& samples, double s, const BarnesHutOptions& options) : kernel_(s), options_(options) {
    if (!(options.beta > 1) || !std::isfinite(options.beta))
        throw ParameterError(
            "the Barnes-Hut opening criterion β (BarnesHutOptions::beta) must be finite and > 1 (got " + numberText(options.beta) + ")",
            {"BarnesHutOptions::beta"});
    if (!(options.covarianceRatio >= 1) || !std::isfinite(options.covarianceRatio))
        throw ParameterError("the covariance's opening ratio (BarnesHutOptions::covarianceRatio) must be finite and >= 1 (got " +
                                 numberText(options.covarianceRatio) + ")",
                             {"BarnesHutOptions::covarianceRatio"});
    if (options.leafSize < 1) throw ParameterError("the Barnes-Hut leaf size must be >= 1");
    if (!(options.cellWidth >= 0) || !std::isfinite(options.cellWidth))
        throw ParameterError(
            "the far field's cell width (BarnesHutOptions::cellWidth) must be finite and >= 0 (got " + numberText(options.cellWidth) + ")",
            {"BarnesHutOptions::cellWidth"});
    if (options.cellWidth > 0 && !std::isnormal(options.cellWidth * s))
        throw ParameterError(
            "the far field's cell width (BarnesHutOptions::cellWidth) times the smoothing is not a normal "
            "number (got " +
                numberText(options.cellWidth) + " × " + numberText(s) + "): use 0 or a width near 12",
            {"BarnesHutOptions::cellWidth"});
    if (options.cellNodes < 2 || options.cellNodes > 8)
        throw ParameterError("the cells' Chebyshev nodes per axis (BarnesHutOptions::cellNodes) must be 2 to 8 (got " +
                                 std::to_string(options.cellNodes) + ")",
                             {"BarnesHutOptions::cellNodes"});
    if (!(options.cellSeparation >= 0.5) || !std::isfinite(options.cellSeparation))
        throw ParameterError("the cells' separation (BarnesHutOptions::cellSeparation) must be finite and >= 0.5 (got " +
                                 numberText(options.cellSeparation) + ")",
                             {"BarnesHutOptions::cellSeparation"});
    if (samples.size() == 0) throw InputError("no samples to build a GPIS from");
    if (samples.size() >= std::size_t(UINT32_MAX)) throw InputError("too many samples (limit 2^32 - 1)");
    if (options.cellWidth > 0) cells_ = newCellCache();
    samples_ = samples;
    addNode(0, std::uint32_t(samples_.size()));
    split(0, 0);
    const double s2 = s * s, s4 = s2 * s2;
    // Two records past the end: the packets load 16 floats from each record (packet_near_field.h).
    nearSamples_.assign(samples_.size() + 2, NearSample{});
    for (std::size_t i = 0; i < samples_.size(); ++i) {
        NearSample& n = nearSamples_[i];
        for (int d = 0; d < 3; ++d) n.w[d] = float(samples_.normal[i][d] / s2);
        n.var = float(samples_.positionVariance[i] / s2);
        const Sym3& N = samples_.normalCovariance[i];
        const double entries[6] = {N.xx, N.xy, N.xz, N.yy, N.yz, N.zz};
        for (int k = 0; k < 6; ++k) n.N[k] = float(entries[k] / s4);
    }
}

std::size_t BarnesHutGpis::memoryBytes() const {
    return nodes_.capacity() * sizeof(Node) + meanMoments_.capacity() * sizeof(MeanMoments) +
           covMoments_.capacity() * sizeof(CovarianceMoments) +
           samples_.size() * (2 * sizeof(Vec3d) + sizeof(double) + sizeof(Sym3) + sizeof(NearSample));
}

// === Tree: split the samples' bounding box at its centre into octants, children contiguous in nodes_.
void BarnesHutGpis::split(std::uint32_t self, int depth) {
    const std::uint32_t begin = nodes_[self].begin, end = nodes_[self].end;
    if (end - begin <= std::uint32_t(options_.leafSize) || depth >= kMaxDepth) return;
    Vec3d lo = samples_.position[begin], hi = lo;
    for (std::uint32_t i = begin; i < end; ++i) {
        lo = lo.cwiseMin(samples_.position[i]);
        hi = hi.cwiseMax(samples_.position[i]);
    }
    if ((hi - lo).maxCoeff() <= 0) return;  // all coincident
    const Vec3d mid = 0.5 * (lo + hi);
    auto octant = [&](std::uint32_t i) {
        const Vec3d& p = samples_.position[i];
        return std::size_t((p.x() > mid.x() ? 1 : 0) | (p.y() > mid.y() ? 2 : 0) | (p.z() > mid.z() ? 4 : 0));
    };
    // Stable counting sort of the range by octant: the tree depends on nothing but the input.
    std::array<std::uint32_t, 9> start{};
    for (std::uint32_t i = begin; i < end; ++i) ++start[octant(i) + 1];
    for (int k = 0; k < 8; ++k) start[k + 1] += start[k];
    std::vector<std::uint32_t> order(end - begin);
    std::array<std::uint32_t, 8> fill;
    std::copy(start.begin(), start.begin() + 8, fill.begin());
    for (std::uint32_t i = begin; i < end; ++i) order[fill[octant(i)]++] = i;
    auto permute = [&](auto& v) {
        std::vector<typename std::decay_t<decltype(v)>::value_type> sorted(order.size());
        for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = v[order[k]];
        std::copy(sorted.begin(), sorted.end(), v.begin() + begin);
    };
    permute(samples_.position);
    permute(samples_.normal);
    permute(samples_.positionVariance);
    permute(samples_.normalCovariance);

    const std::uint32_t first = std::uint32_t(nodes_.size());
    for (int k = 0; k < 8; ++k)
        if (start[k + 1] > start[k]) addNode(begin + start[k], begin + start[k + 1]);
    nodes_[self].firstChild = first;
    nodes_[self].childCount = std::uint8_t(nodes_.size() - first);
    for (std::uint32_t c = first; c < first + nodes_[self].childCount; ++c) split(c, depth + 1);
}

// === Far-field moments of one node (docs/math.md#barnes-hut)
std::uint32_t BarnesHutGpis::addNode(std::uint32_t begin, std::uint32_t end) {
    Node node;
    node.begin = begin;
    node.end = end;
    double wSum = 0;
    Vec3d c = Vec3d::Zero(), lo = samples_.position[begin], hi = lo;
    for (std::uint32_t i = begin; i < end; ++i) {
        const Vec3d& p = samples_.position[i];
        const double a = samples_.normal[i].norm();
        wSum += a;
        c += a * p;
        lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    }
    node.centre = wSum > 0 ? Vec3d(c / wSum) : Vec3d(0.5 * (lo + hi));

    MeanMoments mm;
    CovarianceMoments cm;
    mm.w0.setZero();
    mm.m1.setZero();
    cm.posW.setZero();
    cm.nrmS.setZero();
    for (int k = 0; k < 3; ++k) mm.m2[k].setZero(), cm.posB[k].setZero(), cm.nrmC[k].setZero();
    double r2 = 0;
    for (std::uint32_t i = begin; i < end; ++i) {
        const Vec3d& w = samples_.normal[i];
        const Vec3d d = samples_.position[i] - node.centre;
        const double v = samples_.positionVariance[i];
        const Mat3d S = samples_.normalCovariance[i].matrix();
        r2 = std::max(r2, d.squaredNorm());
        mm.w0 += w;
        mm.m1 += d * w.transpose();
        const Mat3d dd = d * d.transpose();
        for (int n = 0; n < 3; ++n) mm.m2[n] += w[n] * dd;
        const Mat3d dw = v * (d * w.transpose());
        cm.posW += v * (w * w.transpose());
        for (int n = 0; n < 3; ++n) cm.posB[n] += dw * w[n];
        cm.nrmS += S;
        for (int l = 0; l < 3; ++l) cm.nrmC[l] += d[l] * S;
    }
    node.radius = std::sqrt(r2);
    for (int n = 0; n < 3; ++n) mm.m2trace[n] = mm.m2[n].trace();
    mm.m2mixed = mm.m2[0].row(0).transpose() + mm.m2[1].row(1).transpose() + mm.m2[2].row(2).transpose();
    nodes_.push_back(node);
    meanMoments_.push_back(mm);
    covMoments_.push_back(cm);
    return std::uint32_t(nodes_.size() - 1);
}

namespace {

/// (D³ρ : X)_k = Σ_lm D³ρ_klm X_lm for any 3×3 X.
Vec3d contract3(const RadialDerivatives& F, const Vec3d& y, const Mat3d& X) {
    const double tr = X.trace(), yXy = y.dot(X * y);
    return F.F2 * (X * y + X.transpose() * y + tr * y) + (F.F3 * yXy) * y;
}

/// (D⁴ρ : X)_jk = Σ_lm D⁴ρ_jkml X_lm for any 3×3 X.
Mat3d contract4(const RadialDerivatives& F, const Vec3d& y, const Mat3d& X) {
    const double tr = X.trace(), yXy = y.dot(X * y);
    const Vec3d z = (X + X.transpose()) * y;
    Mat3d out = F.F2 * (X + X.transpose()) + F.F3 * (z * y.transpose() + y * z.transpose() + tr * (y * y.transpose())) +
                (F.F4 * yXy) * (y * y.transpose());
    out.diagonal().array() += F.F2 * tr + F.F3 * yXy;
    return out;
}

/// D²ρ : X = Σ_lm D²ρ_lm X_lm.
double contract2(const RadialDerivatives& F, const Vec3d& y, const Mat3d& X) { return F.F1 * X.trace() + F.F2 * y.dot(X * y); }

}  // namespace

void BarnesHutGpis::addFarMean(const MeanMoments& mm, const Vec3d& y, const RadialDerivatives& F, ValueGradient& out) const {
    const Mat3d D2 = RegularizedKernel::hessian(F, y);

    // === Mean: ∇ρ(y − δ)·w and D²ρ(y − δ) w to second order in δ
    // With M2_lmn = Σ δ_l δ_m w_n: tr_n = Σ_l M2_lln, um_m = Σ_l M2_lml, Q_l = Σ_mn M2_lmn y_m y_n,
    // P_n = Σ_lm M2_lmn y_l y_m (derivation in docs/model.md).
    const Mat3d& M1 = mm.m1;
    const Vec3d& tr = mm.m2trace;
    const Vec3d& um = mm.m2mixed;
    Vec3d P, Q = Vec3d::Zero();
    for (int n = 0; n < 3; ++n) {
        const Vec3d v = mm.m2[n] * y;
        P[n] = y.dot(v);
        Q += y[n] * v;
    }
    const double Y3 = y.dot(P), ty = tr.dot(y), uy = um.dot(y);
    out.mean[0] += F.F1 * y.dot(mm.w0) - contract2(F, y, M1) + 0.5 * (F.F2 * (ty + 2 * uy) + F.F3 * Y3);
    const Vec3d d4m2 = F.F2 * (2 * um + tr) + F.F3 * (2 * Q + P + (ty + 2 * uy) * y) + (F.F4 * Y3) * y;
    out.mean.tail<3>() += D2 * mm.w0 - contract3(F, y, M1) + 0.5 * d4m2;
}

void BarnesHutGpis::addFarCovariance(const CovarianceMoments& cm, const Vec3d& y, const RadialDerivatives& F, ValueGradient& out) const {
    const Mat3d D2 = RegularizedKernel::hessian(F, y);

    // === Covariance to first order in δ. Q_m = J(y, e_m) = [D²ρ e_m; D³ρ·e_m] is also ∂_m K(y).
    Mat43d Qm[3];
    for (int m = 0; m < 3; ++m) {
        Qm[m].row(0) = D2.col(m).transpose();
        Qm[m].bottomRows<3>() = RegularizedKernel::thirdContracted(F, y, Vec3d::Unit(m));
    }
    // Position noise: Σ σ² J Jᵀ ≈ Σ_mn W_mn Q_m Q_nᵀ − (S + Sᵀ), S = Σ_n R_n Q_nᵀ, R_n = Σ_lm B_lmn ∂_l Q_m.
    Mat4d S = Mat4d::Zero();
    for (int m = 0; m < 3; ++m) {
        Mat43d WQ = Mat43d::Zero();
        for (int n = 0; n < 3; ++n) WQ += cm.posW(m, n) * Qm[n];
        Mat43d R;
        R.row(0) = contract3(F, y, cm.posB[m]).transpose();
        R.bottomRows<3>() = contract4(F, y, cm.posB[m]);
        S.noalias() += Qm[m] * (0.5 * WQ - R).transpose();
    }
    out.cov += S + S.transpose();
    // Normal noise: K Σ' Kᵀ − (U + Uᵀ), U = Σ_l ∂_l K C_l Kᵀ, K = [∇ρᵀ; D²ρ].
    Mat43d K;
    K.row(0) = (F.F1 * y).transpose();
    K.bottomRows<3>() = D2;
    Mat43d V = 0.5 * K * cm.nrmS;
    for (int l = 0; l < 3; ++l) V.noalias() -= Qm[l] * cm.nrmC[l];
    const Mat4d U = V * K.transpose();
    out.cov += U + U.transpose();
}

ValueGradient BarnesHutGpis::evaluate(const Vec3d& x) const {
    ValueGradient out;
    // Stack entries: node index, and which parts (bit 0 mean, bit 1 covariance) an ancestor already summed.
    std::array<std::pair<std::uint32_t, std::uint8_t>, 8 * kMaxDepth + 8> stack;
    int top = 0;
    stack[top++] = {0u, std::uint8_t(0)};
    const double betaMean2 = options_.beta * options_.beta;
    while (top > 0) {
        auto [index, done] = stack[--top];
        const Node& node = nodes_[index];
        const Vec3d y = x - node.centre;
        const double d2 = y.squaredNorm(), r2 = node.radius * node.radius;
        const bool farMean = !(done & 1) && d2 > betaMean2 * r2;
        const bool farCov = !(done & 2) && d2 > covarianceBeta2(d2) * r2;
        if (farMean || farCov) {
            const RadialDerivatives F = kernel_.at(d2);
            if (farMean) addFarMean(meanMoments_[index], y, F, out), done |= 1;
            if (farCov) addFarCovariance(covMoments_[index], y, F, out), done |= 2;
        }
        if (done == 3) continue;
        if (node.childCount == 0) {
            for (std::uint32_t i = node.begin; i < node.end; ++i) {
                const Vec3d yi = x - samples_.position[i];
                const RadialDerivatives F = kernel_.at(yi.squaredNorm());
                if (!(done & 1)) detail::addMean(F, yi, samples_.normal[i], out.mean);
                if (!(done & 2)) {
                    detail::addPositionNoise(F, yi, samples_.normal[i], samples_.positionVariance[i], out.cov);
                    detail::addNormalNoise(F, yi, samples_.normalCovariance[i].matrix(), out.cov);
                }
            }
            continue;
        }
        for (int c = node.childCount - 1; c >= 0; --c) stack[top++] = {node.firstChild + std::uint32_t(c), done};
    }
    detail::finish(out);
    return out;
}

}  // namespace gpisvdb
