#pragma once
// A candidate for μ and T at voxels much coarser than μ's width (issue 38 item 2; docs/benchmarks.md#column-values),
// measured by bench_resolution --values column, not an engine path: each voxel's μ and T are their means along the
// voxel's three axis-parallel segments through its centre, weighted by n_a² (n the mean normal there; Σ n_a² = 1), by
// Kac–Rice at Gauss points along each segment on the Gaussian (φ, ∇φ) interpolated between the neighbouring centres.
// The mean and its gradient are interpolated in the probit scale, ψ = Φ⁻¹(γ) and ∇ψ = ∇γ / φ(ψ), in which a surface's
// profile γ ≈ Φ(−d/s) is linear, so a crossing between two centres a voxel apart (h ≫ s) lands where it is and with
// the gradient it has there; the covariance linearly. Summed down a column of one axis the segments give ∫ μ dt, the
// expected area per unit cross-section over |n_a|, wherever the surface falls between centres: the expected area no
// longer depends on the lattice's offset, as the centres' values do once h ≫ w_μ.
#include <array>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb::column {

struct CoordHash {
    std::size_t operator()(const openvdb::Coord& c) const {
        return std::size_t(c.x()) * 73856093u ^ std::size_t(c.y()) * 19349663u ^ std::size_t(c.z()) * 83492791u;
    }
};

/// Φ⁻¹ by Newton on erfc, for p in (0, 1).
inline double probit(double p) {
    double x = 0;
    for (int k = 0; k < 60; ++k) {
        const double f = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p, d = std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI);
        const double step = f / std::max(d, 1e-300);
        x -= std::clamp(step, -2.0, 2.0);
        if (std::abs(step) < 1e-13) break;
    }
    return x;
}

/// The Gaussian at fraction λ ∈ [0, 1] from a to b. Where both means lie in (ε, 1 − ε) and `probitMean`, the mean and
/// its gradient in the probit scale (ψ = Φ⁻¹(γ) and ∇ψ = ∇γ / φ(ψ) linearly, mapped back with φ(ψ(λ))); the
/// covariance, and everything elsewhere, linearly. (Scaling the covariance with φ(ψ)² as the gradient was tried: the
/// far centres' tiny φ(ψ) then blow it up, and the area overshot by 1–19 % at h / w_μ = 2–8.)
inline gpisvdb::ValueGradient interpolate(const gpisvdb::ValueGradient& a, const gpisvdb::ValueGradient& b, double lambda,
                                          bool probitMean) {
    gpisvdb::ValueGradient z;
    constexpr double eps = 1e-9;
    const double ma = a.mean[0], mb = b.mean[0];
    if (!(probitMean && ma > eps && ma < 1 - eps && mb > eps && mb < 1 - eps)) {
        z.mean = (1 - lambda) * a.mean + lambda * b.mean;
        z.cov = (1 - lambda) * a.cov + lambda * b.cov;
        return z;
    }
    const auto pdf = [](double x) { return std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI); };
    const double pa = probit(ma), pb = probit(mb), fa = pdf(pa), fb = pdf(pb);
    const double psi = (1 - lambda) * pa + lambda * pb, f = pdf(psi);
    const gpisvdb::Vec3d grad = (1 - lambda) * a.mean.tail<3>() / fa + lambda * b.mean.tail<3>() / fb;
    z.mean[0] = 0.5 * std::erfc(-psi / std::sqrt(2.0));
    z.mean.tail<3>() = f * grad;
    z.cov = (1 - lambda) * a.cov + lambda * b.cov;
    return z;
}

/// The band of `pointBand`'s voxels and their face neighbours, with μ and T as above; voxels whose μ ≤ eta are left
/// out (eta in world units⁻¹, as the band's own threshold).
inline gpisvdb::Band columnValues(const gpisvdb::GpisModel& model, const gpisvdb::Band& pointBand, double iso, double eta, int qmc,
                                  double maxAnisotropy, bool probitMean = true) {
    const double h = pointBand.voxelSize;
    const std::array<openvdb::Coord, 3> axis = {openvdb::Coord(1, 0, 0), openvdb::Coord(0, 1, 0), openvdb::Coord(0, 0, 1)};
    // === The voxels: the band and its face neighbours (a crossing may lie between a band voxel and the next)
    std::unordered_map<openvdb::Coord, std::size_t, CoordHash> index;
    std::vector<openvdb::Coord> coords;
    auto add = [&](const openvdb::Coord& c) {
        if (index.emplace(c, coords.size()).second) coords.push_back(c);
    };
    for (const auto& c : pointBand.coord) add(c);
    for (std::size_t i = 0, n = coords.size(); i < n; ++i)
        for (const auto& e : axis) add(coords[i] + e), add(coords[i] - e);
    std::vector<Vec3d> xs(coords.size());
    for (std::size_t i = 0; i < coords.size(); ++i) xs[i] = h * Vec3d(coords[i].x(), coords[i].y(), coords[i].z());
    const std::vector<ValueGradient> z = model.evaluateDense(xs);
    // === Per voxel and axis: the mean of μ and T over the segment through its centre, 6 Gauss points per half
    const QmcRule rule(qmc);
    const double gx[3] = {0.2386191860831909, 0.6612093864662645, 0.9324695142031521};
    const double gw[3] = {0.4679139345661783, 0.3607615730065964, 0.1713244923791926};
    std::vector<BandVoxel> voxels;
    for (std::size_t i = 0; i < coords.size(); ++i) {
        const Vec3d g = z[i].mean.tail<3>();
        const Vec3d n = g.norm() > 0 ? Vec3d(g / g.norm()) : Vec3d(1, 0, 0).eval();
        double mu = 0;
        Mat3d T = Mat3d::Zero();
        for (int a = 0; a < 3; ++a) {
            const double w = n[a] * n[a];
            if (w == 0) continue;
            double muA = 0;
            Mat3d TA = Mat3d::Zero();
            for (int side = -1; side <= 1; side += 2) {
                const openvdb::Coord& e = axis[std::size_t(a)];
                const auto it = index.find(coords[i] + openvdb::Coord(e.x() * side, e.y() * side, e.z() * side));
                // the half segment [centre, centre ± h/2]: λ from 0 to 1/2 towards the neighbour's centre
                for (int k = 0; k < 6; ++k) {
                    const double u = 0.5 * (1 + (k < 3 ? -gx[k] : gx[k - 3]));  // in (0, 1) over the half segment
                    const double weight = gw[k < 3 ? k : k - 3] * 0.5;          // Gauss weights on (0, 1), sum 1
                    const ValueGradient zt = it == index.end() ? z[i] : interpolate(z[i], z[it->second], 0.5 * u, probitMean);
                    const SurfaceDensity d = kacRice(zt, iso, rule);
                    muA += 0.5 * weight * d.mu, TA += 0.5 * weight * d.T;
                }
            }
            mu += w * muA, T += w * TA;
        }
        if (!(mu > eta)) continue;
        const SurfaceDensity c = kacRice(z[i], iso, rule);
        const double cg = c.meanGradient.norm();
        voxels.push_back({coords[i], mu, T, z[i].mean[0], std::sqrt(std::max(0.0, z[i].cov(0, 0))),
                          cg > 0 ? Vec3d(-c.meanGradient / cg) : Vec3d::Zero(), false});
    }
    return bandFromVoxels(std::move(voxels), h, maxAnisotropy).band;
}

}  // namespace gpisvdb::column
