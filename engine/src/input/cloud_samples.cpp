#include <cmath>
#include <nanoflann.hpp>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/point_cloud.h"

namespace gpisvdb {

namespace {
struct CloudAdaptor {
    const std::vector<Vec3d>& pts;
    std::size_t kdtree_get_point_count() const { return pts.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][int(d)]; }
    template <class B>
    bool kdtree_get_bbox(B&) const { return false; }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, CloudAdaptor>,
                                                   CloudAdaptor, 3, std::size_t>;
}  // namespace

double cloudSamplingBytes(std::size_t points) {
    // nanoflann splits down to leaves of at most 16 points (the tree's parameter below), about half of that on
    // average: 2 n / 8 nodes
    const double n = double(points), nodes = 2.0 * n / 8.0;
    return 16.0 * n + double(sizeof(std::size_t)) * n + nodes * double(sizeof(KdTree::Node));
}

CloudSamples cloudSamples(const PointCloud& cloud, const CloudNoiseOptions& options) {
    if (!(options.sigmaRel > 0) || !std::isfinite(options.sigmaRel))
        throw ParameterError("the relative noise σ (CloudNoiseOptions::sigmaRel) must be finite and > 0 (got " +
                                 numberText(options.sigmaRel) + ")",
                             {"CloudNoiseOptions::sigmaRel"});
    const std::size_t n = cloud.positions.size();
    if (n < 2) throw InputError("a point cloud needs at least 2 points (got " + std::to_string(n) + ")");
    if (cloud.normals.size() != n) throw InputError("the point cloud has no normals (need nx ny nz per point)");

    // === Local spacing. ℓ: mean nearest-neighbour distance. Area: a_i = π R² / (points in the cylinder of
    // radius R and half-height R around p_i along n_i), R = 2 × the distance to the k-th neighbour. The
    // cylinder counts the whole thickness of a noisy cloud, so the estimate is of the surface density even
    // when the position noise exceeds the spacing (a 3D ball count would over-estimate areas there).
    CloudAdaptor adaptor{cloud.positions};
    KdTree tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    tree.buildIndex();
    const std::size_t k = std::min<std::size_t>(std::size_t(std::max(1, options.areaNeighbours)), n - 1);
    std::vector<double> area(n), nearest(n);
    std::vector<std::size_t> idx(k + 1);
    std::vector<double> d2(k + 1);
    std::vector<std::pair<std::size_t, double>> ball;
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3d& p = cloud.positions[i];
        const std::size_t found = tree.knnSearch(p.data(), k + 1, idx.data(), d2.data());
        // The first hit is the point itself (distance 0); duplicates also show as 0.
        nearest[i] = found > 1 ? std::sqrt(d2[1]) : 0.0;
        const double R = 2.0 * std::sqrt(d2[found - 1]);
        const double len = cloud.normals[i].norm();
        if (!(R > 0) || !(len > 0)) continue;
        const Vec3d nrm = cloud.normals[i] / len;
        ball.clear();
        tree.radiusSearch(p.data(), 2.0 * R * R, ball, nanoflann::SearchParams(32, 0, false));
        std::size_t inside = 0;
        for (const auto& [j, dist2] : ball) {
            const Vec3d d = cloud.positions[j] - p;
            const double h = d.dot(nrm);
            if (std::abs(h) <= R && d.squaredNorm() - h * h <= R * R) ++inside;
        }
        area[i] = M_PI * R * R / double(std::max<std::size_t>(inside, 1));
    }
    double ell = 0;
    for (double d : nearest) ell += d;
    ell /= double(n);
    if (!(ell > 0)) throw InputError("all points of the cloud coincide");

    CloudSamples out;
    out.sigma = options.sigmaRel * ell;
    Samples& S = out.samples;
    S.lengthScale = ell;
    S.position.reserve(n);  // exactly: what samplesBytes counts, not up to twice that
    S.normal.reserve(n);
    S.positionVariance.reserve(n);
    S.normalCovariance.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double len = cloud.normals[i].norm();
        if (!(len > 0)) throw InputError("point " + std::to_string(i + 1) + " has a zero normal");
        const Vec3d nrm = cloud.normals[i] / len;
        const double a = cloud.areas.empty() ? area[i] : cloud.areas[i];
        const double sigma = cloud.sigmas.empty() ? out.sigma : cloud.sigmas[i];
        if (!(sigma > 0)) throw InputError("point " + std::to_string(i + 1) + " has sigma <= 0");
        // Σ' = a² τ² (I − n nᵀ), τ = σ/√a (normal-angle std = position std over the local spacing)
        const double tau2a2 = a * sigma * sigma;
        S.position.push_back(cloud.positions[i]);
        S.normal.push_back(a * nrm);
        S.positionVariance.push_back(sigma * sigma);
        S.normalCovariance.push_back(Sym3::from(tau2a2 * (Mat3d::Identity() - nrm * nrm.transpose())));
    }
    return out;
}

}  // namespace gpisvdb
