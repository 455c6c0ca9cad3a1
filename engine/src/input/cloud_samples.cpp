#include <algorithm>
#include <cmath>
#include <cstdint>
#include <Eigen/Eigenvalues>
#include <limits>
#include <nanoflann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/morton.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/point_cloud.h"

namespace gpisvdb {

namespace {
struct CloudAdaptor {
    const std::vector<Vec3d>& pts;
    std::size_t kdtree_get_point_count() const { return pts.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][int(d)]; }
    template <class B>
    bool kdtree_get_bbox(B&) const {
        return false;
    }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, CloudAdaptor>, CloudAdaptor, 3, std::size_t>;

/// Point i's area from the points in its cylinder (the rule: cloudSamples' "Local area"); 0 where p_i has no
/// distinct neighbour or no normal. idx, d2 (k + 1 entries) and ball are the caller's scratch.
double cylinderArea(const KdTree& tree, const PointCloud& cloud, std::size_t i, std::size_t k, const CloudNoiseOptions& options,
                    std::vector<std::size_t>& idx, std::vector<double>& d2, std::vector<std::pair<std::size_t, double>>& ball) {
    const Vec3d& p = cloud.positions[i];
    const std::size_t found = tree.knnSearch(p.data(), k + 1, idx.data(), d2.data());
    double R = 2.0 * std::sqrt(d2[found - 1]);
    const double len = cloud.normals[i].norm();
    if (!(R > 0) || !(len > 0)) return 0.0;
    const Vec3d nrm = cloud.normals[i] / len;
    const std::size_t growthLimit = std::size_t(std::max(1, options.areaGrowthPoints)) * k;
    double first = 0;
    for (int doubling = 0;; ++doubling, R *= 2) {
        ball.clear();
        tree.radiusSearch(p.data(), 2.0 * R * R, ball, nanoflann::SearchParams(32, 0, false));
        std::size_t inside = 0;
        Mat3d moment = Mat3d::Zero();
        for (const auto& [j, dist2] : ball) {
            const Vec3d d = cloud.positions[j] - p;
            const double h = d.dot(nrm);
            if (!(std::abs(h) <= R && d.squaredNorm() - h * h <= R * R)) continue;
            ++inside;
            const Vec3d t = d - h * nrm;
            moment += t * t.transpose();
        }
        const double area = M_PI * R * R / double(std::max<std::size_t>(inside, 1));
        if (doubling == 0) first = area;
        // The tangent moments are the two largest eigenvalues of `moment` (its normal one is 0).
        Eigen::SelfAdjointEigenSolver<Mat3d> eig;
        const Eigen::Vector3d ev = eig.computeDirect(moment, Eigen::EigenvaluesOnly).eigenvalues();
        if (ev[1] >= options.areaIsotropy * ev[2]) return area;
        // Never covered (a corner, a strip, an outlier's slice of a distant surface): a larger cylinder would only
        // count more of the same shape, so the first one's area stands.
        if (doubling == options.areaDoublings || inside > growthLimit) return first;
    }
}
}  // namespace

double cloudSamplingBytes(std::size_t points) {
    // Per point: its area and the copy ℓ's trimmed mean sorts (2 doubles), its Morton key and index (16 bytes),
    // the tree's index; nanoflann splits down to leaves of at most 16 points (the tree's parameter below), about
    // half of that on average: 2 n / 8 nodes.
    const double n = double(points), nodes = 2.0 * n / 8.0;
    return 32.0 * n + double(sizeof(std::size_t)) * n + nodes * double(sizeof(KdTree::Node));
}

CloudSamples cloudSamples(const PointCloud& cloud, const CloudNoiseOptions& options) {
    if (!(options.sigmaRel > 0) || !std::isfinite(options.sigmaRel))
        throw ParameterError(
            "the relative noise σ (CloudNoiseOptions::sigmaRel) must be finite and > 0 (got " + numberText(options.sigmaRel) + ")",
            {"CloudNoiseOptions::sigmaRel"});
    if (options.areaDoublings < 0 || options.areaDoublings > 20)
        throw ParameterError("the cylinder's doublings (CloudNoiseOptions::areaDoublings) must be in 0…20 (got " +
                                 std::to_string(options.areaDoublings) + ")",
                             {"CloudNoiseOptions::areaDoublings"});
    if (!(options.areaIsotropy >= 0 && options.areaIsotropy <= 1))
        throw ParameterError(
            "the cylinder's isotropy (CloudNoiseOptions::areaIsotropy) must be in [0, 1] (got " + numberText(options.areaIsotropy) + ")",
            {"CloudNoiseOptions::areaIsotropy"});
    if (options.areaGrowthPoints < 1)
        throw ParameterError("the cylinder's growth limit (CloudNoiseOptions::areaGrowthPoints) must be >= 1 (got " +
                                 std::to_string(options.areaGrowthPoints) + ")",
                             {"CloudNoiseOptions::areaGrowthPoints"});
    const std::size_t n = cloud.positions.size();
    if (n < 2) throw InputError("a point cloud needs at least 2 points (got " + std::to_string(n) + ")");
    if (n > std::numeric_limits<std::uint32_t>::max())
        throw InputError("a point cloud of more than 2^32 points (got " + std::to_string(n) + ")");
    if (cloud.normals.size() != n) throw InputError("the point cloud has no normals (need nx ny nz per point)");
    for (std::size_t i = 0; i < n; ++i)
        if (!(cloud.normals[i].norm() > 0)) throw InputError("point " + std::to_string(i + 1) + " has a zero normal");
    if (!cloud.normalCovariances.empty() && cloud.normalCovariances.size() != n)
        throw InputError("the point cloud has " + std::to_string(cloud.normalCovariances.size()) + " normal covariances for " +
                         std::to_string(n) + " points");
    if (!cloud.positionVariances.empty() && cloud.positionVariances.size() != n)
        throw InputError("the point cloud has " + std::to_string(cloud.positionVariances.size()) + " position variances for " +
                         std::to_string(n) + " points");
    if (!(cloud.lengthScale >= 0) || !std::isfinite(cloud.lengthScale))
        throw InputError("the point cloud's given length scale must be finite and > 0");
    if (!cloud.areas.empty()) {
        if (cloud.areas.size() != n)
            throw InputError("the point cloud has " + std::to_string(cloud.areas.size()) + " areas for " + std::to_string(n) + " points");
        for (std::size_t i = 0; i < n; ++i)
            if (!(cloud.areas[i] >= 0) || !std::isfinite(cloud.areas[i]))
                throw InputError("point " + std::to_string(i + 1) + " has an area that is not a finite number >= 0");
    }

    // === Local area. a_i = π R² / (points in the cylinder of radius R and half-height R around p_i along n_i),
    // R = 2 × the distance to the k-th neighbour. The cylinder counts the whole thickness of a noisy cloud, so the
    // estimate is of the surface density even when the position noise exceeds the spacing (a 3D ball count would
    // over-estimate areas there). Scan lines (dense along, sparse across) put every one of the k neighbours on
    // p_i's own line, and so does the cylinder while R is below the lines' spacing: its points then lie along one
    // direction of the tangent disc, the count is of a line and the area is too small. R doubles (at most
    // `areaDoublings` times, and while it holds at most areaGrowthPoints × k points) until the points' second
    // moments about p_i in the tangent plane, which are equal (R²/4 each) for a covered disc and for a half disc at
    // a boundary, differ by at most 1/areaIsotropy; a cylinder that never gets there keeps its first area.
    CloudAdaptor adaptor{cloud.positions};
    KdTree tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    if (cloud.areas.empty()) tree.buildIndex();  // given areas need no neighbours
    const std::size_t k = std::min<std::size_t>(std::size_t(std::max(1, options.areaNeighbours)), n - 1);
    std::vector<double> area(cloud.areas.empty() ? n : 0);
    // Neighbours visited together: the tree's nodes stay in cache (docs/benchmarks.md#length-scale).
    const auto order = area.empty() ? decltype(detail::mortonSorted(cloud.positions)){} : detail::mortonSorted(cloud.positions);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, area.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<std::size_t> idx(k + 1);
        std::vector<double> d2(k + 1);
        std::vector<std::pair<std::size_t, double>> ball;
        for (std::size_t j = r.begin(); j < r.end(); ++j) {
            const std::size_t i = order[j].second;
            area[i] = cylinderArea(tree, cloud, i, k, options, idx, d2, ball);
        }
    });
    const std::vector<double>& pointArea = cloud.areas.empty() ? area : cloud.areas;

    // === Length scale ℓ = √(A / N), A the cloud's area: the spacing of the surface, whatever the sampling's
    // pattern (a regular grid's and a random cloud's of the same density are equal; scan lines give the geometric
    // mean of their two spacings). A is the sum of the areas (given or estimated) of all but the largest 1 %,
    // whose share stands for them: an outlier's area is that of the empty disc around it.
    std::vector<double> areas = pointArea;
    const std::size_t kept = n - n / 100;
    std::nth_element(areas.begin(), areas.begin() + std::ptrdiff_t(kept - 1), areas.end());
    double keptArea = 0;
    for (std::size_t i = 0; i < kept; ++i) keptArea += areas[i];
    const double ell = cloud.lengthScale > 0 ? cloud.lengthScale : std::sqrt(keptArea / double(kept));
    if (!(ell > 0) || !std::isfinite(ell))
        throw InputError(cloud.areas.empty() ? "all points of the cloud coincide" : "the point cloud's areas are all 0 (or all but 1 %)");

    CloudSamples out;
    out.sigma = options.sigmaRel * ell;
    Samples& S = out.samples;
    S.lengthScale = ell;
    S.position.reserve(n);  // exactly: what samplesBytes counts, not up to twice that
    S.normal.reserve(n);
    S.positionVariance.reserve(n);
    S.normalCovariance.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3d nrm = cloud.normals[i].normalized();
        const double a = pointArea[i];
        const double sigma = cloud.sigmas.empty() ? out.sigma : cloud.sigmas[i];
        const double variance = cloud.positionVariances.empty() ? sigma * sigma : cloud.positionVariances[i];
        if (!(variance > 0)) throw InputError("point " + std::to_string(i + 1) + " has sigma <= 0");
        // Σ' = a² τ² (I − n nᵀ), τ = σ/√a (normal-angle std = position std over the local spacing)
        const double tau2a2 = a * variance;
        S.position.push_back(cloud.positions[i]);
        S.normal.push_back(cloud.vectorAreas ? cloud.normals[i] : a * nrm);
        S.positionVariance.push_back(variance);
        S.normalCovariance.push_back(cloud.normalCovariances.empty() ? Sym3::from(tau2a2 * (Mat3d::Identity() - nrm * nrm.transpose()))
                                                                     : cloud.normalCovariances[i]);
    }
    return out;
}

}  // namespace gpisvdb
