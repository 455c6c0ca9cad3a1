#include "gpisvdb/solve/geodesic_path.h"

#include <cmath>
#include <limits>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// U and the upwind flow V around a point, in index space (voxel k centred at q = k).
class Flow {
public:
    Flow(const Band& band, const std::vector<double>& U) : band_(band), U_(U), acc_(band.index->getConstAccessor()) {}

    std::int32_t voxel(const openvdb::Coord& c) { return acc_.getValue(c); }
    double u(std::int32_t i) const { return i >= 0 ? U_[std::size_t(i)] : kInf; }

    /// V(x_i) = Σ_k λ_k max(0, U(x_i) − U(x_i ± e_k)) (±e_k): towards the smaller neighbour of each term.
    Vec3d at(std::size_t i) {
        const VoxelStencil& st = band_.stencil[i];
        const openvdb::Coord c = band_.coord[i];
        const double ui = U_[i];
        Vec3d v = Vec3d::Zero();
        for (int k = 0; k < st.count; ++k) {
            const auto& o = st.offset[std::size_t(k)];
            const openvdb::Coord e(o[0], o[1], o[2]);
            const Vec3d ev(o[0], o[1], o[2]);
            const double plus = ui - u(voxel(c + e)), minus = ui - u(voxel(c - e));
            const double lambda = st.weight[std::size_t(k)];
            if (plus >= minus && plus > 0) v += lambda * plus * ev;
            else if (minus > 0) v -= lambda * minus * ev;
        }
        return v;
    }

    struct Sample {
        bool valid = false;       ///< some corner of the cell holds a finite U
        double u = kInf;          ///< trilinear U over the valid corners (weights renormalised)
        Vec3d v = Vec3d::Zero();  ///< trilinear V likewise
        std::int32_t seed = -1;   ///< a corner with U = 0 (lowest index), or −1
    };

    Sample sample(const Vec3d& q) {
        Sample s;
        const Vec3d base = q.array().floor();
        const Vec3d f = q - base;
        const openvdb::Coord b(int(base.x()), int(base.y()), int(base.z()));
        double weightSum = 0, uSum = 0;
        Vec3d vSum = Vec3d::Zero();
        for (int corner = 0; corner < 8; ++corner) {
            const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
            const std::int32_t i = voxel(b.offsetBy(dx, dy, dz));
            const double ui = u(i);
            if (!std::isfinite(ui)) continue;
            if (ui == 0 && (s.seed < 0 || i < s.seed)) s.seed = i;
            const double w = (dx ? f.x() : 1 - f.x()) * (dy ? f.y() : 1 - f.y()) * (dz ? f.z() : 1 - f.z());
            if (w <= 0) continue;
            weightSum += w;
            uSum += w * ui;
            vSum += w * at(std::size_t(i));
        }
        if (weightSum > 0) s.valid = true, s.u = uSum / weightSum, s.v = vSum / weightSum;
        return s;
    }

    /// The lowest-U band voxel among the cell's corners and their stencil neighbours (ties: lowest index).
    std::int32_t lowestNear(const Vec3d& q) {
        const Vec3d base = q.array().floor();
        const openvdb::Coord b(int(base.x()), int(base.y()), int(base.z()));
        std::int32_t best = -1;
        auto consider = [&](std::int32_t i) {
            if (i >= 0 && std::isfinite(u(i)) && (best < 0 || u(i) < u(best) || (u(i) == u(best) && i < best))) best = i;
        };
        for (int corner = 0; corner < 8; ++corner) {
            const openvdb::Coord c = b.offsetBy(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            const std::int32_t i = voxel(c);
            if (i < 0) continue;
            consider(i);
            const VoxelStencil& st = band_.stencil[std::size_t(i)];
            for (int k = 0; k < st.count; ++k) {
                const auto& o = st.offset[std::size_t(k)];
                const openvdb::Coord e(o[0], o[1], o[2]);
                consider(voxel(c + e));
                consider(voxel(c - e));
            }
        }
        return best;
    }

private:
    const Band& band_;
    const std::vector<double>& U_;
    openvdb::Int32Grid::ConstAccessor acc_;
};

Vec3d centre(const Band& band, std::size_t i) {
    const openvdb::Coord& c = band.coord[i];
    return Vec3d(c.x(), c.y(), c.z());
}

}  // namespace

GeodesicPath backtrack(const Band& band, const std::vector<double>& U, std::size_t target, const BacktrackOptions& options) {
    if (U.size() != band.size()) throw ParameterError("the distance does not match the band");
    if (target >= band.size()) throw ParameterError("a path target is not a band voxel");
    if (!(options.step > 0) || !(options.step <= 1)) throw ParameterError("the path step must be in (0, 1] voxels");
    const double h = band.voxelSize;
    GeodesicPath path;
    Vec3d q = centre(band, target);  // index space
    path.distance = U[target];
    path.points.push_back(h * q);
    path.values.push_back(U[target]);
    if (!std::isfinite(U[target])) return path;  // not reached by the march

    std::size_t cap = options.maxSteps;
    if (cap == 0) {
        const openvdb::Coord extent = band.bbox().dim();
        cap = std::size_t(64.0 * double(extent.x() + extent.y() + extent.z()) / options.step);
    }
    Flow flow(band, U);
    auto advance = [&](const Vec3d& next, double u) {
        path.length += h * (next - q).norm();
        q = next;
        path.points.push_back(h * q);
        path.values.push_back(u);
    };
    for (std::size_t n = 0; n < cap; ++n) {
        const Flow::Sample here = flow.sample(q);
        // === At a source: end at its centre
        if (here.seed >= 0) {
            if (here.u > 0) advance(centre(band, std::size_t(here.seed)), 0.0);
            path.source = std::size_t(here.seed);
            path.reachedSource = true;
            return path;
        }
        // === Heun step along V/‖V‖, halved while U does not decrease
        bool moved = false;
        if (here.valid && here.v.norm() > 0) {
            const Vec3d d1 = here.v.normalized();
            for (double s = options.step; !moved && s >= options.step / 8; s /= 2) {
                const Flow::Sample mid = flow.sample(q + s * d1);
                const Vec3d d2 = mid.valid && mid.v.norm() > 0 ? Vec3d((d1 + mid.v.normalized()).normalized()) : d1;
                if (!d2.allFinite()) continue;
                const Vec3d next = q + s * d2;
                const Flow::Sample there = flow.sample(next);
                if (there.valid && there.u < here.u) advance(next, there.u), moved = true;
            }
        }
        // === Otherwise the lowest voxel nearby: one is lower than here, since here is a mean of corner values and
        // every reached voxel but a source has a stencil neighbour with a smaller U
        if (!moved) {
            const std::int32_t low = flow.lowestNear(q);
            if (low < 0 || !(U[std::size_t(low)] < here.u)) return path;  // stalled
            advance(centre(band, std::size_t(low)), U[std::size_t(low)]);
        }
    }
    return path;  // step cap
}

}  // namespace gpisvdb
