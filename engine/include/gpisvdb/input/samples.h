#pragma once
// The GPIS input (docs/math.md#samples): oriented samples with Gaussian noise on positions and vector areas.
#include <string>
#include <vector>

#include "gpisvdb/core/types.h"

namespace gpisvdb {

/// The default noise σ of vertices and points without their own, relative to the length scale ℓ (docs/math.md).
constexpr double kDefaultSigmaRel = 0.5;

/// Symmetric 3×3 stored as (xx, yy, zz, xy, xz, yz).
struct Sym3 {
    double xx = 0, yy = 0, zz = 0, xy = 0, xz = 0, yz = 0;
    Mat3d matrix() const {
        Mat3d m;
        m << xx, xy, xz, xy, yy, yz, xz, yz, zz;
        return m;
    }
    static Sym3 from(const Mat3d& m) { return {m(0, 0), m(1, 1), m(2, 2), m(0, 1), m(0, 2), m(1, 2)}; }
    double trace() const { return xx + yy + zz; }
};

struct Samples {
    std::vector<Vec3d> position;           ///< p_i, world units
    std::vector<Vec3d> normal;             ///< w_i, vector area (outward), world units²
    std::vector<double> positionVariance;  ///< Σ_i = v_i I (isotropic for both noise models), world units²
    std::vector<Sym3> normalCovariance;    ///< Σ'_i, world units⁴
    double lengthScale = 0;                ///< ℓ, world units: mean edge length (soup) or √(area / points) (cloud)

    std::size_t size() const { return position.size(); }
};

/// Bytes a Samples of n samples holds, its vectors reserved exactly: position and normal (Vec3d), the position
/// variance (double) and the normal covariance (Sym3, 6 doubles): 104 B per sample.
double samplesBytes(std::size_t n);

}  // namespace gpisvdb
