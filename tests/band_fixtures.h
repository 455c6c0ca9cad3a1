#pragma once
// Small bands shared by the operator, solver, task and output tests (built once per test process).
#include <Eigen/Geometry>
#include <random>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/model/barnes_hut_gpis.h"

namespace gpisvdb::test {

inline Band bandOf(const TriangleSoup& soup, double sigmaRel, double voxelSize) {
    const SoupSamples ss = soupSamples(soup, {sigmaRel});
    const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
    BandOptions o;
    o.voxelSize = voxelSize;
    return buildBand(model, ss.samples, o).band;
}

/// Unit sphere (320 triangles), σ_rel = 1, h = 0.08: about 13 000 voxels.
inline const Band& sphereBand() {
    static const Band band = bandOf(icosphere(2), 1.0, 0.08);
    return band;
}

/// Torus (ring 1, tube 0.4) with its top cut away, σ_rel = 1, h = 0.06.
inline const Band& torusGapBand() {
    static const Band band = bandOf(cutAbove(torus(48, 16), 0.25), 1.0, 0.06);
    return band;
}

/// A band from analytic fields, no GPIS: a ball of `radius` voxels (index space) with h = `h`, a smooth
/// positive μ, and T = μ R diag(1, a⁻², a⁻¹) Rᵀ of anisotropy `a` under a rotation that varies over the ball,
/// so that stencils are wide (reach grows with a) and change from voxel to voxel.
inline Band anisotropicBall(int radius, double h, double a, double maxAnisotropy = 100) {
    std::vector<BandVoxel> voxels;
    for (int x = -radius; x <= radius; ++x)
        for (int y = -radius; y <= radius; ++y)
            for (int z = -radius; z <= radius; ++z) {
                if (x * x + y * y + z * z > radius * radius) continue;
                const Vec3d p = h * Vec3d(x, y, z);
                const double r = p.norm() / (h * radius);
                BandVoxel v;
                v.coord = openvdb::Coord(x, y, z);
                v.mu = (1.5 - r * r) / h;
                const Mat3d R = (Eigen::AngleAxisd(0.7 + 0.9 * r, Vec3d(1, 2, 3).normalized()) *
                                 Eigen::AngleAxisd(0.4 * x / double(radius), Vec3d::UnitZ()))
                                    .toRotationMatrix();
                v.T = v.mu * R * Vec3d(1.0, 1.0 / (a * a), 1.0 / a).asDiagonal() * R.transpose();
                v.mean = 0.5;
                voxels.push_back(v);
            }
    return bandFromVoxels(std::move(voxels), h, maxAnisotropy).band;
}

/// `ref`'s voxels as if the scene were scaled by `a`: μ and T are densities per unit length, so both become 1/a
/// of their values (build the band with voxel size a h).
inline std::vector<BandVoxel> scaledVoxels(const Band& ref, double a) {
    std::vector<BandVoxel> voxels;
    for (std::size_t i = 0; i < ref.size(); ++i) {
        BandVoxel v;
        v.coord = ref.coord[i];
        v.mu = ref.mu[i] / a;
        const auto& t = ref.T[i];
        v.T << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
        v.T /= a;
        voxels.push_back(v);
    }
    return voxels;
}

inline std::vector<float> randomField(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> U(-1, 1);
    std::vector<float> u(n);
    for (auto& v : u) v = U(rng);
    return u;
}

inline double dot(const std::vector<float>& a, const std::vector<float>& b) {
    double s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) s += double(a[i]) * double(b[i]);
    return s;
}

inline double maxAbs(const std::vector<float>& a) {
    double m = 0;
    for (float v : a) m = std::max(m, double(std::abs(v)));
    return m;
}

}  // namespace gpisvdb::test
