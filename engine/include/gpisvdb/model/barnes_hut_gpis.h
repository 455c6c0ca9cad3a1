#pragma once
// The Barnes–Hut GPIS (paper Sec. 9.1; docs/math.md#barnes-hut): an octree over the samples, built once. Each node keeps
// moments about its |w|-weighted centroid c (δ = p − c): for the mean Σ w, Σ δ wᵀ, Σ δδw (a Taylor expansion
// of ∇ρ(y − δ) to second order), for the covariance Σ σ² w wᵀ, Σ σ² δ w wᵀ, Σ Σ', Σ δ Σ' (first order).
// A node stands in for its samples when ‖x − c‖ > β·r (mean) or > β_cov(d)·r (covariance; see
// BarnesHutOptions), r its radius about c; otherwise its children, or its samples exactly, are summed.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/gpis_model.h"
#include "gpisvdb/model/kernel.h"

namespace gpisvdb {

struct BarnesHutOptions {
    double beta = 6.0;             ///< accuracy: a node stands in for its samples' mean beyond beta × its radius,
                                   ///< and for their covariance beyond covarianceRatio·beta × its radius near
                                   ///< the query (dimensionless, > 1)
    double covarianceRatio = 2.0;  ///< the covariance's opening ratio near the query, in units of beta
                                   ///< (dimensionless, ≥ 1): its expansion is first order, the mean's second
    double covarianceRelax = 5.0;  ///< beyond this distance (units of the smoothing s) the covariance ratio
                                   ///< relaxes like √(L/d), down to 2 (or to covarianceRatio·beta if smaller)
    int leafSize = 32;             ///< most samples in a leaf (≥ 1); 32 is both faster and more accurate than 16 in packets
                                   ///< (docs/model.md#packets)
    bool floatNearField = true;    ///< packets sum a leaf's samples in float lanes, in units of s (≈ 1e-6 relative,
                                   ///< docs/model.md#packets); false: in double, to rounding of evaluate(x)
    double cellWidth = 12;         ///< > 0: evaluateDense (a band's voxels) shares the far field per cell of this width
                                   ///< (units of s, a lattice anchored at the world origin), Chebyshev-interpolated
                                   ///< (docs/model.md#cells); 0: every packet sums its own, to rounding of evaluate(x)
    int cellNodes = 4;             ///< Chebyshev nodes per axis of a cell's interpolant (2…8)
    double cellSeparation = 1;     ///< a node joins a cell's far field only this far from the cell (units of cellWidth,
                                   ///< ≥ 0.5), besides passing the opening tests for every point of the cell
    /// cellCacheBytes' default: room for a table per cell within one cell of a sample's cell (a band's cells,
    /// docs/model.md#cells), at least 64 MB.
    static constexpr std::size_t kAutoCellCache = std::numeric_limits<std::size_t>::max();
    std::size_t cellCacheBytes = kAutoCellCache;  ///< cells' tables kept for later batches, at most (bytes; 0: none);
                                                  ///< beyond, a cell is tabulated again in every batch
};

class BarnesHutGpis final : public GpisModel {
public:
    /// s: smoothing length of the kernel, world units (> 0). Builds the tree (O(n log n)).
    BarnesHutGpis(const Samples& samples, double s, const BarnesHutOptions& options = {});
    /// One point: the reference path, one traversal per point.
    ValueGradient evaluate(const Vec3d& x) const override;
    /// Many points: sorted along a Morton curve and evaluated kPacket at a time, one traversal per packet
    /// (evaluatePacket). Each result equals evaluate(x) up to rounding, and depends on neither the thread count nor
    /// the other points of the batch (to the bit).
    std::vector<ValueGradient> evaluate(const std::vector<Vec3d>& xs, const Progress& progress = {}) const override;
    /// A band's voxels: with cellWidth > 0 the far field comes from the point's cell (evaluateInCells), within the
    /// model's error of evaluate(x), not to rounding, and still independent of the batch and the thread count (to
    /// the bit: the band's builder evaluates in batches of any size); with cellWidth = 0, evaluate(xs).
    std::vector<ValueGradient> evaluateDense(const std::vector<Vec3d>& xs, const Progress& progress = {}) const override {
        return options_.cellWidth > 0 ? evaluateInCells(xs, progress) : evaluate(xs, progress);
    }

    /// Points evaluated together: every node is tested for each of them and its expansion computed for all of them
    /// at once, in SIMD lanes; each point keeps exactly the nodes and the order that evaluate(x) would use.
    static constexpr int kPacket = 8;
    /// evaluate(x) for count ≤ kPacket points xs[0..count) into out[0..count).
    void evaluatePacket(const Vec3d* xs, int count, ValueGradient* out) const;

    std::size_t nodeCount() const { return nodes_.size(); }
    /// Bytes held by the tree and its reordered copy of the samples.
    std::size_t memoryBytes() const;
    /// Bytes held by the cells' tables kept for later batches (cellWidth > 0; at most cellCacheLimit()).
    std::size_t cellCacheBytes() const;
    /// The most bytes of tables kept: BarnesHutOptions::cellCacheBytes, resolved (0 with cellWidth = 0).
    std::size_t cellCacheLimit() const;
    /// The tables a band near the samples will add to those held: 1.5 per cell holding a sample (measured 1.1–1.8
    /// on the bunny, a sphere, a cloud and a mesh with holes, docs/memory.md#band), within cellCacheLimit().
    double expectedDenseCacheBytes() const override;
    /// The winding number's mean is a probability of being inside, ≈ Φ(−d/s) across the surface.
    MeanScale meanScale() const override { return MeanScale::Probit; }

    /// Tree topology and the opening test: what every visit reads, kept small for the cache.
    struct Node {
        Vec3d centre;                      ///< expansion centre (|w|-weighted centroid)
        double radius = 0;                 ///< max distance of the node's samples to `centre`
        std::uint32_t begin = 0, end = 0;  ///< sample range (tree order)
        std::uint32_t firstChild = 0;      ///< children are contiguous
        std::uint8_t childCount = 0;
    };
    /// Moments for the mean's far field, δ = p − centre; read only when the node is far.
    struct MeanMoments {
        Vec3d w0;       ///< Σ w
        Mat3d m1;       ///< Σ δ wᵀ
        Mat3d m2[3];    ///< m2[n](l, m) = Σ δ_l δ_m w_n
        Vec3d m2trace;  ///< Σ_l m2[n](l, l), per n
        Vec3d m2mixed;  ///< Σ_l m2[l](l, m), per m
    };
    /// Moments for the covariance's far field; read only when the node is far.
    struct CovarianceMoments {
        Mat3d posW;     ///< Σ σ² w wᵀ
        Mat3d posB[3];  ///< posB[n](l, m) = Σ σ² δ_l w_m w_n
        Mat3d nrmS;     ///< Σ Σ'
        Mat3d nrmC[3];  ///< nrmC[l] = Σ δ_l Σ'
    };

    /// A sample in units of the smoothing s, in float, for the packets' near field (docs/model.md#packets): w/s²,
    /// σ²/s² and Σ'/s⁴ (xx, xy, xz, yy, yz, zz). In units of s the kernel's values stay within float's range at any
    /// scale of the input.
    struct NearSample {
        float w[3];
        float var;
        float N[6];
    };

private:
    friend struct PacketTraversal;  // barnes_hut_packet.cpp
    friend struct CellPlanner;      // barnes_hut_cells.cpp
    friend struct CellTable;        // barnes_hut_cells.cpp
    /// A node where a packet's traversal starts, with the parts (mean, covariance) its cell already holds.
    struct Root {
        std::uint32_t node = 0;
        bool doneMean = false, doneCov = false;
    };
    /// evaluateDense with cellWidth > 0 (barnes_hut_cells.cpp).
    std::vector<ValueGradient> evaluateInCells(const std::vector<Vec3d>& xs, const Progress& progress) const;
    /// The packet traversal from `roots` (barnes_hut_packet.cpp): points xs[d][lane], unnormalised sums mean[a][lane]
    /// and cov[a][b][lane] (a ≤ b).
    void traversePacket(const Root* roots, std::size_t rootCount, const double (*xs)[kPacket], double (*mean)[kPacket],
                        double (*cov)[4][kPacket]) const;
    /// The far expansions of the listed nodes at every point of a packet, unnormalised, as traversePacket.
    void farPacket(const std::uint32_t* meanNodes, std::size_t meanCount, const std::uint32_t* covNodes, std::size_t covCount,
                   const double (*xs)[kPacket], double (*mean)[kPacket], double (*cov)[4][kPacket]) const;
    static constexpr int kMaxDepth = 48;  // coincident samples stop splitting here
    void split(std::uint32_t node, int depth);
    /// Appends a node over samples [begin, end) with its moments; returns its index.
    std::uint32_t addNode(std::uint32_t begin, std::uint32_t end);
    void addFarMean(const MeanMoments& mm, const Vec3d& y, const RadialDerivatives& F, ValueGradient& out) const;
    void addFarCovariance(const CovarianceMoments& cm, const Vec3d& y, const RadialDerivatives& F, ValueGradient& out) const;
    /// The covariance's opening ratio², by the squared distance d2 (the packet traversal repeats it in lanes).
    double covarianceBeta2(double d2) const {
        // The covariance's relative truncation error per node has a large constant (its terms fall off like
        // 1/d⁴…1/d⁸), so near the query it needs twice the mean's ratio (covarianceRatio = 2). Far away its terms
        // are small against the near field: a node's absolute error falls like (r/d)⁴ (L/d)², so the ratio may relax
        // like √(L/d) beyond L = covarianceRelax·s, down to 2 (or to its ratio near the query, if that is smaller).
        const double b2 = covarianceRatio2();
        const double L = options_.covarianceRelax * kernel_.smoothing();
        if (d2 <= L * L) return b2;
        return std::max(std::min(4.0, b2), b2 * L / std::sqrt(d2));
    }

    /// (covarianceRatio·beta)², the covariance's opening ratio² near the query.
    double covarianceRatio2() const {
        const double b = options_.covarianceRatio * options_.beta;
        return b * b;
    }

    struct CellCache;  // barnes_hut_cells.cpp
    static std::shared_ptr<CellCache> newCellCache();
    std::shared_ptr<CellCache> cells_;        // filled by const batches: a cell's table depends on nothing but the cell
    const CellCache& sizedCellCache() const;  // cells_, its cap resolved on first use

    Samples samples_;                      // reordered so that every node's samples are contiguous
    std::vector<NearSample> nearSamples_;  // samples_ in units of s, in float, in the same order
    std::vector<Node> nodes_;
    std::vector<MeanMoments> meanMoments_;       // per node
    std::vector<CovarianceMoments> covMoments_;  // per node
    RegularizedKernel kernel_;
    BarnesHutOptions options_;
};

}  // namespace gpisvdb
