#include "gpisvdb/mpi/distributed_band.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>

#include "gpisvdb/band/band_voxel_evaluator.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb::mpi {

namespace {

using openvdb::Coord;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// A found voxel as it travels between ranks: what bandFromVoxels needs, in double, so that the stencils computed
/// from T on the receiving rank are the one-process band's.
struct WireVoxel {
    std::int32_t coord[3];
    std::int32_t unused;
    double mu, T[9], mean, stddev, normal[3];
};

WireVoxel toWire(const BandVoxel& v) {
    WireVoxel w{};
    for (int d = 0; d < 3; ++d) w.coord[d] = v.coord[d], w.normal[d] = v.normal[d];
    w.mu = v.mu, w.mean = v.mean, w.stddev = v.stddev;
    for (int k = 0; k < 9; ++k) w.T[k] = v.T(k / 3, k % 3);
    return w;
}

BandVoxel fromWire(const WireVoxel& w) {
    BandVoxel v;
    v.coord = Coord(w.coord[0], w.coord[1], w.coord[2]);
    v.mu = w.mu, v.mean = w.mean, v.stddev = w.stddev;
    v.normal = Vec3d(w.normal[0], w.normal[1], w.normal[2]);
    for (int k = 0; k < 9; ++k) v.T(k / 3, k % 3) = w.T[k];
    return v;
}

struct WireCoord {
    std::int32_t c[3];
    std::int32_t present;
};

bool coordLess(const Coord& a, const Coord& b) { return treeOrderLess(a, b); }

}  // namespace

TreePartition samplePartition(const Ranks& ranks, const Samples& samples, double h) {
    std::map<Coord, double> weight;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const Vec3d k = samples.position[i] / h;
        weight[leafOrigin(Coord(int(std::lround(k.x())), int(std::lround(k.y())), int(std::lround(k.z()))))] += samples.normal[i].norm();
    }
    return partitionLeaves({weight.begin(), weight.end()}, ranks.size);
}

DistributedBand buildBandDistributed(const Ranks& ranks, const GpisModel& model, const Samples& samples, const BandOptions& o,
                                     const Progress& progress) {
    const auto start = Clock::now();
    const std::size_t P = std::size_t(ranks.size);
    DistributedBand out;
    std::vector<Coord> sampleVox;
    TreePartition search;
    together(ranks, [&] {
        checkBandOptions(o);
        sampleVox = sampleVoxels(samples, o.voxelSize);  // checks the voxel size against the extent
        search = samplePartition(ranks, samples, o.voxelSize);
    });
    BandVoxelEvaluator evaluate(model, o);
    BandStats& stats = out.stats;

    // === Seeds: the samples' voxels and their 26 neighbours, each rank its own
    openvdb::MaskGrid visited(false);
    auto seen = visited.getAccessor();
    std::vector<Coord> frontier, next;
    const auto visit = [&](const Coord& c, std::vector<Coord>& into) {
        if (!seen.isValueOn(c)) seen.setValueOn(c), into.push_back(c);
    };
    for (const Coord& c : sampleVox) {
        for (const Coord& d : bfsNeighbourOffsets())
            if (search.owner(c + d) == ranks.rank) visit(c + d, frontier);
        if (search.owner(c) == ranks.rank) visit(c, frontier);
    }

    // === Breadth-first search: evaluate this rank's frontier, keep μ > η, send each new neighbour to its rank
    std::vector<BandVoxel> kept;
    std::vector<std::vector<Coord>> toRank(P);
    double eta = 0;
    std::size_t evaluatedHere = 0;
    const auto keep = [&](const std::vector<BandVoxel>& values) {
        for (const BandVoxel& v : values) {
            if (!keepsVoxel(v, eta, o.values)) continue;
            kept.push_back(v);
            for (const Coord& d : bfsNeighbourOffsets()) {
                const Coord n = v.coord + d;
                const int owner = search.owner(n);
                if (owner == ranks.rank) visit(n, next);
                else toRank[std::size_t(owner)].push_back(n);
            }
        }
    };
    for (;;) {
        const std::size_t level = sum(ranks, frontier.size());
        if (level == 0) break;
        stats.evaluated += level;
        const bool first = stats.levels++ == 0;
        std::vector<BandVoxel> firstLevel;
        together(ranks, [&] {
            progress.checkInterrupt();
            checkVoxelBudget(stats.evaluated, o);
            evaluatedHere += frontier.size();
            for (std::size_t b = 0; b < frontier.size(); b += o.batchVoxels) {
                std::vector<BandVoxel> values =
                    evaluate(frontier, b, std::min(frontier.size(), b + o.batchVoxels), progress.interruptOnly(), stats);
                if (first) firstLevel.insert(firstLevel.end(), values.begin(), values.end());
                else keep(values);
            }
            evaluate.nextRound();
        });
        if (first) {
            // η: the median μ over all the samples' voxels, whichever rank evaluated them
            std::vector<double> mus;
            for (const BandVoxel& v : firstLevel)
                if (std::binary_search(sampleVox.begin(), sampleVox.end(), v.coord)) mus.push_back(v.mu);
            std::vector<double> all = allGather(ranks, mus);
            together(ranks, [&] {
                eta = etaFromSampleMus(std::move(all), o.etaRelative, stats);
                keep(firstLevel);
            });
        }
        for (auto& list : toRank) {  // a neighbour of several kept voxels is sent once
            std::sort(list.begin(), list.end());
            list.erase(std::unique(list.begin(), list.end()), list.end());
        }
        const std::vector<Coord> received = allToAll(ranks, toRank);
        for (auto& list : toRank) list.clear();
        for (const Coord& c : received) visit(c, next);
        frontier.swap(next);
        next.clear();
        if (ranks.rank == 0) progress.update("band", 1.0 - 1.0 / (1.0 + 0.1 * stats.levels));
    }
    std::vector<Coord>().swap(frontier);
    visited.clear();
    for (std::size_t r : allGather(ranks, std::vector<std::size_t>{kept.size()})) out.searchVoxels.push_back(r);
    for (std::size_t r : allGather(ranks, std::vector<std::size_t>{evaluatedHere})) out.searchEvaluated.push_back(r);
    stats.searchSeconds = since(start) - stats.modelSeconds - stats.kacRiceSeconds;

    // === Balance: rank p receives linear indices [N p / P, N (p + 1) / P) of the band
    const auto tBalance = Clock::now();
    tbb::parallel_sort(kept.begin(), kept.end(), [](const BandVoxel& a, const BandVoxel& b) { return coordLess(a.coord, b.coord); });
    std::size_t N = 0, before = 0;
    for (std::size_t r = 0; r < P; ++r) {
        if (int(r) < ranks.rank) before += out.searchVoxels[r];
        N += out.searchVoxels[r];
    }
    const auto boundary = [&](std::size_t p) { return N * p / P; };
    std::vector<std::vector<WireVoxel>> toOwner(P);
    for (std::size_t p = 0; p < P; ++p) {
        const std::size_t lo = std::max(before, boundary(p)), hi = std::min(before + kept.size(), boundary(p + 1));
        for (std::size_t g = lo; g < hi; ++g) toOwner[p].push_back(toWire(kept[g - before]));
    }
    std::vector<BandVoxel>().swap(kept);
    std::vector<WireVoxel> mine = allToAll(ranks, toOwner);
    std::vector<std::vector<WireVoxel>>().swap(toOwner);
    std::vector<BandVoxel> voxels(mine.size());
    tbb::parallel_for(std::size_t(0), mine.size(), [&](std::size_t i) { voxels[i] = fromWire(mine[i]); });
    std::vector<WireVoxel>().swap(mine);

    // === This rank's band, and where every rank's range starts
    std::vector<WireCoord> firsts = allGather(
        ranks, std::vector<WireCoord>{voxels.empty() ? WireCoord{{0, 0, 0}, 0}
                                                     : WireCoord{{voxels[0].coord.x(), voxels[0].coord.y(), voxels[0].coord.z()}, 1}});
    out.partition.first.assign(P, Coord::max());
    for (std::size_t p = P; p-- > 1;)  // an empty rank starts where the next non-empty one does
        out.partition.first[p] = firsts[p].present ? Coord(firsts[p].c[0], firsts[p].c[1], firsts[p].c[2])
                                                   : (p + 1 < P ? out.partition.first[p + 1] : Coord::max());
    out.counts.resize(P);
    for (std::size_t p = 0; p < P; ++p) out.counts[p] = boundary(p + 1) - boundary(p);
    out.offset = boundary(std::size_t(ranks.rank));
    out.globalSize = N;
    BandResult local;
    together(ranks, [&] { local = bandFromVoxels(std::move(voxels), o.voxelSize, o.maxAnisotropy, progress.interruptOnly()); });
    out.local = std::move(local.band);
    out.local.iso = o.iso;
    stats.regularised = sum(ranks, local.stats.regularised);
    stats.maxStencilL1 = int(max(ranks, std::size_t(local.stats.maxStencilL1)));
    out.balanceSeconds = since(tBalance);
    stats.finishSeconds = out.balanceSeconds;
    stats.modelSeconds = max(ranks, stats.modelSeconds);
    stats.kacRiceSeconds = max(ranks, stats.kacRiceSeconds);
    stats.searchSeconds = max(ranks, stats.searchSeconds);
    if (ranks.rank == 0) progress.update("band", 1.0);
    return out;
}

namespace {

template <class Wire, class Value, class Convert>
void gatherInto(const Ranks& ranks, const std::vector<Value>& local, std::vector<Value>& out, Convert convert) {
    std::vector<Wire> mine(local.size());
    for (std::size_t i = 0; i < local.size(); ++i) std::memcpy(&mine[i], &local[i], sizeof(Wire));
    std::vector<Wire> all = gatherToRoot(ranks, mine);
    out.resize(all.size());
    for (std::size_t i = 0; i < all.size(); ++i) out[i] = convert(all[i]);
}

}  // namespace

Band gatherBand(const Ranks& ranks, const DistributedBand& d) {
    Band b;
    b.voxelSize = d.local.voxelSize;
    b.iso = d.local.iso;
    using C3 = std::array<std::int32_t, 3>;
    using F3 = std::array<float, 3>;
    static_assert(sizeof(openvdb::Coord) == sizeof(C3) && sizeof(openvdb::Vec3f) == sizeof(F3));
    gatherInto<C3>(ranks, d.local.coord, b.coord, [](const C3& c) { return Coord(c[0], c[1], c[2]); });
    gatherInto<F3>(ranks, d.local.normal, b.normal, [](const F3& v) { return openvdb::Vec3f(v[0], v[1], v[2]); });
    b.mu = gatherToRoot(ranks, d.local.mu);
    b.T = gatherToRoot(ranks, d.local.T);
    b.mean = gatherToRoot(ranks, d.local.mean);
    b.stddev = gatherToRoot(ranks, d.local.stddev);
    b.stencil = gatherToRoot(ranks, d.local.stencil);
    b.index = openvdb::Int32Grid::create(-1);
    b.index->setTransform(d.local.index->transform().copy());
    b.index->setName("index");
    auto acc = b.index->getAccessor();
    for (std::size_t i = 0; i < b.coord.size(); ++i) acc.setValue(b.coord[i], int(i));  // already in linear order
    return b;
}

}  // namespace gpisvdb::mpi
