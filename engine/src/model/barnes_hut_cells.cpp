// The far field shared per cell (docs/model.md#cells): the points of one cell of a world lattice share one traversal
// for the nodes that are far from the whole cell, whose expansions are summed at the cell's Chebyshev nodes and
// interpolated at every point; each point (in packets) adds the rest of the tree from the cell's remaining roots.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <tbb/blocked_range.h>
#include <tbb/concurrent_hash_map.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tuple>

#include "contributions.h"
#include "core/morton.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "lattice_cell.h"

namespace gpisvdb {

using detail::cellIndex;
using detail::CellKey;
using detail::CellKeyHash;

namespace {

constexpr int kParts = 14;  // the mean's 4 numbers and the covariance's upper triangle (10)
constexpr int kLanes = BarnesHutGpis::kPacket;

/// Chebyshev points of the first kind on [−1, 1] and the Lagrange basis through them.
struct Chebyshev {
    int n;
    double t[8], inverse[8];  // inverse[i] = 1 / Π_{j≠i} (t_i − t_j)
    explicit Chebyshev(int count) : n(count) {
        for (int i = 0; i < n; ++i) t[i] = std::cos(M_PI * (2 * i + 1) / (2.0 * n));
        for (int i = 0; i < n; ++i) {
            double p = 1;
            for (int j = 0; j < n; ++j)
                if (j != i) p *= t[i] - t[j];
            inverse[i] = 1 / p;
        }
    }
    void basis(double u, double* out) const {
        for (int i = 0; i < n; ++i) {
            double p = inverse[i];
            for (int j = 0; j < n; ++j)
                if (j != i) p *= u - t[j];
            out[i] = p;
        }
    }
};

/// The lattice index of world coordinate `u` in cell widths (a NaN lands in cell 0; beyond ±9e15 widths, clamped).
}  // namespace

/// What a cell's points share: the far nodes' expansions summed at the Chebyshev nodes, and the roots left to each
/// point.
struct CellTable {
    std::vector<BarnesHutGpis::Root> roots;
    std::vector<double> values;  // [Chebyshev node][kParts], unnormalised sums

    std::size_t bytes() const { return sizeof(CellTable) + roots.capacity() * sizeof(roots[0]) + values.capacity() * sizeof(double); }

    /// The far field at x (in the cell at lo), added to `sums` (kParts numbers).
    void interpolate(const Vec3d& x, const Vec3d& lo, double width, const Chebyshev& cheb, double* sums) const {
        const int n = cheb.n;
        double w[3][8];
        for (int d = 0; d < 3; ++d) cheb.basis(2 * (x[d] - lo[d]) / width - 1, w[d]);
        for (int k = 0; k < n; ++k)
            for (int j = 0; j < n; ++j) {
                const double wjk = w[1][j] * w[2][k];
                for (int i = 0; i < n; ++i) {
                    const double wi = w[0][i] * wjk;
                    const double* v = &values[std::size_t(i + n * (j + n * k)) * kParts];
                    for (int q = 0; q < kParts; ++q) sums[q] += wi * v[q];
                }
            }
    }
};

/// Builds a cell's table.
struct CellPlanner {
    CellTable table;
    std::vector<std::uint32_t> farMean, farCov;

    // === Which nodes the cell takes: those far for every point of the cell and separated from it
    // A node is far for every point x of the box when it is far at the box's nearest point: ‖x − c‖ ≥ dist(c, box),
    // and the covariance's ratio never grows with the distance (covarianceBeta2). So each part is opened at least as
    // finely as evaluate(x) would open it. The separation keeps every interpolated expansion smooth on the cell.
    void plan(const BarnesHutGpis& bh, const Vec3d& lo, double width) {
        const Vec3d hi = lo + Vec3d::Constant(width);
        const double betaMean2 = bh.options_.beta * bh.options_.beta;
        const double separation = bh.options_.cellSeparation * width, separation2 = separation * separation;
        std::vector<BarnesHutGpis::Root> stack{{0u, false, false}};
        while (!stack.empty()) {
            BarnesHutGpis::Root e = stack.back();
            stack.pop_back();
            const BarnesHutGpis::Node& node = bh.nodes_[e.node];
            const Vec3d gap = (lo - node.centre).cwiseMax(node.centre - hi).cwiseMax(0.0);
            const double d2 = gap.squaredNorm(), r2 = node.radius * node.radius;
            const bool separated = d2 >= separation2;
            if (separated && !e.doneMean && d2 > betaMean2 * r2) farMean.push_back(e.node), e.doneMean = true;
            if (separated && !e.doneCov && d2 > bh.covarianceBeta2(d2) * r2) farCov.push_back(e.node), e.doneCov = true;
            if (e.doneMean && e.doneCov) continue;
            // A leaf, or a node near the cell and no larger than it: its points' own traversal takes it from here.
            if (node.childCount == 0 || (!separated && node.radius <= width)) {
                table.roots.push_back(e);
                continue;
            }
            for (int c = node.childCount - 1; c >= 0; --c) stack.push_back({node.firstChild + std::uint32_t(c), e.doneMean, e.doneCov});
        }
    }

    // === The far nodes' sums at the cell's Chebyshev nodes, a packet at a time
    void tabulate(const BarnesHutGpis& bh, const Vec3d& lo, double width, const Chebyshev& cheb) {
        const int n = cheb.n, total = n * n * n;
        std::vector<double>& values = table.values;
        values.assign(std::size_t(total) * kParts, 0.0);
        if (farMean.empty() && farCov.empty()) return;
        for (int first = 0; first < total; first += kLanes) {
            double x[3][kLanes], mean[4][kLanes], cov[4][4][kLanes];
            for (int l = 0; l < kLanes; ++l) {
                const int k = std::min(first + l, total - 1), idx[3] = {k % n, (k / n) % n, k / (n * n)};
                for (int d = 0; d < 3; ++d) x[d][l] = lo[d] + 0.5 * width * (1 + cheb.t[idx[d]]);
            }
            bh.farPacket(farMean.data(), farMean.size(), farCov.data(), farCov.size(), x, mean, cov);
            for (int l = 0; l < kLanes && first + l < total; ++l) {
                double* v = &values[std::size_t(first + l) * kParts];
                int q = 0;
                for (int a = 0; a < 4; ++a) v[q++] = mean[a][l];
                for (int a = 0; a < 4; ++a)
                    for (int b = a; b < 4; ++b) v[q++] = cov[a][b][l];
            }
        }
    }
};

/// Cells' tables kept across batches (the band's BFS hands a cell's points over in several batches), up to
/// cellCacheBytes; a table depends on nothing but its cell, so whether it was kept never changes a result.
struct BarnesHutGpis::CellCache {
    tbb::concurrent_hash_map<CellKey, std::shared_ptr<const CellTable>, CellKeyHash> tables;
    std::atomic<std::size_t> bytes{0};
    // Sized once, on first use: the cells holding a sample, and the cap in bytes.
    std::once_flag sized;
    std::size_t sampleCells = 0, limit = 0;
};

std::shared_ptr<BarnesHutGpis::CellCache> BarnesHutGpis::newCellCache() { return std::make_shared<CellCache>(); }

std::size_t BarnesHutGpis::cellCacheBytes() const { return cells_ ? cells_->bytes.load() : 0; }

namespace {

/// A table's bytes with `nodes`³ Chebyshev nodes, its roots (≈ 60 measured; 64 counted) and its entry in the map.
std::size_t tableBytesEstimate(int nodes) {
    return sizeof(CellTable) + std::size_t(nodes * nodes * nodes * kParts) * sizeof(double) +
           64 * sizeof(decltype(CellTable::roots)::value_type) + 64;
}

}  // namespace

// === The cache's size: a band's voxels lie near the samples, so the cells within one cell of a sample's hold them
// (the band touched 1.1–1.8 cells per sample-holding cell where these hold 3–7: docs/memory.md#band).
const BarnesHutGpis::CellCache& BarnesHutGpis::sizedCellCache() const {
    std::call_once(cells_->sized, [&] {
        const double width = options_.cellWidth * kernel_.smoothing();
        const auto less = [](const CellKey& a, const CellKey& b) {
            return std::tie(a.c[0], a.c[1], a.c[2]) < std::tie(b.c[0], b.c[1], b.c[2]);
        };
        std::vector<CellKey> cells(samples_.size());
        tbb::parallel_for(std::size_t(0), cells.size(), [&](std::size_t i) { cells[i] = CellKey::of(samples_.position[i], width); });
        tbb::parallel_sort(cells.begin(), cells.end(), less);
        cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
        cells_->sampleCells = cells.size();
        if (options_.cellCacheBytes != BarnesHutOptions::kAutoCellCache) {
            cells_->limit = options_.cellCacheBytes;
            return;
        }
        std::vector<CellKey> near;
        near.reserve(27 * cells.size());
        for (const CellKey& k : cells)
            for (int a = -1; a <= 1; ++a)
                for (int b = -1; b <= 1; ++b)
                    for (int c = -1; c <= 1; ++c) near.push_back({{k.c[0] + a, k.c[1] + b, k.c[2] + c}});
        tbb::parallel_sort(near.begin(), near.end(), less);
        const std::size_t nearCells = std::size_t(std::unique(near.begin(), near.end()) - near.begin());
        cells_->limit = std::max(std::size_t(64) << 20, nearCells * tableBytesEstimate(options_.cellNodes));
    });
    return *cells_;
}

std::size_t BarnesHutGpis::cellCacheLimit() const { return cells_ ? sizedCellCache().limit : 0; }

double BarnesHutGpis::expectedDenseCacheBytes() const {
    if (!cells_) return 0;
    const CellCache& cache = sizedCellCache();
    const double expected = std::min(1.5 * double(cache.sampleCells) * double(tableBytesEstimate(options_.cellNodes)), double(cache.limit));
    return std::max(0.0, expected - double(cache.bytes.load()));
}

std::vector<ValueGradient> BarnesHutGpis::evaluateInCells(const std::vector<Vec3d>& xs, const Progress& progress) const {
    std::vector<ValueGradient> out(xs.size());
    if (xs.empty()) return out;
    const double width = options_.cellWidth * kernel_.smoothing();
    const Chebyshev cheb(options_.cellNodes);
    // === Each point's cell (a lattice anchored at the origin: a point's cell does not depend on the batch), and
    // a Morton order inside it so that a packet holds neighbours
    struct Key {
        std::int64_t cell[3];
        std::uint64_t order;
        std::uint32_t index;
        bool operator<(const Key& o) const {
            return std::tie(cell[0], cell[1], cell[2], order, index) < std::tie(o.cell[0], o.cell[1], o.cell[2], o.order, o.index);
        }
        bool sameCell(const Key& o) const { return cell[0] == o.cell[0] && cell[1] == o.cell[1] && cell[2] == o.cell[2]; }
    };
    std::vector<Key> keys(xs.size());
    tbb::parallel_for(std::size_t(0), xs.size(), [&](std::size_t i) {
        Key& k = keys[i];
        std::uint64_t q[3];
        for (int d = 0; d < 3; ++d) {
            // (a NaN point lands in cell 0 and yields NaN, as in packets)
            const double u = xs[i][d] / width, f = std::floor(u);
            k.cell[d] = cellIndex(u);
            q[d] = std::isfinite(f) ? std::uint64_t(std::clamp((u - f) * 1024.0, 0.0, 1023.0)) : 0;
        }
        k.order = detail::morton(q[0], q[1], q[2]);
        k.index = std::uint32_t(i);
    });
    std::sort(keys.begin(), keys.end());
    std::vector<std::size_t> starts;
    for (std::size_t i = 0; i < keys.size(); ++i)
        if (i == 0 || !keys[i].sameCell(keys[i - 1])) starts.push_back(i);
    starts.push_back(keys.size());
    const std::size_t cells = starts.size() - 1;
    const std::size_t limit = sizedCellCache().limit;
    // A cell's table: kept from an earlier batch, or made now (and kept while the cache has room).
    const auto tableOf = [&](const Key& k, const Vec3d& lo) {
        const CellKey key{{k.cell[0], k.cell[1], k.cell[2]}};
        {
            decltype(cells_->tables)::const_accessor found;
            if (cells_->tables.find(found, key)) return found->second;
        }
        CellPlanner planner;
        planner.plan(*this, lo, width);
        planner.tabulate(*this, lo, width, cheb);
        auto made = std::make_shared<CellTable>(std::move(planner.table));
        made->roots.shrink_to_fit();
        const std::size_t bytes = made->bytes();
        if (cells_->bytes.fetch_add(bytes) + bytes <= limit) {
            decltype(cells_->tables)::accessor slot;
            if (cells_->tables.insert(slot, key)) slot->second = made;
            else cells_->bytes -= bytes;  // another caller kept it first (the same table)
        } else {
            cells_->bytes -= bytes;
        }
        return std::shared_ptr<const CellTable>(made);
    };
    // One packet of a cell's points: the rest of the tree from the cell's roots, plus the interpolated far field.
    const auto packet = [&](std::size_t first, std::size_t end, const CellTable& table, const Vec3d& lo) {
        const int count = int(std::min<std::size_t>(kLanes, end - first));
        double x[3][kLanes], mean[4][kLanes] = {}, cov[4][4][kLanes] = {};
        for (int l = 0; l < kLanes; ++l)
            for (int d = 0; d < 3; ++d) x[d][l] = xs[keys[first + std::size_t(std::min(l, count - 1))].index][d];
        if (!table.roots.empty()) traversePacket(table.roots.data(), table.roots.size(), x, mean, cov);
        for (int l = 0; l < count; ++l) {
            const std::uint32_t i = keys[first + std::size_t(l)].index;
            double sums[kParts] = {};
            table.interpolate(xs[i], lo, width, cheb, sums);
            ValueGradient& o = out[i];
            int q = 0;
            for (int a = 0; a < 4; ++a) o.mean[a] = mean[a][l] + sums[q++];
            for (int a = 0; a < 4; ++a)
                for (int b = a; b < 4; ++b) o.cov(a, b) = o.cov(b, a) = cov[a][b][l] + sums[q++];
            detail::finish(o);
        }
    };
    // === Per cell, in parallel: its table, then its points in packets (in parallel too: a batch may hold few cells)
    constexpr std::size_t kBlock = 256;  // cells between progress reports
    for (std::size_t b = 0; b < cells; b += kBlock) {
        progress.checkInterrupt();
        progress.update("evaluate", double(starts[b]) / double(xs.size()));
        tbb::parallel_for(tbb::blocked_range<std::size_t>(b, std::min(cells, b + kBlock), 1), [&](const auto& r) {
            for (std::size_t c = r.begin(); c != r.end(); ++c) {
                progress.checkInterruptAt(c, 8);
                const Key& k0 = keys[starts[c]];
                const Vec3d lo = width * Vec3d(double(k0.cell[0]), double(k0.cell[1]), double(k0.cell[2]));
                const std::shared_ptr<const CellTable> table = tableOf(k0, lo);
                const std::size_t packets = (starts[c + 1] - starts[c] + kLanes - 1) / kLanes;
                tbb::parallel_for(tbb::blocked_range<std::size_t>(0, packets, 4), [&](const auto& pr) {
                    for (std::size_t p = pr.begin(); p != pr.end(); ++p) {
                        progress.checkInterruptAt(p, 32);
                        packet(starts[c] + p * kLanes, starts[c + 1], *table, lo);
                    }
                });
            }
        });
    }
    progress.update("evaluate", 1.0);
    return out;
}

}  // namespace gpisvdb
