#pragma once
// One sample's (or one aggregated node's) share of the mean and covariance of Z = (φ, ∇φ), paper Eq. 7.
// The 1/(4π) factors are left out here and applied once per evaluation (mean ×1/(4π), covariance ×1/(4π)²).
#include "gpisvdb/core/types.h"
#include "gpisvdb/model/gpis_model.h"
#include "gpisvdb/model/kernel.h"

namespace gpisvdb::detail {

constexpr double kInv4Pi = 0.25 / M_PI;

/// Mean: (∇ρ(y)·w, D²ρ(y) w).
inline void addMean(const RadialDerivatives& F, const Vec3d& y, const Vec3d& w, Vec4d& mean) {
    const double yw = y.dot(w);
    mean[0] += F.F1 * yw;
    mean.tail<3>() += F.F1 * w + (F.F2 * yw) * y;
}

/// Position noise: var · J Jᵀ with J = [(D²ρ w)ᵀ; D³ρ·w] (the sign of J drops out).
inline void addPositionNoise(const RadialDerivatives& F, const Vec3d& y, const Vec3d& w, double var, Mat4d& cov) {
    Mat43d J;
    J.row(0) = (F.F1 * w + (F.F2 * y.dot(w)) * y).transpose();
    J.bottomRows<3>() = RegularizedKernel::thirdContracted(F, y, w);
    cov.noalias() += var * (J * J.transpose());
}

/// Normal noise: K Σ' Kᵀ with K = [∇ρᵀ; D²ρ].
inline void addNormalNoise(const RadialDerivatives& F, const Vec3d& y, const Mat3d& S, Mat4d& cov) {
    Mat43d K;
    K.row(0) = (F.F1 * y).transpose();
    K.bottomRows<3>() = RegularizedKernel::hessian(F, y);
    cov.noalias() += K * S * K.transpose();
}

inline void finish(ValueGradient& out) {
    out.mean *= kInv4Pi;
    out.cov *= kInv4Pi * kInv4Pi;
}

}  // namespace gpisvdb::detail
