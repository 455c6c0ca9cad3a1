#include "gpisvdb/kacrice/kac_rice_voxel.h"

#include <algorithm>
#include <cmath>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <vector>

#include "core/simd_lanes.h"
#include "gpisvdb/kacrice/box_gaussian.h"

namespace gpisvdb {

namespace {

/// g = m + L q and x = r − βᵀ L q at the rule's points (by coordinate, padded).
GPISVDB_SIMD_CLONES void gradientSamples(const QmcRule& rule, const double (*L)[3], const double* m, const double* beta, double r,
                                         double* gx, double* gy, double* gz, double* x) {
    const double *q0 = rule.coordinate(0).data(), *q1 = rule.coordinate(1).data(), *q2 = rule.coordinate(2).data();
    const std::size_t S = rule.weight().size();
    for (std::size_t k = 0; k < S; ++k) {
        const double d0 = L[0][0] * q0[k] + L[0][1] * q1[k] + L[0][2] * q2[k];
        const double d1 = L[1][0] * q0[k] + L[1][1] * q1[k] + L[1][2] * q2[k];
        const double d2 = L[2][0] * q0[k] + L[2][1] * q1[k] + L[2][2] * q2[k];
        gx[k] = m[0] + d0, gy[k] = m[1] + d1, gz[k] = m[2] + d2;
        x[k] = r - (beta[0] * d0 + beta[1] * d1 + beta[2] * d2);
    }
}

/// sums[0] = Σ w ρ ‖g‖, sums[1..6] = Σ w ρ g gᵀ/‖g‖ as (xx, yy, zz, xy, xz, yz), w the rule's weights (0: padding).
GPISVDB_SIMD_CLONES void weightedMoments(const QmcRule& rule, const double* gx, const double* gy, const double* gz, const double* rho,
                                         double* sums) {
    const double* weight = rule.weight().data();
    double acc[7] = {0, 0, 0, 0, 0, 0, 0};
    const std::size_t S = rule.weight().size();
    for (std::size_t k = 0; k < S; ++k) {
        const double n = std::sqrt(gx[k] * gx[k] + gy[k] * gy[k] + gz[k] * gz[k]);
        const double wr = weight[k] * rho[k], inv = n > 0 ? wr / n : 0.0;
        acc[0] += wr * n;
        acc[1] += gx[k] * gx[k] * inv, acc[2] += gy[k] * gy[k] * inv, acc[3] += gz[k] * gz[k] * inv;
        acc[4] += gx[k] * gy[k] * inv, acc[5] += gx[k] * gz[k] * inv, acc[6] += gy[k] * gz[k] * inv;
    }
    for (int i = 0; i < 7; ++i) sums[i] = acc[i];
}

}  // namespace

bool meanSurfaceCrosses(const ValueGradient& z, double iso, double h) {
    return std::abs(iso - z.mean[0]) <= 0.5 * h * z.mean.tail<3>().lpNorm<1>();
}

SurfaceDensity kacRiceVoxel(const ValueGradient& z, double iso, double h, const QmcRule& rule) {
    SurfaceDensity out;
    const double c00 = z.cov(0, 0);
    if (!(c00 > 0)) return out;
    const Vec3d cg0 = z.cov.block<3, 1>(1, 0);
    const double r = iso - z.mean[0];
    out.density = std::exp(-0.5 * r * r / c00) / std::sqrt(2.0 * M_PI * c00);
    out.meanGradient = z.mean.tail<3>() + cg0 * (r / c00);

    // === The marginal of ∇φ, g ~ N(∇γ, C_gg) = N(∇γ, L Lᵀ), and φ₀ given g: mean γ + βᵀ(g − ∇γ), β = C_gg⁻¹ c_g0,
    // variance c₀₀ − c_g0ᵀ β. Cholesky where C_gg is positive definite (unique, continuous in C_gg, as in kacRice);
    // otherwise the eigen-decomposition and a pseudo-inverse.
    Mat3d Cgg = z.cov.block<3, 3>(1, 1);
    Cgg = (0.5 * (Cgg + Cgg.transpose())).eval();
    Mat3d L;
    Vec3d beta;
    const Eigen::LLT<Mat3d> llt(Cgg);
    if (llt.info() == Eigen::Success) {
        L = llt.matrixL();
        beta = llt.solve(cg0);
    } else {
        const Eigen::SelfAdjointEigenSolver<Mat3d> eig(Cgg);
        const Vec3d lambda = eig.eigenvalues().cwiseMax(0.0);
        const double floor = 1e-12 * lambda.maxCoeff();
        Vec3d inv;
        for (int k = 0; k < 3; ++k) inv[k] = lambda[k] > floor ? 1.0 / lambda[k] : 0.0;
        L = eig.eigenvectors() * lambda.cwiseSqrt().asDiagonal();
        beta = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose() * cg0;
    }
    // A covariance that is not positive semi-definite (the model's error where it is tiny, far from the samples)
    // could explain more of φ₀'s variance through g than φ₀ has: cap it at c₀₀.
    const double explained = cg0.dot(beta);
    if (explained > c00) beta *= std::sqrt(c00 / explained);
    const double s = std::sqrt(std::max(0.0, c00 - cg0.dot(beta)));
    const Vec3d gradMean = z.mean.tail<3>();
    // === No share where the field at every point of the cube stays 8 std from u: its value there has mean
    // γ + ∇γ·y and a variance at most (√c₀₀ + ‖y‖ √λmax(C_gg))², ‖y‖ ≤ √3 h/2.
    const double reach = 0.5 * h * gradMean.lpNorm<1>(), spread = std::sqrt(c00) + 0.87 * h * std::sqrt(Cgg.trace());
    if (std::abs(r) > reach + 8 * spread) return out;

    // === Expectations over g by the QMC rule: each g makes the plane φ₀ + g·y = u, its area inside the cube the box
    // spline with widths h|g_k| in φ's units, blurred by φ₀'s noise given g. By coordinate over all of the rule's
    // points (padded to a multiple of 8 with weight 0), so that the loops run in SIMD lanes.
    const std::size_t S = rule.weight().size();
    thread_local std::vector<double> gx, gy, gz, x, rho;
    gx.resize(S), gy.resize(S), gz.resize(S), x.resize(S), rho.resize(S);
    const double Lr[3][3] = {{L(0, 0), L(0, 1), L(0, 2)}, {L(1, 0), L(1, 1), L(1, 2)}, {L(2, 0), L(2, 1), L(2, 2)}};
    const double m[3] = {gradMean[0], gradMean[1], gradMean[2]}, bt[3] = {beta[0], beta[1], beta[2]};
    gradientSamples(rule, Lr, m, bt, r, gx.data(), gy.data(), gz.data(), x.data());
    thread_local std::vector<double> a, b, c;
    a.resize(S), b.resize(S), c.resize(S);
    for (std::size_t k = 0; k < S; ++k) a[k] = h * gx[k], b[k] = h * gy[k], c[k] = h * gz[k];
    boxGaussianDensities(S, x.data(), a.data(), b.data(), c.data(), s, rho.data());
    double sums[7];
    weightedMoments(rule, gx.data(), gy.data(), gz.data(), rho.data(), sums);
    const double norms = sums[0];
    Mat3d outer;  // Σ ρ g gᵀ/‖g‖
    outer << sums[1], sums[4], sums[5], sums[4], sums[2], sums[6], sums[5], sums[6], sums[3];
    const double w = 1.0 / double(rule.size());
    out.mu = w * norms;
    out.T = w * (norms * Mat3d::Identity() - outer);
    out.T = (0.5 * (out.T + out.T.transpose())).eval();
    return out;
}

}  // namespace gpisvdb
