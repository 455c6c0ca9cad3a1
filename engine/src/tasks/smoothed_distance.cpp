#include "gpisvdb/tasks/smoothed_distance.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {
constexpr int kLeafSize = 8;

/// A node of the k-d tree.
struct TreeNode {
    Vec3d lo, hi;       // box of the node's points
    Vec3d centre;       // weighted centroid c
    double radius = 0;  // max ‖x_j − c‖
    double weight = 0;  // Σ μ h³
    int begin = 0, end = 0;
    int left = -1, right = -1;
};

/// Nodes of the tree over n points, split at the middle until a node holds at most kLeafSize. A level's sizes
/// differ by at most one, so memoising them takes O(log n) calls.
double treeNodes(std::size_t n, std::map<std::size_t, double>& memo) {
    if (n <= std::size_t(kLeafSize)) return 1;
    if (const auto it = memo.find(n); it != memo.end()) return it->second;
    return memo[n] = 1 + treeNodes(n / 2, memo) + treeNodes(n - n / 2, memo);
}
}  // namespace

struct SmoothedDistance::Impl {
    using Node = TreeNode;
    double alpha = 0;
    double totalWeight = 0;
    std::vector<Vec3d> point;    // voxel centres, tree order
    std::vector<double> weight;  // μ h³, tree order
    std::vector<Node> nodes;

    int build(int begin, int end) {
        Node n;
        n.begin = begin;
        n.end = end;
        n.lo = n.hi = point[std::size_t(begin)];
        n.centre = Vec3d::Zero();
        for (int i = begin; i < end; ++i) {
            n.lo = n.lo.cwiseMin(point[std::size_t(i)]);
            n.hi = n.hi.cwiseMax(point[std::size_t(i)]);
            n.weight += weight[std::size_t(i)];
            n.centre += weight[std::size_t(i)] * point[std::size_t(i)];
        }
        n.centre = n.weight > 0 ? Vec3d(n.centre / n.weight) : Vec3d(0.5 * (n.lo + n.hi));
        for (int i = begin; i < end; ++i) n.radius = std::max(n.radius, (point[std::size_t(i)] - n.centre).norm());
        const int id = int(nodes.size());
        nodes.push_back(n);
        if (end - begin <= kLeafSize) return id;
        // Median split along the longest side; ties broken by the original order (stable), so the tree is fixed.
        int axis = 0;
        (n.hi - n.lo).maxCoeff(&axis);
        const int mid = (begin + end) / 2;
        {  // freed before the children are built: otherwise every level's copies (36 B per point) stay alive
            std::vector<int> order(std::size_t(end - begin));
            std::iota(order.begin(), order.end(), begin);
            std::stable_sort(order.begin(), order.end(),
                             [&](int a, int b) { return point[std::size_t(a)][axis] < point[std::size_t(b)][axis]; });
            std::vector<Vec3d> p(order.size());
            std::vector<double> w(order.size());
            for (std::size_t k = 0; k < order.size(); ++k) {
                p[k] = point[std::size_t(order[k])];
                w[k] = weight[std::size_t(order[k])];
            }
            std::copy(p.begin(), p.end(), point.begin() + begin);
            std::copy(w.begin(), w.end(), weight.begin() + begin);
        }
        const int left = build(begin, mid);
        const int right = build(mid, end);
        nodes[std::size_t(id)].left = left;
        nodes[std::size_t(id)].right = right;
        return id;
    }

    static double nearDistance(const Node& n, const Vec3d& x) { return (n.lo - x).cwiseMax(x - n.hi).cwiseMax(0.0).norm(); }
    static double farDistance(const Node& n, const Vec3d& x) { return (x - n.lo).cwiseAbs().cwiseMax((x - n.hi).cwiseAbs()).norm(); }

    /// min_j ‖x − x_j‖ by a nearest-first descent with box pruning.
    double nearest(const Vec3d& x) const {
        double best = std::numeric_limits<double>::infinity();
        int stack[128];
        int top = 0;
        stack[top++] = 0;
        while (top) {
            const Node& n = nodes[std::size_t(stack[--top])];
            if (nearDistance(n, x) >= best) continue;
            if (n.left < 0) {
                for (int i = n.begin; i < n.end; ++i) best = std::min(best, (point[std::size_t(i)] - x).norm());
                continue;
            }
            const Node &a = nodes[std::size_t(n.left)], &b = nodes[std::size_t(n.right)];
            const bool leftFirst = nearDistance(a, x) <= nearDistance(b, x);
            stack[top++] = leftFirst ? n.right : n.left;  // the nearer child is popped first
            stack[top++] = leftFirst ? n.left : n.right;
        }
        return best;
    }
};

SmoothedDistance::SmoothedDistance(const Band& band, double alpha) : impl_(std::make_unique<Impl>()) {
    if (!(alpha > 0) || !std::isfinite(alpha))
        throw ParameterError("the sharpness α (SmoothedDistanceOptions::alpha) must be finite and > 0 (world units^-1)",
                             {"SmoothedDistanceOptions::alpha"});
    if (band.size() == 0) throw Error("smoothed distance: the band is empty");
    const double h3 = std::pow(band.voxelSize, 3);
    impl_->alpha = alpha;
    impl_->point.resize(band.size());
    impl_->weight.resize(band.size());
    for (std::size_t i = 0; i < band.size(); ++i) {
        const openvdb::Coord& k = band.coord[i];
        impl_->point[i] = band.voxelSize * Vec3d(k.x(), k.y(), k.z());
        impl_->weight[i] = double(band.mu[i]) * h3;
        impl_->totalWeight += impl_->weight[i];
    }
    std::map<std::size_t, double> memo;
    impl_->nodes.reserve(std::size_t(treeNodes(band.size(), memo)));  // exactly: no growth by doubling
    impl_->build(0, int(band.size()));
}

SmoothedDistance::~SmoothedDistance() = default;
SmoothedDistance::SmoothedDistance(SmoothedDistance&&) noexcept = default;
double SmoothedDistance::alpha() const { return impl_->alpha; }

double SmoothedDistance::exact(const Vec3d& x) const {
    const Impl& m = *impl_;
    const double dStar = m.nearest(x);
    double s = 0;
    for (std::size_t i = 0; i < m.point.size(); ++i) s += m.weight[i] * std::exp(-m.alpha * ((m.point[i] - x).norm() - dStar));
    return dStar - std::log(s) / m.alpha;
}

double SmoothedDistance::at(const Vec3d& x, double tolerance, std::size_t* terms) const {
    if (!(tolerance > 0)) throw ParameterError("smoothed distance: the tolerance must be > 0");
    const Impl& m = *impl_;
    const double alpha = m.alpha;
    const double dStar = m.nearest(x);
    const double q = std::exp(-alpha * tolerance);
    const double eps = (1.0 - q) / (2.0 - q);
    double s = 0;
    std::size_t count = 0;
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    const auto pushChildren = [&](const Impl::Node& n) {  // a leaf's terms, or its children nearest first
        if (n.left < 0) {
            for (int i = n.begin; i < n.end; ++i)
                s += m.weight[std::size_t(i)] * std::exp(-alpha * ((m.point[std::size_t(i)] - x).norm() - dStar));
            count += std::size_t(n.end - n.begin);
            return;
        }
        const bool leftFirst = Impl::nearDistance(m.nodes[std::size_t(n.left)], x) <= Impl::nearDistance(m.nodes[std::size_t(n.right)], x);
        stack[top++] = leftFirst ? n.right : n.left;
        stack[top++] = leftFirst ? n.left : n.right;
    };
    while (top) {
        const Impl::Node& n = m.nodes[std::size_t(stack[--top])];
        // === Collapse when one term errs by at most ε/2 of (its own value + its weight's share of the sum so far):
        //     over all collapsed nodes that is at most ε S, S the final computed sum.
        const double share = s * n.weight / m.totalWeight;
        //     (i) at the centroid: Σ w f(x_j) − W f(c) = Σ w (f(x_j) − f(c) − ∇f(c)·(x_j − c)), at most ½ W r² max‖D²f‖
        //     over the node's ball, ‖D²f‖ = f max(α², α/ρ) for f = e^{−αρ}, ρ ≥ ‖x − c‖ − r.
        const double dc = (n.centre - x).norm(), rho = dc - n.radius;
        // (An exponent above 600 marks a node far wider than 1/α: never collapsible, and e^x would overflow.)
        if (rho > 0 && alpha * (dStar - rho) < 600) {
            const double fc = n.weight * std::exp(-alpha * (dc - dStar));
            const double bound =
                0.5 * n.weight * n.radius * n.radius * std::exp(-alpha * (rho - dStar)) * std::max(alpha * alpha, alpha / rho);
            if (bound <= 0.5 * eps * (fc + share)) {
                s += fc;
                ++count;
                continue;
            }
        }
        //     (ii) the middle of [W e^{−αb}, W e^{−αa}], a and b the distances to the node's box.
        const double a = Impl::nearDistance(n, x), b = Impl::farDistance(n, x);
        if (alpha * (dStar - a) >= 600) {
            pushChildren(n);
            continue;
        }
        const double hi = n.weight * std::exp(-alpha * (a - dStar)), lo = n.weight * std::exp(-alpha * (b - dStar));
        if (0.5 * (hi - lo) <= 0.5 * eps * (0.5 * (hi + lo) + share)) {
            s += 0.5 * (hi + lo);
            ++count;
            continue;
        }
        pushChildren(n);
    }
    if (terms) *terms = count;
    return dStar - std::log(s) / alpha;
}

DistanceGridShape smoothedDistanceGridShape(const Band& band, const SmoothedDistanceOptions& o) {
    // === The grid: the band's box plus padding, voxel size H
    const openvdb::CoordBBox box = band.bbox();
    const Vec3d lo = band.voxelSize * Vec3d(box.min().x(), box.min().y(), box.min().z());
    const Vec3d hi = band.voxelSize * Vec3d(box.max().x(), box.max().y(), box.max().z());
    const double side = (hi - lo).maxCoeff();
    const double pad = o.padding >= 0 ? o.padding : 0.1 * side;
    if (!std::isfinite(pad))
        throw ParameterError("the grid padding (SmoothedDistanceOptions::padding) must be finite", {"SmoothedDistanceOptions::padding"});
    if (o.gridVoxelSize < 0 || !std::isfinite(o.gridVoxelSize))
        throw ParameterError("the grid voxel size H (SmoothedDistanceOptions::gridVoxelSize) must be finite and > 0",
                             {"SmoothedDistanceOptions::gridVoxelSize"});
    const double H = o.gridVoxelSize > 0 ? o.gridVoxelSize : (side + 2 * pad) / 128.0;
    if (!(H > 0) || !std::isfinite(H))
        throw ParameterError("the grid voxel size H (SmoothedDistanceOptions::gridVoxelSize) must be finite and > 0",
                             {"SmoothedDistanceOptions::gridVoxelSize"});
    DistanceGridShape shape;
    Eigen::Vector3d last;
    for (int c = 0; c < 3; ++c) {
        shape.first[c] = std::floor((lo[c] - pad) / H);
        last[c] = std::ceil((hi[c] + pad) / H);
    }
    shape.count = last - shape.first + Vec3d::Ones();
    shape.voxelSize = H;
    shape.points = shape.count.prod();
    return shape;
}

std::vector<std::pair<std::string, double>> smoothedDistanceBytes(const Band& band, const SmoothedDistanceOptions& o, bool levelCopy) {
    const DistanceGridShape shape = smoothedDistanceGridShape(band, o);
    const double n = double(band.size());
    std::map<std::size_t, double> memo;
    // The tree: each voxel's centre (Vec3d) and weight (double), its nodes (reserved exactly); while it is built, the
    // top level's sort order (int), centres and weights copied in that order (36 B per voxel)
    const double tree = 32.0 * n + treeNodes(band.size(), memo) * double(sizeof(TreeNode));
    const double build = 36.0 * n;
    // The dense grid: its leaves (8³ floats) and the internal nodes above them (16³ and 32³ children), along each
    // axis those the points [first, first + count) touch
    const auto spanned = [&](double width) {
        double nodes = 1;
        for (int c = 0; c < 3; ++c)
            nodes *= std::floor((shape.first[c] + shape.count[c] - 1) / width) - std::floor(shape.first[c] / width) + 1;
        return nodes;
    };
    using Tree = openvdb::FloatTree;
    using Leaf = Tree::LeafNodeType;
    using Lower = Tree::RootNodeType::ChildNodeType::ChildNodeType;
    using Upper = Tree::RootNodeType::ChildNodeType;
    const double leafBytes = double(sizeof(Leaf) + Leaf::SIZE * sizeof(float));  // the node and its block of values
    const double grid =
        spanned(Leaf::DIM) * leafBytes + spanned(Lower::DIM) * double(sizeof(Lower)) + spanned(Upper::DIM) * double(sizeof(Upper));
    const double values = 4.0 * shape.points;  // float per point while they are computed
    // The larger of: the tree's build; the evaluation (the tree, the values, the grid they are copied into); the
    // command's level set (a copy of the grid beside it)
    const double evaluation = tree + values + grid;
    if (levelCopy && 2 * grid > std::max(evaluation, tree + build)) return {{"grid", grid}, {"level_set_copy", grid}};
    if (tree + build > evaluation) return {{"kd_tree", tree}, {"kd_tree_build", build}};
    return {{"kd_tree", tree}, {"values", values}, {"grid", grid}};
}

double smoothedDistanceGridVoxelSizeWithin(const Band& band, const SmoothedDistanceOptions& o, bool levelCopy, double bytes) {
    SmoothedDistanceOptions t = o;
    t.gridVoxelSize = smoothedDistanceGridShape(band, o).voxelSize;
    double last = -1;
    for (int step = 0; step < 5000; ++step, t.gridVoxelSize *= 1.02) {
        double need = 0;
        for (const auto& [name, b] : smoothedDistanceBytes(band, t, levelCopy)) need += b;
        if (need <= bytes) return t.gridVoxelSize;
        const double points = smoothedDistanceGridShape(band, t).points;
        if (points == last && points <= 8) return 0;  // a grid of one or two points along each axis: only the tree is left
        last = points;
    }
    return 0;
}

SmoothedDistanceResult smoothedDistanceGrid(const Band& band, const SmoothedDistanceOptions& o, const Progress& progress) {
    if (band.size() == 0) throw Error("smoothed distance: the band is empty");
    const DistanceGridShape shape = smoothedDistanceGridShape(band, o);
    const Vec3d first = shape.first, count = shape.count;
    const double H = shape.voxelSize, points = shape.points;
    constexpr double kMaxPoints = 2147483648.0;  // 2^31: the points are counted in int
    if (!(points <= kMaxPoints) || (count.array() > 2e9).any())
        throw MemoryLimitError("the distance grid would hold " + numberText(points) + " points at grid voxel size H = " + numberText(H) +
                                   ", more than " + numberText(kMaxPoints) +
                                   ": use a grid voxel size (SmoothedDistanceOptions::gridVoxelSize) of " +
                                   numberText(H * std::cbrt(points / kMaxPoints) * 1.01) + " or larger",
                               {"SmoothedDistanceOptions::gridVoxelSize"});
    if (o.maxBytes > 0) {
        // The peak as the command estimates it (docs/memory.md#distance)
        double need = 0;
        for (const auto& [name, bytes] : smoothedDistanceBytes(band, o, false)) need += bytes;
        if (need > o.maxBytes) {
            const std::string what = "the distance grid at grid voxel size H = " + numberText(H) + " needs about " +
                                     numberText(need / 1e6) +
                                     " MB (the k-d tree over the band's voxels, the values and the dense grid), more than the " +
                                     numberText(o.maxBytes / 1e6) + " MB allowed (SmoothedDistanceOptions::maxBytes): ";
            if (const double fits = smoothedDistanceGridVoxelSizeWithin(band, o, false, o.maxBytes); fits > 0)
                throw MemoryLimitError(
                    what + "use a grid voxel size (SmoothedDistanceOptions::gridVoxelSize) of " + numberText(fits * 1.001) + " or larger",
                    {"SmoothedDistanceOptions::maxBytes", "SmoothedDistanceOptions::gridVoxelSize"});
            throw MemoryLimitError(what +
                                       "no grid voxel size fits beside the k-d tree over the band's voxels and the grid's top-level "
                                       "nodes: use a coarser voxel size (BandOptions::voxelSize) or raise the limit",
                                   {"SmoothedDistanceOptions::maxBytes", "BandOptions::voxelSize"});
        }
    }
    const double tol = o.tolerance > 0 ? o.tolerance : 1e-2 * H;
    if (!std::isfinite(tol))
        throw ParameterError("the distance tolerance (SmoothedDistanceOptions::tolerance) must be finite and > 0",
                             {"SmoothedDistanceOptions::tolerance"});

    const SmoothedDistance field(band, o.alpha);  // after the checks: a refused grid builds no tree

    // === Evaluate, in slabs of z so that progress and Ctrl-C stay on the calling thread
    const int nx = int(count[0]), ny = int(count[1]), nz = int(count[2]);
    std::vector<float> values(static_cast<std::size_t>(points));
    std::vector<std::size_t> terms(std::size_t(nz), 0);
    for (int z = 0; z < nz; ++z) {
        progress.checkInterrupt();
        progress.update("smoothed distance", double(z) / nz);
        std::vector<std::size_t> rowTerms(std::size_t(ny), 0);
        tbb::parallel_for(tbb::blocked_range<int>(0, ny), [&](const tbb::blocked_range<int>& r) {
            for (int y = r.begin(); y != r.end(); ++y) {
                progress.checkInterrupt();  // per row of nx points, from the workers too
                for (int x = 0; x < nx; ++x) {
                    const Vec3d p = H * (first + Vec3d(x, y, z));
                    std::size_t t = band.size();
                    const double d = o.bruteForce ? field.exact(p) : field.at(p, tol, &t);
                    values[(std::size_t(z) * std::size_t(ny) + std::size_t(y)) * std::size_t(nx) + std::size_t(x)] = float(d);
                    rowTerms[std::size_t(y)] += t;
                }
            }
        });
        for (std::size_t t : rowTerms) terms[std::size_t(z)] += t;
    }
    progress.update("smoothed distance", 1.0);

    // === Into a dense OpenVDB grid. Outside the box nothing was computed: the background there must never read as
    //     "near" (0 would be "on the surface"), so it is a sentinel above every computed value, the largest one
    //     plus the box's diagonal: a far distance, never a real one.
    float largest = -std::numeric_limits<float>::infinity();
    for (float v : values) largest = std::max(largest, v);
    const double diagonal = H * (count - Vec3d::Ones()).norm();
    const float background = float(std::max(double(largest), 0.0) + std::max(diagonal, H));
    SmoothedDistanceResult r;
    r.grid = openvdb::FloatGrid::create(background);
    r.grid->setName("smoothed_distance");
    r.grid->setTransform(openvdb::math::Transform::createLinearTransform(H));
    auto acc = r.grid->getAccessor();
    for (int z = 0; z < nz; ++z)
        for (int y = 0; y < ny; ++y)
            for (int x = 0; x < nx; ++x)
                acc.setValueOn(openvdb::Coord(int(first[0]) + x, int(first[1]) + y, int(first[2]) + z),
                               values[(std::size_t(z) * std::size_t(ny) + std::size_t(y)) * std::size_t(nx) + std::size_t(x)]);
    r.voxelSize = H;
    r.background = background;
    r.tolerance = o.bruteForce ? 0.0 : tol;
    r.points = std::size_t(points);
    r.meanTerms = double(std::accumulate(terms.begin(), terms.end(), std::size_t(0))) / points;
    return r;
}

}  // namespace gpisvdb
