#include "gpisvdb/solve/aggregation_multigrid.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <Eigen/Dense>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <utility>
#include <vector>

#include "deterministic_dot.h"
#include "gpisvdb/band/stencil_neighbours.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr std::size_t kGrain = 2048;
constexpr std::size_t kMaxDenseUnknowns = 4096;  // the coarsest level's dense factor: 128 MB at most
constexpr double kKCycleRatio = 0.25;            // the K-cycle's second step only while the first left more residual (Notay)

double dot(const float* a, const float* b, std::size_t n) { return detail::deterministicDot(a, b, n, kGrain); }

template <class F>
void forEach(std::size_t n, std::size_t grain, const F& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
    });
}

/// One coarse row's entries while they are gathered: (column, weight), merged by column in emission order.
using Entry = std::pair<std::int32_t, double>;
void mergeByColumn(std::vector<Entry>& row) {
    std::stable_sort(row.begin(), row.end(), [](const Entry& a, const Entry& b) { return a.first < b.first; });
    std::size_t m = 0;
    for (const Entry& e : row) {
        if (m > 0 && row[m - 1].first == e.first) row[m - 1].second += e.second;
        else row[m++] = e;
    }
    row.resize(m);
}

/// Compressed rows of non-negative edge weights W_IJ (the operator's off-diagonal entries are −W_IJ).
struct EdgeRows {
    std::vector<std::uint64_t> start;  // rows + 1
    std::vector<std::int32_t> col;
    std::vector<float> weight;
    std::size_t entries() const { return col.size(); }
    std::size_t bytes() const {
        return start.capacity() * sizeof(std::uint64_t) + col.capacity() * sizeof(std::int32_t) + weight.capacity() * sizeof(float);
    }
};

/// Rows built in two passes over `gather(I, row)` (which fills row I's merged entries): count, then fill.
template <class Gather>
EdgeRows buildRows(std::size_t rows, const Gather& gather) {
    EdgeRows out;
    out.start.assign(rows + 1, 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows, kGrain), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<Entry> row;
        for (std::size_t I = r.begin(); I != r.end(); ++I) {
            gather(I, row);
            out.start[I + 1] = row.size();
        }
    });
    for (std::size_t I = 0; I < rows; ++I) out.start[I + 1] += out.start[I];
    out.col.resize(out.start[rows]);
    out.weight.resize(out.start[rows]);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows, kGrain), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<Entry> row;
        for (std::size_t I = r.begin(); I != r.end(); ++I) {
            gather(I, row);
            for (std::size_t e = 0; e < row.size(); ++e) {
                out.col[out.start[I] + e] = row[e].first;
                out.weight[out.start[I] + e] = float(row[e].second);
            }
        }
    });
    return out;
}

/// Nodes of a finer level grouped into the aggregates of the next: member lists in compressed rows, each list
/// ascending.
struct Aggregates {
    std::vector<std::uint32_t> start;  // aggregates + 1
    std::vector<std::int32_t> member;
    std::size_t count() const { return start.empty() ? 0 : start.size() - 1; }
    std::size_t bytes() const { return start.capacity() * sizeof(std::uint32_t) + member.capacity() * sizeof(std::int32_t); }
};

/// Groups nodes by coord >> 1 (2×2×2 blocks of their lattice). Aggregates are numbered in the order of their
/// smallest coarse coordinate (x, then y, then z): a fixed order, whatever the thread count. `parent` gets each
/// node's aggregate and `coarse` each aggregate's coordinate.
Aggregates aggregate(const std::vector<openvdb::Coord>& coord, std::vector<std::int32_t>& parent, std::vector<openvdb::Coord>& coarse) {
    const std::size_t n = coord.size();
    std::vector<std::int32_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = std::int32_t(i);
    auto key = [&](std::int32_t i) {
        const openvdb::Coord& c = coord[std::size_t(i)];
        return std::array<int, 3>{c.x() >> 1, c.y() >> 1, c.z() >> 1};
    };
    // (key, index) is a strict total order: the sorted result is unique, so parallel sorting is deterministic.
    tbb::parallel_sort(order.begin(), order.end(), [&](std::int32_t a, std::int32_t b) {
        const auto ka = key(a), kb = key(b);
        return ka != kb ? ka < kb : a < b;
    });
    Aggregates agg;
    agg.member = std::move(order);
    agg.start.push_back(0);
    parent.resize(n);
    coarse.clear();
    for (std::size_t s = 0; s < n; ++s) {
        const auto k = key(agg.member[s]);
        if (s > 0 && k != key(agg.member[s - 1])) agg.start.push_back(std::uint32_t(s));
        if (s == 0 || k != key(agg.member[s - 1])) coarse.emplace_back(k[0], k[1], k[2]);
        parent[std::size_t(agg.member[s])] = std::int32_t(coarse.size() - 1);
    }
    agg.start.push_back(std::uint32_t(n));
    return agg;
}

}  // namespace

/// A coarse level: A = Σ_{I<J} W_IJ (e_I − e_J)(e_I − e_J)ᵀ + diag(boundary), its rows stored whole (both ends of
/// every edge) so that applying it is a gather.
struct CoarseLevel {
    Aggregates fromFiner;  // this level's nodes as aggregates of the finer level's nodes
    EdgeRows edges;
    std::vector<float> diag, invDiag;
    std::vector<double> boundary;                   // set-up only: the weights of edges that leave the band
    std::vector<openvdb::Coord> coord;              // set-up only: the node's block, in units of this level's spacing
    mutable std::vector<float> r, x, t;             // the cycle's right-hand side, iterate and residual
    mutable std::vector<float> v1, w1, v2, w2, rt;  // the K-cycle's two flexible-CG steps (kCycle)
    std::size_t size() const { return diag.size(); }
    std::size_t bytes() const {
        return fromFiner.bytes() + edges.bytes() +
               (diag.capacity() + invDiag.capacity() + r.capacity() + x.capacity() + t.capacity() + v1.capacity() + w1.capacity() +
                v2.capacity() + w2.capacity() + rt.capacity()) *
                   sizeof(float);
    }
    /// out = A u, each row summed in double in a fixed order.
    void apply(const float* u, float* out) const {
        forEach(size(), kGrain, [&](std::size_t I) {
            double s = double(diag[I]) * double(u[I]);
            for (std::uint64_t e = edges.start[I]; e != edges.start[I + 1]; ++e)
                s -= double(edges.weight[e]) * double(u[std::size_t(edges.col[e])]);
            out[I] = float(s);
        });
    }
};

struct AggregationMultigrid::Impl {
    const LaplacianOperator& L;
    AggregationOptions options;
    std::size_t n = 0;
    std::vector<float> invDiag;       // the finest level's
    mutable std::vector<float> t;     // the finest level's residual
    std::vector<CoarseLevel> levels;  // 1, 2, …
    Eigen::LLT<Eigen::MatrixXd> coarsest;
    std::size_t fineEntries = 0;

    Impl(const LaplacianOperator& op, const AggregationOptions& o) : L(op), options(o), n(op.size()) {
        const Band& band = L.band();
        invDiag.resize(n);
        L.diagonal(invDiag.data());
        for (float& d : invDiag) d = d > 0 ? 1.0f / d : 1.0f;
        for (std::size_t i = 0; i < n; ++i) fineEntries += std::size_t(2 * band.stencil[i].count);
        if (n > options.coarsestUnknowns) {
            levels.push_back(firstLevel(band));
            // A level whose nodes lie ≥ 2 apart merges nothing, but a coarser lattice will: no early stop.
            while (levels.back().size() > options.coarsestUnknowns && int(levels.size()) + 1 < options.maxLevels)
                levels.push_back(coarsen(levels.back()));
            if (levels.back().size() > kMaxDenseUnknowns)
                throw Error("aggregation multigrid: " + std::to_string(levels.back().size()) + " nodes left after " +
                            std::to_string(levels.size()) +
                            " levels (AggregationOptions::maxLevels), too many for the "
                            "dense coarsest solve: use --preconditioner multigrid or jacobi");
            for (std::size_t c = 0; c < levels.size(); ++c) {
                CoarseLevel& level = levels[c];
                std::vector<double>().swap(level.boundary);
                std::vector<openvdb::Coord>().swap(level.coord);
                for (auto* v : {&level.r, &level.x, &level.t}) v->resize(level.size());
                if (options.kCycle && c + 1 < levels.size())  // the coarsest is solved exactly
                    for (auto* v : {&level.v1, &level.w1, &level.v2, &level.w2, &level.rt}) v->resize(level.size());
            }
        }
        t.resize(n);
        factorCoarsest();
    }

    /// Level 1 from the band: aggregates of voxels, and W_IJ = Σ over the stencil edges between I and J of h λ/2
    /// (each voxel's own edges are its half of the edge: docs/math.md#operators).
    CoarseLevel firstLevel(const Band& band) {
        CoarseLevel level;
        std::vector<std::int32_t> parent;
        level.fromFiner = aggregate(band.coord, parent, level.coord);
        const std::size_t m = level.fromFiner.count();
        const std::int32_t* nb = L.neighbours();
        const double halfH = 0.5 * band.voxelSize;
        level.boundary.assign(m, 0.0);
        // === The edges each aggregate's voxels emit (out), merged by the aggregate they reach
        EdgeRows out = buildRows(m, [&](std::size_t I, std::vector<Entry>& row) {
            row.clear();
            double boundary = 0;
            for (std::uint32_t s = level.fromFiner.start[I]; s != level.fromFiner.start[I + 1]; ++s) {
                const std::size_t i = std::size_t(level.fromFiner.member[s]);
                const VoxelStencil& st = band.stencil[i];
                for (int k = 0; k < st.count; ++k) {
                    const double w = halfH * double(st.weight[std::size_t(k)]);
                    for (int sign = 0; sign < 2; ++sign) {
                        const std::int32_t j = nb[kStencilSlots * i + 2 * std::size_t(k) + std::size_t(sign)];
                        if (j < 0) boundary += w;
                        else if (const std::int32_t J = parent[std::size_t(j)]; std::size_t(J) != I) row.emplace_back(J, w);
                    }
                }
            }
            level.boundary[I] = boundary;
            mergeByColumn(row);
        });
        std::vector<std::int32_t>().swap(parent);
        // === The edges they receive (out transposed) merged in: W_IJ = out_IJ + out_JI
        level.edges = symmetrise(out, options.transposeChunkEntries);
        setDiagonal(level);
        return level;
    }

    /// Rows of W = out + outᵀ. outᵀ is formed for one range of rows at a time (a few hundred MB at most) and twice,
    /// to count and then to fill, so that the set-up never holds a whole transposed copy beside out and W.
    static EdgeRows symmetrise(const EdgeRows& out, std::size_t chunkEntries) {
        const std::size_t m = out.start.size() - 1;
        const std::size_t chunks = std::max<std::size_t>(1, (out.entries() + chunkEntries - 1) / chunkEntries);
        EdgeRows w, in;
        w.start.assign(m + 1, 0);
        // Rows [a, b) of outᵀ, each row's entries in ascending source row (a serial scan: a fixed order).
        auto transpose = [&](std::size_t a, std::size_t b) {
            in.start.assign(b - a + 1, 0);
            for (std::size_t e = 0; e < out.entries(); ++e)
                if (const std::size_t J = std::size_t(out.col[e]); J >= a && J < b) ++in.start[J - a + 1];
            for (std::size_t J = 0; J < b - a; ++J) in.start[J + 1] += in.start[J];
            in.col.resize(in.start[b - a]);
            in.weight.resize(in.start[b - a]);
            std::vector<std::uint64_t> cursor(in.start.begin(), in.start.end() - 1);
            for (std::size_t I = 0; I < m; ++I)
                for (std::uint64_t e = out.start[I]; e != out.start[I + 1]; ++e)
                    if (const std::size_t J = std::size_t(out.col[e]); J >= a && J < b) {
                        const std::uint64_t slot = cursor[J - a]++;
                        in.col[slot] = std::int32_t(I);
                        in.weight[slot] = out.weight[e];
                    }
        };
        auto merged = [&](std::size_t I, std::size_t a, std::vector<Entry>& row) {
            row.clear();
            for (std::uint64_t e = out.start[I]; e != out.start[I + 1]; ++e) row.emplace_back(out.col[e], double(out.weight[e]));
            for (std::uint64_t e = in.start[I - a]; e != in.start[I - a + 1]; ++e) row.emplace_back(in.col[e], double(in.weight[e]));
            mergeByColumn(row);
        };
        auto forRows = [&](std::size_t a, std::size_t b, const auto& body) {
            tbb::parallel_for(tbb::blocked_range<std::size_t>(a, b, kGrain), [&](const tbb::blocked_range<std::size_t>& r) {
                std::vector<Entry> row;
                for (std::size_t I = r.begin(); I != r.end(); ++I) {
                    merged(I, a, row);
                    body(I, row);
                }
            });
        };
        const std::size_t rowsPerChunk = (m + chunks - 1) / chunks;
        for (int pass = 0; pass < 2; ++pass) {
            if (pass == 1) {
                for (std::size_t I = 0; I < m; ++I) w.start[I + 1] += w.start[I];
                w.col.resize(w.start[m]);
                w.weight.resize(w.start[m]);
            }
            for (std::size_t a = 0; a < m; a += rowsPerChunk) {
                const std::size_t b = std::min(m, a + rowsPerChunk);
                transpose(a, b);
                if (pass == 0) {
                    forRows(a, b, [&](std::size_t I, const std::vector<Entry>& row) { w.start[I + 1] = row.size(); });
                } else {
                    forRows(a, b, [&](std::size_t I, const std::vector<Entry>& row) {
                        for (std::size_t e = 0; e < row.size(); ++e) {
                            w.col[w.start[I] + e] = row[e].first;
                            w.weight[w.start[I] + e] = float(row[e].second);
                        }
                    });
                }
            }
        }
        return w;
    }

    /// The next level: aggregates of `fine`'s nodes, W_KL = Σ_{I∈K, J∈L} W_IJ (rows already hold both ends).
    static CoarseLevel coarsen(const CoarseLevel& fine) {
        CoarseLevel level;
        std::vector<std::int32_t> parent;
        level.fromFiner = aggregate(fine.coord, parent, level.coord);
        const std::size_t m = level.fromFiner.count();
        level.boundary.assign(m, 0.0);
        level.edges = buildRows(m, [&](std::size_t K, std::vector<Entry>& row) {
            row.clear();
            double boundary = 0;
            for (std::uint32_t s = level.fromFiner.start[K]; s != level.fromFiner.start[K + 1]; ++s) {
                const std::size_t I = std::size_t(level.fromFiner.member[s]);
                boundary += fine.boundary[I];
                for (std::uint64_t e = fine.edges.start[I]; e != fine.edges.start[I + 1]; ++e)
                    if (const std::int32_t J = parent[std::size_t(fine.edges.col[e])]; std::size_t(J) != K)
                        row.emplace_back(J, double(fine.edges.weight[e]));
            }
            level.boundary[K] = boundary;
            mergeByColumn(row);
        });
        setDiagonal(level);
        return level;
    }

    static void setDiagonal(CoarseLevel& level) {
        const std::size_t m = level.fromFiner.count();
        level.diag.resize(m);
        level.invDiag.resize(m);
        forEach(m, kGrain, [&](std::size_t I) {
            double d = level.boundary[I];
            for (std::uint64_t e = level.edges.start[I]; e != level.edges.start[I + 1]; ++e) d += double(level.edges.weight[e]);
            level.diag[I] = float(d);
            level.invDiag[I] = d > 0 ? float(1.0 / d) : 1.0f;
        });
    }

    /// The coarsest level (or L itself for a band this small) as a dense matrix, factored once.
    void factorCoarsest() {
        if (levels.empty()) {
            const SparseMatrixF A = L.assemble();
            coarsest.compute(Eigen::MatrixXd(A.cast<double>()));
        } else {
            const CoarseLevel& c = levels.back();
            Eigen::MatrixXd A = Eigen::MatrixXd::Zero(long(c.size()), long(c.size()));
            for (std::size_t I = 0; I < c.size(); ++I) {
                A(long(I), long(I)) = c.diag[I];
                for (std::uint64_t e = c.edges.start[I]; e != c.edges.start[I + 1]; ++e)
                    A(long(I), long(c.edges.col[e])) = -double(c.edges.weight[e]);
            }
            coarsest.compute(A);
        }
        if (coarsest.info() != Eigen::Success) throw Error("aggregation multigrid: the coarsest level is not positive definite");
    }

    void solveCoarsest(const float* r, float* x) const {
        const long m = long(coarsest.rows());
        Eigen::VectorXd b(m);
        for (long i = 0; i < m; ++i) b[i] = r[i];
        const Eigen::VectorXd y = coarsest.solve(b);
        for (long i = 0; i < m; ++i) x[i] = float(y[i]);
    }

    /// c.x ≈ A_c⁻¹ c.r on coarse level c (≥ 1, not the coarsest) by two flexible-CG steps preconditioned by its cycle
    /// (Notay & Vassilevski 2008, the K-cycle): the second step is skipped when the first leaves ≤ kKCycleRatio of
    /// the residual.
    void kCycle(std::size_t c, const CoarseLevel& lv) const {
        const std::size_t m = lv.size();
        const float* r = lv.r.data();
        // === First step: v1 = B r, along v1
        cycle(c, r, lv.v1.data());
        lv.apply(lv.v1.data(), lv.w1.data());
        const double rho1 = dot(lv.v1.data(), lv.w1.data(), m), alpha1 = dot(lv.v1.data(), r, m);
        if (!(rho1 > 0)) {  // r = 0 (or rounding at its level): no correction
            std::fill(lv.x.begin(), lv.x.end(), 0.0f);
            return;
        }
        const double a1 = alpha1 / rho1;
        forEach(m, kGrain, [&](std::size_t i) { lv.rt[i] = float(double(r[i]) - a1 * double(lv.w1[i])); });
        const double rr = dot(r, r, m), rtrt = dot(lv.rt.data(), lv.rt.data(), m);
        if (rtrt <= kKCycleRatio * kKCycleRatio * rr) {
            forEach(m, kGrain, [&](std::size_t i) { lv.x[i] = float(a1 * double(lv.v1[i])); });
            return;
        }
        // === Second step: v2 = B r̃, A-orthogonalised against v1
        cycle(c, lv.rt.data(), lv.v2.data());
        lv.apply(lv.v2.data(), lv.w2.data());
        const double gamma = dot(lv.v2.data(), lv.w1.data(), m), beta = dot(lv.v2.data(), lv.w2.data(), m),
                     alpha2 = dot(lv.v2.data(), lv.rt.data(), m);
        const double rho2 = beta - gamma * gamma / rho1;
        if (!(rho2 > 0)) {
            forEach(m, kGrain, [&](std::size_t i) { lv.x[i] = float(a1 * double(lv.v1[i])); });
            return;
        }
        const double c1 = a1 - gamma * alpha2 / (rho1 * rho2), c2 = alpha2 / rho2;
        forEach(m, kGrain, [&](std::size_t i) { lv.x[i] = float(c1 * double(lv.v1[i]) + c2 * double(lv.v2[i])); });
    }

    /// x ≈ A_l⁻¹ r by one cycle from x = 0 on level l (0: L, matrix-free).
    void cycle(std::size_t l, const float* r, float* x) const {
        if (l == levels.size()) {
            solveCoarsest(r, x);
            return;
        }
        const std::size_t size = l == 0 ? n : levels[l - 1].size();
        const float* dinv = l == 0 ? invDiag.data() : levels[l - 1].invDiag.data();
        float* res = l == 0 ? t.data() : levels[l - 1].t.data();
        const float w = float(options.jacobiWeight);
        auto apply = [&](const float* u, float* out) {
            if (l == 0) L.apply(u, out);
            else levels[l - 1].apply(u, out);
        };
        auto residual = [&] {  // res = r − A x
            apply(x, res);
            forEach(size, kGrain, [&](std::size_t i) { res[i] = float(double(r[i]) - double(res[i])); });
        };
        auto sweeps = [&](int count) {
            for (int s = 0; s < count; ++s) {
                residual();
                forEach(size, kGrain, [&](std::size_t i) { x[i] += w * dinv[i] * res[i]; });
            }
        };
        // === Pre-smoothing from x = 0 (its first sweep needs no product)
        forEach(size, kGrain, [&](std::size_t i) { x[i] = w * dinv[i] * r[i]; });
        sweeps(options.smoothingSteps - 1);
        // === Coarse correction: restrict the residual (Pᵀ: sums over each aggregate), cycle, prolong (P: copies,
        // scaled by α: piecewise constants under-correct smooth errors, docs/operators.md#aggregation)
        residual();
        const CoarseLevel& coarse = levels[l];
        const Aggregates& agg = coarse.fromFiner;
        forEach(coarse.size(), kGrain, [&](std::size_t K) {
            double s = 0;
            for (std::uint32_t m = agg.start[K]; m != agg.start[K + 1]; ++m) s += double(res[std::size_t(agg.member[m])]);
            coarse.r[K] = float(s);
        });
        if (options.kCycle && l + 1 < levels.size()) kCycle(l + 1, coarse);
        else cycle(l + 1, coarse.r.data(), coarse.x.data());
        const float alpha = float(options.coarseCorrectionWeight);
        forEach(coarse.size(), kGrain, [&](std::size_t K) {
            for (std::uint32_t m = agg.start[K]; m != agg.start[K + 1]; ++m) x[std::size_t(agg.member[m])] += alpha * coarse.x[K];
        });
        // === Post-smoothing: the pre-smoother's adjoint (the same Jacobi sweeps), so the cycle stays symmetric
        sweeps(options.smoothingSteps);
    }
};

AggregationMultigrid::AggregationMultigrid(const LaplacianOperator& L, const AggregationOptions& options) {
    if (options.smoothingSteps < 1) throw ParameterError("aggregation multigrid: smoothingSteps must be >= 1");
    if (!(options.jacobiWeight > 0 && options.jacobiWeight < 1))
        throw ParameterError("aggregation multigrid: jacobiWeight must lie in (0, 1)");
    if (!(options.coarseCorrectionWeight >= 1 && options.coarseCorrectionWeight < 2))
        throw ParameterError("aggregation multigrid: coarseCorrectionWeight must lie in [1, 2)");
    if (options.maxLevels < 2) throw ParameterError("aggregation multigrid: maxLevels must be >= 2");
    if (options.transposeChunkEntries < 1) throw ParameterError("aggregation multigrid: transposeChunkEntries must be >= 1");
    if (L.size() == 0) throw Error("aggregation multigrid: the band is empty");
    if (options.coarsestUnknowns > kMaxDenseUnknowns)
        throw ParameterError("aggregation multigrid: coarsestUnknowns must be <= " + std::to_string(kMaxDenseUnknowns));
    impl_ = std::make_unique<Impl>(L, options);
}

AggregationMultigrid::~AggregationMultigrid() = default;

void AggregationMultigrid::apply(const float* r, float* z) const { impl_->cycle(0, r, z); }

int AggregationMultigrid::levels() const { return int(impl_->levels.size()) + 1; }

bool AggregationMultigrid::linear() const { return !impl_->options.kCycle || impl_->levels.size() < 2; }

double AggregationMultigrid::operatorComplexity() const {
    double entries = double(impl_->fineEntries);
    for (const CoarseLevel& c : impl_->levels) entries += double(c.edges.entries());
    return impl_->fineEntries ? entries / double(impl_->fineEntries) : 1.0;
}

std::size_t AggregationMultigrid::coarseUnknowns(int level) const {
    return level >= 1 && level <= int(impl_->levels.size()) ? impl_->levels[std::size_t(level - 1)].size() : 0;
}

static const CoarseLevel& coarseLevel(const std::vector<CoarseLevel>& levels, int level) {
    if (level < 1 || level > int(levels.size())) throw ParameterError("aggregation multigrid: no coarse level " + std::to_string(level));
    return levels[std::size_t(level - 1)];
}

void AggregationMultigrid::applyCoarse(int level, const float* u, float* out) const { coarseLevel(impl_->levels, level).apply(u, out); }

std::vector<std::int32_t> AggregationMultigrid::aggregateOf(int level) const {
    const Aggregates& agg = coarseLevel(impl_->levels, level).fromFiner;
    std::vector<std::int32_t> parent(agg.member.size());
    for (std::size_t K = 0; K < agg.count(); ++K)
        for (std::uint32_t m = agg.start[K]; m != agg.start[K + 1]; ++m) parent[std::size_t(agg.member[m])] = std::int32_t(K);
    return parent;
}

std::size_t AggregationMultigrid::memoryBytes() const {
    std::size_t bytes = (impl_->invDiag.capacity() + impl_->t.capacity()) * sizeof(float);
    for (const CoarseLevel& c : impl_->levels) bytes += c.bytes();
    bytes += std::size_t(impl_->coarsest.rows() * impl_->coarsest.cols()) * sizeof(double);
    return bytes;
}

// The green stage's peak beyond the operator, the PCG and the right-hand side, between the two bands measured
// (a thinner band has smaller aggregates, so more coarse unknowns): docs/memory.md#aggregation.
const double kAggregationBytesPerVoxel = 40;

double aggregationBytes(std::size_t n) { return kAggregationBytesPerVoxel * double(n); }

}  // namespace gpisvdb
