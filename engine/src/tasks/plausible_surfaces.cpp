#include "gpisvdb/tasks/plausible_surfaces.h"

#include <algorithm>
#include <cmath>
#include <Eigen/Eigenvalues>
#include <limits>
#include <numeric>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/simd_lanes.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/model/kernel.h"

namespace gpisvdb {

namespace {

constexpr double kInv4Pi = 0.25 / M_PI;
constexpr int kMaxDraws = 10000;

// === Counter-based normal deviates: a draw's noise depends on (seed, draw, sample) only, never on the order or
//     the thread that asks, so a draw is the same whatever the count, the first draw or the thread count.
std::uint64_t splitMix(std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/// In (0, 1): 53 random bits, offset by half a step so that log() never sees 0.
double uniformOpen(std::uint64_t bits) { return (double(bits >> 11) + 0.5) * 0x1.0p-53; }

/// Six standard normal deviates (three Box–Muller pairs) for one sample of one draw.
std::array<double, 6> normalDeviates(std::uint64_t seed, std::uint64_t draw, std::uint64_t sample) {
    const std::uint64_t key = splitMix(splitMix(splitMix(seed) ^ draw) ^ sample);
    std::array<double, 6> z{};
    for (int m = 0; m < 3; ++m) {
        const double radius = std::sqrt(-2.0 * std::log(uniformOpen(splitMix(key + 2 * m))));
        const double angle = 2.0 * M_PI * uniformOpen(splitMix(key + 2 * m + 1));
        z[2 * m] = radius * std::cos(angle);
        z[2 * m + 1] = radius * std::sin(angle);
    }
    return z;
}

/// The symmetric square root of a positive semi-definite Σ' (rank 2 for clouds, so no Cholesky).
Mat3d symmetricRoot(const Sym3& s) {
    const Eigen::SelfAdjointEigenSolver<Mat3d> eig(s.matrix());
    const Vec3d root = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    return eig.eigenvectors() * root.asDiagonal() * eig.eigenvectors().transpose();
}

/// F₁ and F₂ of the kernel at t = r² (kernel.h), all a draw needs: RegularizedKernel::at's series and closed forms for
/// these two alone, the series stopped once its terms fall below double rounding (they decrease past m = a²t).
struct FirstTwo {
    double F1, F2;
};
FirstTwo firstTwo(const RegularizedKernel& kernel, double t) {
    const double a2 = kernel.erfScale() * kernel.erfScale(), c = kernel.gaussianFactor();
    if (t < kernel.seriesDistance2()) {
        const RegularizedKernel::Series& series = RegularizedKernel::series();
        const double x = -a2 * t;
        double s1 = 0, s2 = 0, term = 1.0;  // term: (−a² t)^m / m!
        for (int m = 0; m < RegularizedKernel::kSeriesTerms; ++m) {
            s1 += term * series.inverse[m][1];
            s2 += term * series.inverse[m][2];
            if (m > -x && std::abs(term) < 1e-18 * std::abs(s1)) break;
            term *= x * series.next[m];
        }
        return {-2.0 * a2 * c * s1, 4.0 * a2 * a2 * c * s2};
    }
    const double r = std::sqrt(t), u = 1.0 / t, ir = 1.0 / r;
    const bool far = t > kernel.newtonDistance2();
    const double E = far ? 1.0 : std::erf(kernel.erfScale() * r);
    const double g = far ? 0.0 : c * std::exp(-a2 * t);
    return {-E * ir * u + g * u, 3.0 * E * ir * u * u - g * (3.0 * u * u + 2.0 * a2 * u)};
}

// One clone per instruction set (GPISVDB_SIMD_CLONES, core/simd_lanes.h): the sums over the draws are SIMD lanes.

/// out[k] += Σ_c q[c] · stream_c[k] over `streams` streams of n values each (stream c at values + c · n).
template <int streams, class T>
inline void addTerms(const double* q, const T* values, int n, double* out) {
    for (int k = 0; k < n; ++k) {
        double sum = 0;
        for (int c = 0; c < streams; ++c) sum += q[c] * double(values[c * n + k]);
        out[k] += sum;
    }
}
GPISVDB_SIMD_CLONES void addNodeTerms(const double* q, const double* moments, int n, double* out) { addTerms<12>(q, moments, n, out); }
GPISVDB_SIMD_CLONES void addSampleTerms(const double* q, const float* noise, int n, double* out) { addTerms<6>(q, noise, n, out); }

struct Node {
    Vec3d centre = Vec3d::Zero();  ///< mean of its samples' positions
    double radius2 = 0;            ///< squared distance from the centre to its farthest sample
    std::uint32_t begin = 0, end = 0;
    std::int32_t left = -1, right = -1;  ///< children; −1 for a leaf
};

}  // namespace

struct SurfaceDraws::Impl {
    RegularizedKernel kernel;
    SurfaceDrawOptions options;
    std::vector<Vec3d> position, normal;  ///< in tree order
    /// δw (c = 0..2, world units²) and δp (c = 3..5, world units) per sample (tree order) and draw, the draws
    /// contiguous (each term is then one multiply-add per draw, in SIMD lanes): noise[(sample · 6 + c) · n + k]
    std::vector<float> noise;
    std::vector<Node> nodes;
    /// Per node and draw: A = Σ δw (c = 0..2), then B = Σ δp wᵀ (c = 3..11, row-major): moments[(node · 12 + c) · n + k]
    std::vector<double> moments;

    explicit Impl(double s) : kernel(s) {}

    int split(std::vector<std::uint32_t>& order, std::uint32_t begin, std::uint32_t end, const Samples& samples) {
        const int id = int(nodes.size());
        nodes.emplace_back();
        Node node;
        node.begin = begin;
        node.end = end;
        Vec3d lo = Vec3d::Constant(HUGE_VAL), hi = Vec3d::Constant(-HUGE_VAL);
        for (std::uint32_t i = begin; i < end; ++i) {
            const Vec3d& p = samples.position[order[i]];
            node.centre += p;
            lo = lo.cwiseMin(p);
            hi = hi.cwiseMax(p);
        }
        node.centre /= double(end - begin);
        for (std::uint32_t i = begin; i < end; ++i)
            node.radius2 = std::max(node.radius2, (samples.position[order[i]] - node.centre).squaredNorm());
        if (end - begin > std::uint32_t(options.leafSize) && (hi - lo).maxCoeff() > 0) {
            int axis = 0;
            (hi - lo).maxCoeff(&axis);
            const std::uint32_t middle = begin + (end - begin) / 2;
            std::nth_element(order.begin() + begin, order.begin() + middle, order.begin() + end, [&](std::uint32_t a, std::uint32_t b) {
                const double pa = samples.position[a][axis], pb = samples.position[b][axis];
                return pa < pb || (pa == pb && a < b);
            });
            node.left = split(order, begin, middle, samples);
            node.right = split(order, middle, end, samples);
        }
        nodes[std::size_t(id)] = node;
        return id;
    }

    /// J ε_k of every draw at x, times 4π, added to out (n values).
    void addPerturbation(const Vec3d& x, double* out) const {
        const int n = options.count;
        const double beta2 = options.openingRatio * options.openingRatio;
        std::int32_t stack[128];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& node = nodes[std::size_t(stack[--top])];
            const Vec3d y = x - node.centre;
            const double d2 = y.squaredNorm();
            if (d2 > beta2 * node.radius2) {
                // === Far node: its zeroth-order term ∇ρ(y)·A − D²ρ(y) : B, as Σ_c coefficient_c × moment_c with
                //     ∇ρ = F₁ y and D²ρ = F₁ I + F₂ y yᵀ
                const FirstTwo F = firstTwo(kernel, d2);
                double coefficient[12];
                for (int a = 0; a < 3; ++a) {
                    coefficient[a] = F.F1 * y[a];
                    for (int b = 0; b < 3; ++b) coefficient[3 + 3 * a + b] = -F.F2 * y[a] * y[b] - (a == b ? F.F1 : 0.0);
                }
                addNodeTerms(coefficient, &moments[std::size_t(&node - nodes.data()) * 12 * std::size_t(n)], n, out);
            } else if (node.left < 0) {
                for (std::uint32_t i = node.begin; i < node.end; ++i) addSample(x, i, out);
            } else {
                stack[top++] = node.right;
                stack[top++] = node.left;
            }
        }
    }

    /// One sample's exact term ∇ρ(y)·δw − δpᵀ D²ρ(y) w = F₁ y·δw − (F₁ w + F₂ (y·w) y)·δp, times 4π.
    void addSample(const Vec3d& x, std::uint32_t i, double* out) const {
        const int n = options.count;
        const Vec3d y = x - position[i];
        const FirstTwo F = firstTwo(kernel, y.squaredNorm());
        const Vec3d& w = normal[i];
        const Vec3d dp = -(F.F1 * w + (F.F2 * y.dot(w)) * y);
        const double coefficient[6] = {F.F1 * y[0], F.F1 * y[1], F.F1 * y[2], dp[0], dp[1], dp[2]};
        addSampleTerms(coefficient, &noise[std::size_t(i) * 6 * std::size_t(n)], n, out);
    }
};

SurfaceDraws::SurfaceDraws(const Samples& samples, double s, const SurfaceDrawOptions& options)
    : impl_(std::make_unique<Impl>(s > 0 && std::isfinite(s) ? s : 1.0)) {
    if (!(s > 0) || !std::isfinite(s)) throw ParameterError("the kernel's smoothing must be positive and finite", {"s"});
    if (options.count < 1 || options.count > kMaxDraws)
        throw ParameterError(
            "the number of draws must be between 1 and " + std::to_string(kMaxDraws) + ", got " + std::to_string(options.count),
            {"SurfaceDrawOptions::count"});
    if (options.firstDraw < 0 || options.firstDraw > std::numeric_limits<int>::max() - options.count)
        throw ParameterError("the first draw's index must be >= 0 and leave room for the draws' indices in an int",
                             {"SurfaceDrawOptions::firstDraw"});
    if (!(options.openingRatio > 1) || !std::isfinite(options.openingRatio))
        throw ParameterError("the opening ratio must be finite and > 1", {"SurfaceDrawOptions::openingRatio"});
    if (options.leafSize < 1) throw ParameterError("the leaf size must be >= 1", {"SurfaceDrawOptions::leafSize"});
    if (samples.size() == 0) throw Error("plausible surfaces need at least one sample");
    if (samples.size() >= std::size_t(1) << 31) throw Error("plausible surfaces take fewer than 2^31 samples");
    Impl& d = *impl_;
    d.options = options;
    const std::size_t N = samples.size(), n = std::size_t(options.count);

    // === The tree: median splits along the box's longest side
    std::vector<std::uint32_t> order(N);
    std::iota(order.begin(), order.end(), 0u);
    d.nodes.reserve(4 * N / std::size_t(options.leafSize) + 1);
    d.split(order, 0, std::uint32_t(N), samples);

    // === The noise of each draw: δp = √v z₁, δw = Σ'^½ z₂ (independent across samples, as the model's covariance)
    d.position.resize(N);
    d.normal.resize(N);
    d.noise.resize(N * n * 6);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, N, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t t = r.begin(); t < r.end(); ++t) {
            const std::uint32_t i = order[t];
            d.position[t] = samples.position[i];
            d.normal[t] = samples.normal[i];
            const Mat3d root = symmetricRoot(samples.normalCovariance[i]);
            const double sd = std::sqrt(std::max(samples.positionVariance[i], 0.0));
            for (std::size_t k = 0; k < n; ++k) {
                const auto z = normalDeviates(options.seed, std::uint64_t(options.firstDraw) + k, i);
                const Vec3d dw = root * Vec3d(z[0], z[1], z[2]);
                float* e = &d.noise[t * 6 * n + k];
                for (int c = 0; c < 3; ++c) {
                    e[std::size_t(c) * n] = float(dw[c]);
                    e[std::size_t(3 + c) * n] = float(sd * z[std::size_t(3 + c)]);
                }
            }
        }
    });

    // === Node moments A = Σ δw, B = Σ δp wᵀ, children before parents (a child's id is larger than its parent's)
    d.moments.assign(d.nodes.size() * n * 12, 0.0);
    for (std::size_t id = d.nodes.size(); id-- > 0;) {
        const Node& node = d.nodes[id];
        double* m = &d.moments[id * n * 12];
        if (node.left >= 0) {
            const double* a = &d.moments[std::size_t(node.left) * n * 12];
            const double* b = &d.moments[std::size_t(node.right) * n * 12];
            for (std::size_t c = 0; c < n * 12; ++c) m[c] = a[c] + b[c];
            continue;
        }
        for (std::uint32_t t = node.begin; t < node.end; ++t) {
            const Vec3d& w = d.normal[t];
            const float* e = &d.noise[std::size_t(t) * 6 * n];
            for (std::size_t k = 0; k < n; ++k) {
                for (std::size_t c = 0; c < 3; ++c) m[c * n + k] += e[c * n + k];
                for (std::size_t a = 0; a < 3; ++a)
                    for (std::size_t b = 0; b < 3; ++b) m[(3 + 3 * a + b) * n + k] += double(e[(3 + a) * n + k]) * w[int(b)];
            }
        }
    }
}

SurfaceDraws::~SurfaceDraws() = default;
SurfaceDraws::SurfaceDraws(SurfaceDraws&&) noexcept = default;

int SurfaceDraws::count() const { return impl_->options.count; }

std::vector<double> SurfaceDraws::perturbation(const Vec3d& x) const {
    std::vector<double> out(std::size_t(impl_->options.count), 0.0);
    impl_->addPerturbation(x, out.data());
    for (double& v : out) v *= kInv4Pi;
    return out;
}

std::vector<double> SurfaceDraws::perturbationExact(const Vec3d& x) const {
    std::vector<double> out(std::size_t(impl_->options.count), 0.0);
    for (std::uint32_t i = 0; i < impl_->position.size(); ++i) impl_->addSample(x, i, out.data());
    for (double& v : out) v *= kInv4Pi;
    return out;
}

std::vector<std::vector<float>> SurfaceDraws::onBand(const Band& band, const Progress& progress) const {
    return onVoxels(
        band, band.size(), [](std::size_t j) { return j; }, progress);
}

std::vector<std::vector<float>> SurfaceDraws::onBand(const Band& band, const std::vector<std::size_t>& voxels,
                                                     const Progress& progress) const {
    for (std::size_t i : voxels)
        if (i >= band.size()) throw Error("a listed voxel is not in the band");
    return onVoxels(
        band, voxels.size(), [&](std::size_t j) { return voxels[j]; }, progress);
}

template <class VoxelOf>
std::vector<std::vector<float>> SurfaceDraws::onVoxels(const Band& band, std::size_t count, VoxelOf voxelOf,
                                                       const Progress& progress) const {
    if (band.mean.size() != band.size()) throw Error("the band's mean channel was released (a spill): plausible surfaces need it");
    const std::size_t n = std::size_t(impl_->options.count);
    std::vector<std::vector<float>> values(n, std::vector<float>(count));
    const double h = band.voxelSize;
    constexpr std::size_t kBlock = 1 << 15;  // voxels between progress reports
    for (std::size_t start = 0; start < count; start += kBlock) {
        progress.checkInterrupt();
        progress.update("plausible surfaces", double(start) / double(count));
        const std::size_t stop = std::min(count, start + kBlock);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(start, stop, 64), [&](const tbb::blocked_range<std::size_t>& r) {
            std::vector<double> out(n);
            for (std::size_t j = r.begin(); j < r.end(); ++j) {
                progress.checkInterruptAt(j);
                const std::size_t i = voxelOf(j);
                const openvdb::Coord& c = band.coord[i];
                std::fill(out.begin(), out.end(), 0.0);
                impl_->addPerturbation(Vec3d(h * c.x(), h * c.y(), h * c.z()), out.data());
                for (std::size_t k = 0; k < n; ++k) values[k][j] = float(double(band.mean[i]) + kInv4Pi * out[k]);
            }
        });
    }
    progress.update("plausible surfaces", 1.0);
    return values;
}

double SurfaceDraws::bytes(std::size_t samples, const SurfaceDrawOptions& options) {
    const double N = double(samples), n = double(std::max(options.count, 1));
    const double nodes = 4.0 * N / double(std::max(options.leafSize, 1)) + 1;  // median splits: leaves hold ≥ leafSize / 2
    return N * (48.0 + 4.0 /* order */ + 24.0 * n) + nodes * (sizeof(Node) + 96.0 * n);
}

openvdb::FloatGrid::Ptr drawGrid(const Band& band, const std::vector<float>& values) {
    if (values.size() != band.size()) throw Error("a draw's values do not match the band");
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("draw");
    grid->setTransform(band.index->transform().copy());
    auto acc = grid->getAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) acc.setValue(band.coord[i], values[i]);
    return grid;
}

openvdb::FloatGrid::Ptr drawGrid(const Band& band, const std::vector<std::size_t>& voxels, const std::vector<float>& values) {
    if (values.size() != voxels.size()) throw Error("a draw's values do not match the listed voxels");
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("draw");
    grid->setTransform(band.index->transform().copy());
    auto acc = grid->getAccessor();
    for (std::size_t j = 0; j < voxels.size(); ++j) {
        if (voxels[j] >= band.size()) throw Error("a listed voxel is not in the band");
        acc.setValue(band.coord[voxels[j]], values[j]);
    }
    return grid;
}

}  // namespace gpisvdb
