#pragma once
// A deterministic quasi-Monte-Carlo rule for expectations over N(0, I₃) (docs/math.md#kac-rice): the first S points of
// the 3D Sobol sequence (Joe–Kuo direction numbers), shifted to the centres of their cells and mapped through
// the inverse normal CDF. Built once, shared by every evaluation.
#include <vector>

#include "gpisvdb/core/types.h"

namespace gpisvdb {

class QmcRule {
public:
    /// S ≥ 1 points; powers of two keep the Sobol net balanced.
    explicit QmcRule(int samples = 512);
    const std::vector<Vec3d>& points() const { return points_; }
    int size() const { return int(points_.size()); }
    /// The same points by coordinate (coordinate(d)[i] = points()[i][d]), zero-padded to a multiple of 8 entries
    /// for SIMD loops; weight()[i] is 1 for a point, 0 for padding.
    const std::vector<double>& coordinate(int d) const { return coordinate_[d]; }
    const std::vector<double>& weight() const { return weight_; }

private:
    std::vector<Vec3d> points_;
    std::vector<double> coordinate_[3];
    std::vector<double> weight_;
};

}  // namespace gpisvdb
