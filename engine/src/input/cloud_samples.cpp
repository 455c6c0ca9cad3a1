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

CloudSamples cloudSamples(const PointCloud& cloud, const CloudNoiseOptions& options) {
    if (!(options.sigmaRel > 0) || !std::isfinite(options.sigmaRel))
        throw ParameterError("--sigma must be finite and > 0 (got " + std::to_string(options.sigmaRel) + ")");
    const std::size_t n = cloud.positions.size();
    if (n < 2) throw InputError("a point cloud needs at least 2 points (got " + std::to_string(n) + ")");
    if (cloud.normals.size() != n) throw InputError("the point cloud has no normals (need nx ny nz per point)");

    // === Local spacing: nearest neighbour (ℓ) and k-th neighbour (area a_i = π r_k² / k)
    CloudAdaptor adaptor{cloud.positions};
    KdTree tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    tree.buildIndex();
    const std::size_t k = std::min<std::size_t>(std::size_t(std::max(1, options.areaNeighbours)), n - 1);
    std::vector<double> area(n), nearest(n);
    std::vector<std::size_t> idx(k + 1);
    std::vector<double> d2(k + 1);
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t found = tree.knnSearch(cloud.positions[i].data(), k + 1, idx.data(), d2.data());
        // The first hit is the point itself (distance 0); duplicates also show as 0.
        nearest[i] = found > 1 ? std::sqrt(d2[1]) : 0.0;
        area[i] = found > 1 ? M_PI * d2[found - 1] / double(found - 1) : 0.0;
    }
    double ell = 0;
    for (double d : nearest) ell += d;
    ell /= double(n);
    if (!(ell > 0)) throw InputError("all points of the cloud coincide");

    CloudSamples out;
    out.sigma = options.sigmaRel * ell;
    Samples& S = out.samples;
    S.lengthScale = ell;
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
