#include "gpisvdb/kacrice/kac_rice_column.h"

#include <algorithm>
#include <cmath>

#include "../core/standard_normal.h"

namespace gpisvdb {

namespace {

/// Means closer than this to 0 or 1 are not mapped to the probit scale (Φ⁻¹ is past ±6 there and its gradient's
/// φ(ψ) below 10⁻⁸: the interpolation falls back to linear).
constexpr double kProbitMargin = 1e-9;

bool probitable(double gamma) { return gamma > kProbitMargin && gamma < 1 - kProbitMargin; }

/// 6 Gauss–Legendre points per half segment: nodes on (0, 1) and weights summing to 1.
constexpr double kNode[6] = {0.0337652428984240, 0.1693953067668677, 0.3806904069584015,
                             0.6193095930415985, 0.8306046932331323, 0.9662347571015760};
constexpr double kWeight[6] = {0.0856622461895852, 0.1803807865240693, 0.2339569672863455,
                               0.2339569672863455, 0.1803807865240693, 0.0856622461895852};

/// The value density at u is below e⁻⁴⁰ of its peak.
bool negligible(const ValueGradient& z, double iso) {
    const double r = iso - z.mean[0];
    return !(z.cov(0, 0) > 0) || r * r > 80 * z.cov(0, 0);
}

}  // namespace

namespace {

/// An end of a segment: its Gaussian and, where the probit scale applies, ψ = Φ⁻¹(γ) and ∇ψ = ∇γ / φ(ψ).
struct SegmentEnd {
    const ValueGradient* z;
    bool probitScale = false;
    double psi = 0;
    Vec3d gradPsi = Vec3d::Zero();

    SegmentEnd(const ValueGradient& g, MeanScale scale) : z(&g) {
        if (scale != MeanScale::Probit || !probitable(g.mean[0])) return;
        probitScale = true;
        psi = normalQuantile(g.mean[0]);
        gradPsi = g.mean.tail<3>() / normalPdf(psi);
    }
};

ValueGradient interpolate(const SegmentEnd& a, const SegmentEnd& b, double lambda) {
    ValueGradient z;
    z.cov = (1 - lambda) * a.z->cov + lambda * b.z->cov;
    if (!(a.probitScale && b.probitScale)) {
        z.mean = (1 - lambda) * a.z->mean + lambda * b.z->mean;
        return z;
    }
    const double psi = (1 - lambda) * a.psi + lambda * b.psi;
    z.mean[0] = normalCdf(psi);
    z.mean.tail<3>() = normalPdf(psi) * ((1 - lambda) * a.gradPsi + lambda * b.gradPsi);
    return z;
}

}  // namespace

ValueGradient interpolateGaussian(const ValueGradient& a, const ValueGradient& b, double lambda, MeanScale scale) {
    return interpolate(SegmentEnd(a, scale), SegmentEnd(b, scale), lambda);
}

SurfaceDensity kacRiceColumn(const ColumnGaussians& z, double iso, MeanScale scale, const QmcRule& rule) {
    SurfaceDensity out;
    const ValueGradient& c = *z.centre;
    const double c00 = c.cov(0, 0);
    if (!(c00 > 0)) return out;
    const double r = iso - c.mean[0];
    out.density = std::exp(-0.5 * r * r / c00) / std::sqrt(2.0 * M_PI * c00);
    out.meanGradient = c.mean.tail<3>() + c.cov.block<3, 1>(1, 0) * (r / c00);

    // === The axes' weights n_a², n the direction of ∇γ at the centre (equal where ∇γ vanishes)
    const Vec3d g = c.mean.tail<3>();
    const double gn2 = g.squaredNorm();
    const Vec3d weight = gn2 > 0 ? Vec3d(g.cwiseAbs2() / gn2) : Vec3d::Constant(1.0 / 3);

    // === Per axis and side: the half segment from the centre to the face, λ ∈ [0, ½] towards the neighbour's centre
    const SegmentEnd centre(c, scale);
    for (int axis = 0; axis < 3; ++axis) {
        if (weight[axis] == 0) continue;
        for (int side = 0; side < 2; ++side) {
            const SegmentEnd far(*z.neighbour[std::size_t(2 * axis + side)], scale);
            for (int k = 0; k < 6; ++k) {
                const ValueGradient zt = interpolate(centre, far, 0.5 * kNode[k]);
                if (negligible(zt, iso)) continue;
                const SurfaceDensity d = kacRice(zt, iso, rule);
                const double w = 0.5 * weight[axis] * kWeight[k];
                out.mu += w * d.mu, out.T += w * d.T;
            }
        }
    }
    return out;
}

}  // namespace gpisvdb
