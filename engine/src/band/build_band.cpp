#include "gpisvdb/band/build_band.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <tbb/parallel_for.h>

#include "../core/heap_reuse.h"
#include "gpisvdb/band/band_voxel_evaluator.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/stencil/resolution.h"
#include "gpisvdb/stencil/selling.h"

namespace gpisvdb {

namespace {

using openvdb::Coord;

}  // namespace

void checkBandOptions(const BandOptions& o) {
    if (!(o.voxelSize > 0) || !std::isfinite(o.voxelSize))
        throw ParameterError("the voxel size (BandOptions::voxelSize) must be finite and > 0", {"BandOptions::voxelSize"});
    if (!(o.etaRelative > 0) || !std::isfinite(o.etaRelative))
        throw ParameterError("the band threshold η (BandOptions::etaRelative) must be finite and > 0", {"BandOptions::etaRelative"});
    if (!(o.maxAnisotropy >= 1))
        throw ParameterError("the anisotropy cap (BandOptions::maxAnisotropy) must be >= 1", {"BandOptions::maxAnisotropy"});
    if (!std::isfinite(o.iso)) throw ParameterError("the iso-value (BandOptions::iso) must be finite", {"BandOptions::iso"});
    if (o.batchVoxels < 1) throw ParameterError("the batch size (BandOptions::batchVoxels) must be >= 1", {"BandOptions::batchVoxels"});
}

namespace {

Coord voxelOf(const Vec3d& p, double h) {
    const Vec3d k = p / h;
    if (k.cwiseAbs().maxCoeff() > 1e9)
        throw ParameterError(
            "the voxel size is too small for the input's extent (index coordinates beyond 1e9): "
            "use a larger voxel size (BandOptions::voxelSize)",
            {"BandOptions::voxelSize"});
    return Coord(int(std::lround(k.x())), int(std::lround(k.y())), int(std::lround(k.z())));
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// A voxel's Selling stencil of T regularised to anisotropy ≤ maxAnisotropy (docs/math.md#resolution).
VoxelStencil stencilOf(const Mat3d& T, double maxAnisotropy, bool& regularised) {
    const Selling3 s = selling(regularise(T, maxAnisotropy, regularised));
    VoxelStencil st;
    st.count = std::uint8_t(s.count);
    st.width = std::uint8_t(std::min(255, s.width()));
    for (int k = 0; k < s.count; ++k) {
        st.weight[std::size_t(k)] = float(s.weight[std::size_t(k)]);
        for (int d = 0; d < 3; ++d) {
            const int e = s.offset[std::size_t(k)][d];
            if (e < -127 || e > 127) throw Error("Selling offset beyond ±127 despite regularisation");
            st.offset[std::size_t(k)][std::size_t(d)] = std::int8_t(e);
        }
    }
    return st;
}

/// The band's voxels in the order they were found, already in the band's storage (float channels, the stencil), in
/// blocks of fixed size so that growing never copies. assemble() turns them into the Band channel by channel, each
/// channel's blocks freed as soon as it is gathered: the peak is the found voxels plus one channel, not two copies.
class FoundVoxels {
public:
    explicit FoundVoxels(double maxAnisotropy) : maxAnisotropy_(maxAnisotropy) {}

    /// Appends voxels[keep[k]] for every k, in order; their stencils are computed in parallel.
    void append(const std::vector<BandVoxel>& voxels, const std::vector<std::uint32_t>& keep) {
        std::vector<VoxelStencil> stencils(keep.size());
        std::vector<std::uint8_t> regularised(keep.size(), 0);
        tbb::parallel_for(std::size_t(0), keep.size(), [&](std::size_t k) {
            bool changed = false;
            stencils[k] = stencilOf(voxels[keep[k]].T, maxAnisotropy_, changed);
            regularised[k] = changed;
        });
        for (std::size_t k = 0; k < keep.size(); ++k) {
            if (size_ % kBlock == 0) blocks_.emplace_back();
            Block& b = blocks_.back();
            const BandVoxel& v = voxels[keep[k]];
            b.coord.push_back(v.coord);
            b.mu.push_back(float(v.mu));
            const Mat3d& T = v.T;
            b.T.push_back({float(T(0, 0)), float(T(1, 1)), float(T(2, 2)), float(T(0, 1)), float(T(0, 2)), float(T(1, 2))});
            b.mean.push_back(float(v.mean));
            b.stddev.push_back(float(v.stddev));
            b.normal.push_back(openvdb::Vec3f(float(v.normal.x()), float(v.normal.y()), float(v.normal.z())));
            b.stencil.push_back(stencils[k]);
            regularised_ += regularised[k];
            maxStencilL1_ = std::max(maxStencilL1_, int(stencils[k].width));
            ++size_;
        }
    }

    std::size_t size() const { return size_; }

    /// The band: the index tree, its leaf order, then the channels gathered in that order.
    BandResult assemble(double voxelSize, const Progress& progress) && {
        BandResult r;
        Band& b = r.band;
        b.voxelSize = voxelSize;
        b.index = openvdb::Int32Grid::create(-1);
        try {
            b.index->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
        } catch (const openvdb::ArithmeticError&) {
            // OpenVDB refuses linear transforms whose determinant h³ is within 1e-15 of zero (h ≲ 1e-5).
            throw ParameterError("the voxel size (BandOptions::voxelSize) " + numberText(voxelSize) +
                                     " is below what an OpenVDB transform can hold (about 1e-5 world units): rescale "
                                     "the input to larger units (e.g. millimetres instead of metres)",
                                 {"BandOptions::voxelSize"});
        }
        b.index->setName("index");
        if (size_ >= std::size_t(INT32_MAX)) throw Error("a band holds fewer than 2^31 voxels");
        {
            auto acc = b.index->getAccessor();
            for (std::size_t i = 0; i < size_; ++i) {
                const Coord& c = blocks_[i >> kBlockBits].coord[i & (kBlock - 1)];
                if (acc.isValueOn(c)) throw Error("bandFromVoxels: a voxel is listed twice");
                acc.setValue(c, int(i));
            }
        }
        progress.checkInterrupt();
        // === Linear indices in leaf order (OpenVDB's value-on iteration order)
        std::vector<std::uint32_t> source;
        source.reserve(size_);
        for (auto it = b.index->tree().beginValueOn(); it; ++it) {
            source.push_back(std::uint32_t(*it));
            it.setValue(int(source.size() - 1));
        }
        gather(source, b.coord, &Block::coord, progress);
        gather(source, b.stencil, &Block::stencil, progress);
        gather(source, b.T, &Block::T, progress);
        gather(source, b.normal, &Block::normal, progress);
        gather(source, b.mu, &Block::mu, progress);
        gather(source, b.mean, &Block::mean, progress);
        gather(source, b.stddev, &Block::stddev, progress);
        blocks_.clear();
        r.stats.regularised = regularised_;
        r.stats.maxStencilL1 = maxStencilL1_;
        return r;
    }

private:
    static constexpr unsigned kBlockBits = 16;
    static constexpr std::size_t kBlock = std::size_t(1) << kBlockBits;
    struct Block {
        std::vector<Coord> coord;
        std::vector<float> mu, mean, stddev;
        std::vector<std::array<float, 6>> T;
        std::vector<openvdb::Vec3f> normal;
        std::vector<VoxelStencil> stencil;
        Block() {
            coord.reserve(kBlock), mu.reserve(kBlock), mean.reserve(kBlock), stddev.reserve(kBlock);
            T.reserve(kBlock), normal.reserve(kBlock), stencil.reserve(kBlock);
        }
    };

    /// out[i] = the channel of found voxel source[i]; then that channel is freed in every block.
    template <class V, class Member>
    void gather(const std::vector<std::uint32_t>& source, std::vector<V>& out, Member member, const Progress& progress) {
        out.resize(source.size());
        tbb::parallel_for(std::size_t(0), source.size(), [&](std::size_t i) {
            progress.checkInterruptAt(i, 65536);
            out[i] = (blocks_[source[i] >> kBlockBits].*member)[source[i] & (kBlock - 1)];
        });
        for (Block& blk : blocks_) std::vector<V>().swap(blk.*member);
        // Under ScopedHeapReuse the blocks' channels lie in malloc's heap; the next channel's array does not fit in
        // their holes, so the freed pages go back before it is made (else the peak grows by a channel's blocks).
        returnFreedPages();
    }

    double maxAnisotropy_;
    std::vector<Block> blocks_;
    std::size_t size_ = 0;
    std::size_t regularised_ = 0;
    int maxStencilL1_ = 0;
};

BandResult finish(FoundVoxels&& found, const BandOptions& o, const BandStats& stats, const Progress& progress) {
    progress.checkInterrupt();
    const auto t = Clock::now();
    BandResult r = std::move(found).assemble(o.voxelSize, progress.interruptOnly());
    r.band.iso = o.iso;
    const BandStats own = r.stats;
    r.stats = stats;
    r.stats.finishSeconds = since(t);
    r.stats.regularised = own.regularised;
    r.stats.maxStencilL1 = own.maxStencilL1;
    return r;
}

}  // namespace

const char* voxelValuesName(VoxelValues values) {
    switch (values) {
        case VoxelValues::Voxel: return "voxel";
        case VoxelValues::Column: return "column";
        default: return "point";
    }
}

VoxelValues voxelValuesNamed(const std::string& name) {
    for (VoxelValues v : {VoxelValues::Point, VoxelValues::Voxel, VoxelValues::Column})
        if (name == voxelValuesName(v)) return v;
    throw ParameterError(
        "the voxel values (BandOptions::values) must be 'point', 'voxel', 'column' or, for a default band, 'auto' (got '" + name + "')",
        {"BandOptions::values"});
}

std::vector<Coord> sampleVoxels(const Samples& samples, double h) {
    std::vector<Coord> v;
    v.reserve(samples.size());
    for (const auto& p : samples.position) v.push_back(voxelOf(p, h));
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    return v;
}

void checkVoxelBudget(std::size_t evaluated, const BandOptions& o) {
    const double h = o.voxelSize;
    if (o.maxVoxels && evaluated > o.maxVoxels)
        throw MemoryLimitError(
            "the band needs more than " + std::to_string(o.maxVoxels) + " voxels at voxel size " + std::to_string(h) +
                ", beyond the voxel budget (BandOptions::maxVoxels): use a larger voxel size (BandOptions::voxelSize), e.g. " +
                numberText(2 * h) + ", or raise the budget",
            {"BandOptions::maxVoxels", "BandOptions::voxelSize"});
}

const std::array<Coord, kBfsNeighbours>& bfsNeighbourOffsets() {
    static const std::array<Coord, kBfsNeighbours> n = [] {
        std::array<Coord, kBfsNeighbours> a;
        int k = 0;
        for (int i = -1; i <= 1; ++i)
            for (int j = -1; j <= 1; ++j)
                for (int l = -1; l <= 1; ++l)
                    if (i || j || l) a[std::size_t(k++)] = Coord(i, j, l);
        return a;
    }();
    return n;
}

double etaFromSampleMus(std::vector<double> mus, double etaRel, BandStats& stats) {
    std::nth_element(mus.begin(), mus.begin() + long(mus.size() / 2), mus.end());
    stats.medianSampleMu = mus.empty() ? 0.0 : mus[mus.size() / 2];
    if (!(stats.medianSampleMu > 0))
        throw InputError("the surface density vanishes at the samples' voxels (sigma far too small for the voxel size?)");
    stats.etaAbsolute = etaRel * stats.medianSampleMu;
    return stats.etaAbsolute;
}

namespace {

/// η in absolute units: etaRelative × the median μ over the voxels holding samples.
double absoluteEta(const std::vector<BandVoxel>& values, const std::vector<Coord>& sampleVoxels, double etaRel, BandStats& stats) {
    std::vector<double> mus;
    for (const auto& v : values)
        if (std::binary_search(sampleVoxels.begin(), sampleVoxels.end(), v.coord)) mus.push_back(v.mu);
    return etaFromSampleMus(std::move(mus), etaRel, stats);
}

/// One round of either builder: evaluates a BFS level (or a scan box) in batches, keeps the voxels with μ > η
/// (the first round also fixes η, so its voxels wait for it) and hands each kept voxel to `kept` in order.
struct Rounds {
    const BandOptions& options;
    const Progress& progress;
    BandVoxelEvaluator evaluate;
    const std::vector<Coord> sampleVox;
    BandStats stats;
    FoundVoxels found;
    double eta = 0;

    Rounds(const GpisModel& m, const Samples& samples, const BandOptions& o, const Progress& p)
        : options(o), progress(p), evaluate(m, o), sampleVox(sampleVoxels(samples, o.voxelSize)), found(o.maxAnisotropy) {}

    template <class Kept>
    void round(const std::vector<Coord>& coords, Kept&& kept) {
        progress.checkInterrupt();
        stats.evaluated += coords.size();
        checkVoxelBudget(stats.evaluated, options);
        const bool first = stats.levels++ == 0;
        std::vector<BandVoxel> firstRound;
        // In batches: a point's Gaussians do not depend on the other points of its batch (GpisModel::evaluateDense),
        // so neither does the band; the batch bounds the transient memory whatever the size of a BFS level.
        for (std::size_t begin = 0; begin < coords.size(); begin += options.batchVoxels) {
            const std::size_t end = std::min(coords.size(), begin + options.batchVoxels);
            std::vector<BandVoxel> values = evaluate(coords, begin, end, progress.interruptOnly(), stats);
            if (first) {
                firstRound.insert(firstRound.end(), values.begin(), values.end());
                continue;
            }
            keep(values, kept);
        }
        if (first) {
            eta = absoluteEta(firstRound, sampleVox, options.etaRelative, stats);
            keep(firstRound, kept);
        }
        evaluate.nextRound();
    }

private:
    template <class Kept>
    void keep(const std::vector<BandVoxel>& values, Kept& kept) {
        std::vector<std::uint32_t> index;
        for (std::size_t i = 0; i < values.size(); ++i)
            if (keepsVoxel(values[i], eta, options.values)) index.push_back(std::uint32_t(i));
        auto t = Clock::now();
        found.append(values, index);
        stats.kacRiceSeconds += since(t);  // the Selling stencils, with μ and T's other channels
        for (std::uint32_t i : index) kept(values[i].coord);
    }
};

}  // namespace

BandResult bandFromVoxels(std::vector<BandVoxel> voxels, double voxelSize, double maxAnisotropy, const Progress& progress) {
    if (!(voxelSize > 0) || !std::isfinite(voxelSize))
        throw ParameterError("the voxel size (BandOptions::voxelSize) must be finite and > 0", {"BandOptions::voxelSize"});
    if (!(maxAnisotropy >= 1))
        throw ParameterError("the anisotropy cap (BandOptions::maxAnisotropy) must be >= 1", {"BandOptions::maxAnisotropy"});
    if (voxels.size() >= std::size_t(INT32_MAX)) throw Error("a band holds fewer than 2^31 voxels");
    FoundVoxels found(maxAnisotropy);
    std::vector<std::uint32_t> all(voxels.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = std::uint32_t(i);
    progress.checkInterrupt();
    found.append(voxels, all);
    std::vector<BandVoxel>().swap(voxels);
    return std::move(found).assemble(voxelSize, progress);
}

BandResult buildBand(const GpisModel& model, const Samples& samples, const BandOptions& o, const Progress& progress) {
    checkBandOptions(o);
    const ScopedHeapReuse heap;  // every batch allocates and frees ≈ 45 MB of arrays (2^17 voxels)
    const auto start = Clock::now();
    Rounds rounds(model, samples, o, progress);

    // === Seeds: the samples' voxels and their 26 neighbours
    openvdb::MaskGrid visited(false);
    auto seen = visited.getAccessor();
    std::vector<Coord> frontier;
    for (const Coord& c : rounds.sampleVox) {
        for (const Coord& d : bfsNeighbourOffsets())
            if (!seen.isValueOn(c + d)) seen.setValueOn(c + d), frontier.push_back(c + d);
        if (!seen.isValueOn(c)) seen.setValueOn(c), frontier.push_back(c);
    }
    // === Breadth-first search: evaluate the frontier, keep μ > η, visit the kept voxels' new neighbours
    while (!frontier.empty()) {
        std::vector<Coord> next;
        rounds.round(frontier, [&](const Coord& c) {
            for (const Coord& d : bfsNeighbourOffsets())
                if (!seen.isValueOn(c + d)) seen.setValueOn(c + d), next.push_back(c + d);
        });
        frontier.swap(next);
        progress.update("band", 1.0 - 1.0 / (1.0 + 0.1 * rounds.stats.levels));
    }
    std::vector<Coord>().swap(frontier);
    progress.update("band", 1.0);
    rounds.stats.searchSeconds = since(start) - rounds.stats.modelSeconds - rounds.stats.kacRiceSeconds;
    return finish(std::move(rounds.found), o, rounds.stats, progress);
}

BandResult scanBand(const GpisModel& model, const Samples& samples, const BandOptions& o, const Progress& progress) {
    checkBandOptions(o);
    const ScopedHeapReuse heap;  // every batch allocates and frees ≈ 45 MB of arrays (2^17 voxels)
    const auto start = Clock::now();
    Rounds rounds(model, samples, o, progress);
    openvdb::CoordBBox box;
    for (const Coord& c : rounds.sampleVox) box.expand(c);
    box.expand(1);
    openvdb::CoordBBox done;  // empty: nothing scanned yet
    // === Scan the box; grow it while band voxels touch its boundary (the scan must not cut the band)
    for (;;) {
        std::vector<Coord> coords;
        for (auto it = box.begin(); it; ++it)
            if (done.empty() || !done.isInside(*it)) coords.push_back(*it);
        bool touches = false;
        rounds.round(coords, [&](const Coord& c) {
            touches = touches || c.x() == box.min().x() || c.y() == box.min().y() || c.z() == box.min().z() || c.x() == box.max().x() ||
                      c.y() == box.max().y() || c.z() == box.max().z();
        });
        if (!touches) break;
        done = box;
        const Coord dim = box.dim();
        box.expand(std::max({2, dim.x() / 8, dim.y() / 8, dim.z() / 8}));
    }
    rounds.stats.searchSeconds = since(start) - rounds.stats.modelSeconds - rounds.stats.kacRiceSeconds;
    return finish(std::move(rounds.found), o, rounds.stats, progress);
}

}  // namespace gpisvdb
