#include "gpisvdb/kacrice/kac_rice.h"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace gpisvdb {

SurfaceDensity kacRice(const ValueGradient& z, double iso, const QmcRule& rule) {
    SurfaceDensity out;
    const double c00 = z.cov(0, 0);
    if (!(c00 > 0)) return out;
    // === Condition ∇φ on φ = u (paper Eq. 4)
    const Vec3d cg0 = z.cov.block<3, 1>(1, 0);
    const double r = iso - z.mean[0];
    out.density = std::exp(-0.5 * r * r / c00) / std::sqrt(2.0 * M_PI * c00);
    out.meanGradient = z.mean.tail<3>() + cg0 * (r / c00);
    if (!(out.density > 0)) return out;
    Mat3d sigma = z.cov.block<3, 3>(1, 1) - cg0 * cg0.transpose() / c00;
    sigma = (0.5 * (sigma + sigma.transpose())).eval();
    // Σ = L Lᵀ through its eigen-decomposition: exact for semi-definite Σ (rounding may leave tiny negatives).
    Eigen::SelfAdjointEigenSolver<Mat3d> eig(sigma);
    const Mat3d L = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    // === Expectations by QMC (paper Sec. 8.3)
    double norms = 0;
    Mat3d outer = Mat3d::Zero();  // Σ X Xᵀ/‖X‖
    for (const Vec3d& q : rule.points()) {
        const Vec3d X = out.meanGradient + L * q;
        const double n = X.norm();
        if (!(n > 0)) continue;  // ‖X‖ I − X Xᵀ/‖X‖ → 0 as X → 0
        norms += n;
        outer.noalias() += (X / n) * X.transpose();
    }
    const double w = out.density / double(rule.size());
    out.mu = w * norms;
    out.T = w * (norms * Mat3d::Identity() - outer);
    out.T = (0.5 * (out.T + out.T.transpose())).eval();
    return out;
}

}  // namespace gpisvdb
