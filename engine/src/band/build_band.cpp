#include "gpisvdb/band/build_band.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <tbb/parallel_for.h>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/stencil/resolution.h"
#include "gpisvdb/stencil/selling.h"

namespace gpisvdb {

namespace {

using openvdb::Coord;

void checkOptions(const BandOptions& o) {
    if (!(o.voxelSize > 0) || !std::isfinite(o.voxelSize)) throw ParameterError("the voxel size (BandOptions::voxelSize) must be finite and > 0", {"BandOptions::voxelSize"});
    if (!(o.etaRelative > 0) || !std::isfinite(o.etaRelative)) throw ParameterError("the band threshold η (BandOptions::etaRelative) must be finite and > 0", {"BandOptions::etaRelative"});
    if (!(o.maxAnisotropy >= 1))
        throw ParameterError("the anisotropy cap (BandOptions::maxAnisotropy) must be >= 1", {"BandOptions::maxAnisotropy"});
    if (!std::isfinite(o.iso)) throw ParameterError("the iso-value (BandOptions::iso) must be finite", {"BandOptions::iso"});
}

Coord voxelOf(const Vec3d& p, double h) {
    const Vec3d k = p / h;
    if (k.cwiseAbs().maxCoeff() > 1e9)
        throw ParameterError("the voxel size is too small for the input's extent (index coordinates beyond 1e9): "
                             "use a larger voxel size (BandOptions::voxelSize)",
                             {"BandOptions::voxelSize"});
    return Coord(int(std::lround(k.x())), int(std::lround(k.y())), int(std::lround(k.z())));
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Evaluates the GPIS and Kac–Rice at voxel centres h·c, in parallel.
std::vector<BandVoxel> evaluateVoxels(const GpisModel& model, const std::vector<Coord>& coords, double h, double iso,
                                      const QmcRule& rule, const Progress& progress, BandStats& stats) {
    auto t = Clock::now();
    std::vector<Vec3d> xs(coords.size());
    for (std::size_t i = 0; i < coords.size(); ++i) xs[i] = h * Vec3d(coords[i].x(), coords[i].y(), coords[i].z());
    const std::vector<ValueGradient> z = model.evaluate(xs, progress);
    stats.modelSeconds += since(t);
    t = Clock::now();
    std::vector<BandVoxel> out(coords.size());
    tbb::parallel_for(std::size_t(0), coords.size(), [&](std::size_t i) {
        progress.checkInterruptAt(i);
        const SurfaceDensity d = kacRice(z[i], iso, rule);
        const double g = d.meanGradient.norm();
        out[i] = {coords[i], d.mu, d.T, z[i].mean[0], std::sqrt(std::max(0.0, z[i].cov(0, 0))),
                  g > 0 ? Vec3d(-d.meanGradient / g) : Vec3d::Zero()};
    });
    stats.kacRiceSeconds += since(t);
    return out;
}

/// η in absolute units: etaRelative × the median μ over the voxels holding samples.
double absoluteEta(const std::vector<BandVoxel>& values, const std::vector<Coord>& sampleVoxels, double etaRel,
                   BandStats& stats) {
    std::vector<double> mus;
    for (const auto& v : values)
        if (std::binary_search(sampleVoxels.begin(), sampleVoxels.end(), v.coord)) mus.push_back(v.mu);
    std::nth_element(mus.begin(), mus.begin() + long(mus.size() / 2), mus.end());
    stats.medianSampleMu = mus.empty() ? 0.0 : mus[mus.size() / 2];
    if (!(stats.medianSampleMu > 0))
        throw InputError("the surface density vanishes at the samples' voxels (sigma far too small for the voxel size?)");
    stats.etaAbsolute = etaRel * stats.medianSampleMu;
    return stats.etaAbsolute;
}

std::vector<Coord> sampleVoxels(const Samples& samples, double h) {
    std::vector<Coord> v;
    v.reserve(samples.size());
    for (const auto& p : samples.position) v.push_back(voxelOf(p, h));
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    return v;
}

void checkBudget(std::size_t evaluated, const BandOptions& o, double h) {
    if (o.maxVoxels && evaluated > o.maxVoxels)
        throw MemoryLimitError("the band needs more than " + std::to_string(o.maxVoxels) +
                             " voxels at voxel size " + std::to_string(h) +
                             ", beyond the voxel budget (BandOptions::maxVoxels): use a larger voxel size (BandOptions::voxelSize), e.g. " +
                             numberText(2 * h) + ", or raise the budget",
                             {"BandOptions::maxVoxels", "BandOptions::voxelSize"});
}

BandResult finish(std::vector<BandVoxel>&& accepted, const BandOptions& o, const BandStats& stats, const Progress& progress) {
    progress.checkInterrupt();
    const auto t = Clock::now();
    BandResult r = bandFromVoxels(std::move(accepted), o.voxelSize, o.maxAnisotropy, progress.interruptOnly());
    const BandStats own = r.stats;
    r.stats = stats;
    r.stats.finishSeconds = since(t);
    r.stats.regularised = own.regularised;
    r.stats.maxStencilL1 = own.maxStencilL1;
    return r;
}

constexpr int kNeighbours = 26;
const std::array<Coord, kNeighbours>& neighbourOffsets() {
    static const std::array<Coord, kNeighbours> n = [] {
        std::array<Coord, kNeighbours> a;
        int k = 0;
        for (int i = -1; i <= 1; ++i)
            for (int j = -1; j <= 1; ++j)
                for (int l = -1; l <= 1; ++l)
                    if (i || j || l) a[std::size_t(k++)] = Coord(i, j, l);
        return a;
    }();
    return n;
}

/// One round of either builder: evaluates a batch of voxels; the first round also fixes η.
struct Rounds {
    const GpisModel& model;
    const BandOptions& options;
    const Progress& progress;
    const QmcRule rule;
    const std::vector<Coord> sampleVox;
    BandStats stats;
    double eta = 0;

    Rounds(const GpisModel& m, const Samples& samples, const BandOptions& o, const Progress& p)
        : model(m), options(o), progress(p), rule(o.qmcSamples), sampleVox(sampleVoxels(samples, o.voxelSize)) {}

    std::vector<BandVoxel> evaluate(const std::vector<Coord>& coords) {
        progress.checkInterrupt();
        stats.evaluated += coords.size();
        checkBudget(stats.evaluated, options, options.voxelSize);
        std::vector<BandVoxel> values = evaluateVoxels(model, coords, options.voxelSize, options.iso, rule,
                                                       progress.interruptOnly(), stats);
        if (stats.levels++ == 0) eta = absoluteEta(values, sampleVox, options.etaRelative, stats);
        return values;
    }
};

}  // namespace

BandResult bandFromVoxels(std::vector<BandVoxel> voxels, double voxelSize, double maxAnisotropy, const Progress& progress) {
    if (!(voxelSize > 0) || !std::isfinite(voxelSize))
        throw ParameterError("the voxel size (BandOptions::voxelSize) must be finite and > 0", {"BandOptions::voxelSize"});
    if (!(maxAnisotropy >= 1))
        throw ParameterError("the anisotropy cap (BandOptions::maxAnisotropy) must be >= 1", {"BandOptions::maxAnisotropy"});
    BandResult r;
    Band& b = r.band;
    b.voxelSize = voxelSize;
    b.index = openvdb::Int32Grid::create(-1);
    try {
        b.index->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
    } catch (const openvdb::ArithmeticError&) {
        // OpenVDB refuses linear transforms whose determinant h³ is within 1e-15 of zero (h ≲ 1e-5).
        throw ParameterError("the voxel size (BandOptions::voxelSize) " + numberText(voxelSize) +
                                 " is below what an OpenVDB transform can hold (about 1e-5 world units): rescale the "
                                 "input to larger units (e.g. millimetres instead of metres)",
                             {"BandOptions::voxelSize"});
    }
    b.index->setName("index");
    {
        auto acc = b.index->getAccessor();
        for (std::size_t i = 0; i < voxels.size(); ++i) {
            if (acc.isValueOn(voxels[i].coord)) throw Error("bandFromVoxels: a voxel is listed twice");
            acc.setValue(voxels[i].coord, int(i));
        }
    }
    // === Linear indices in leaf order (OpenVDB's value-on iteration order)
    const std::size_t n = voxels.size();
    std::vector<std::size_t> source;
    source.reserve(n);
    for (auto it = b.index->tree().beginValueOn(); it; ++it) {
        source.push_back(std::size_t(*it));
        it.setValue(int(source.size() - 1));
    }
    b.coord.resize(n);
    b.mu.resize(n);
    b.T.resize(n);
    b.mean.resize(n);
    b.stddev.resize(n);
    b.normal.resize(n);
    b.stencil.resize(n);
    std::vector<int> regularised(n, 0);
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
        progress.checkInterruptAt(i, 4096);
        const BandVoxel& v = voxels[source[i]];
        b.coord[i] = v.coord;
        b.mu[i] = float(v.mu);
        const Mat3d& T = v.T;
        b.T[i] = {float(T(0, 0)), float(T(1, 1)), float(T(2, 2)), float(T(0, 1)), float(T(0, 2)), float(T(1, 2))};
        b.mean[i] = float(v.mean);
        b.stddev[i] = float(v.stddev);
        b.normal[i] = openvdb::Vec3f(float(v.normal.x()), float(v.normal.y()), float(v.normal.z()));
        // === Selling stencil of T (regularised for anisotropy; docs/math.md#resolution)
        bool changed = false;
        const Selling3 s = selling(regularise(T, maxAnisotropy, changed));
        regularised[i] = changed;
        VoxelStencil& st = b.stencil[i];
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
    });
    for (std::size_t i = 0; i < n; ++i) {
        r.stats.regularised += std::size_t(regularised[i]);
        r.stats.maxStencilL1 = std::max(r.stats.maxStencilL1, int(b.stencil[i].width));
    }
    return r;
}

BandResult buildBand(const GpisModel& model, const Samples& samples, const BandOptions& o, const Progress& progress) {
    checkOptions(o);
    const auto start = Clock::now();
    Rounds rounds(model, samples, o, progress);

    // === Seeds: the samples' voxels and their 26 neighbours
    openvdb::MaskGrid visited(false);
    auto seen = visited.getAccessor();
    std::vector<Coord> frontier;
    for (const Coord& c : rounds.sampleVox) {
        for (const Coord& d : neighbourOffsets())
            if (!seen.isValueOn(c + d)) seen.setValueOn(c + d), frontier.push_back(c + d);
        if (!seen.isValueOn(c)) seen.setValueOn(c), frontier.push_back(c);
    }
    std::vector<BandVoxel> accepted;
    // === Breadth-first search: evaluate the frontier, keep μ > η, visit the kept voxels' new neighbours
    while (!frontier.empty()) {
        std::vector<BandVoxel> values = rounds.evaluate(frontier);
        frontier.clear();
        for (BandVoxel& v : values) {
            if (!(v.mu > rounds.eta)) continue;
            for (const Coord& d : neighbourOffsets())
                if (!seen.isValueOn(v.coord + d)) seen.setValueOn(v.coord + d), frontier.push_back(v.coord + d);
            accepted.push_back(std::move(v));
        }
        progress.update("band", 1.0 - 1.0 / (1.0 + 0.1 * rounds.stats.levels));
    }
    progress.update("band", 1.0);
    rounds.stats.searchSeconds = since(start) - rounds.stats.modelSeconds - rounds.stats.kacRiceSeconds;
    return finish(std::move(accepted), o, rounds.stats, progress);
}

BandResult scanBand(const GpisModel& model, const Samples& samples, const BandOptions& o, const Progress& progress) {
    checkOptions(o);
    const auto start = Clock::now();
    Rounds rounds(model, samples, o, progress);
    openvdb::CoordBBox box;
    for (const Coord& c : rounds.sampleVox) box.expand(c);
    box.expand(1);
    std::vector<BandVoxel> all;
    openvdb::CoordBBox done;  // empty: nothing scanned yet
    // === Scan the box; grow it while band voxels touch its boundary (the scan must not cut the band)
    for (;;) {
        std::vector<Coord> coords;
        for (auto it = box.begin(); it; ++it)
            if (done.empty() || !done.isInside(*it)) coords.push_back(*it);
        std::vector<BandVoxel> values = rounds.evaluate(coords);
        bool touches = false;
        for (BandVoxel& v : values) {
            if (!(v.mu > rounds.eta)) continue;
            const Coord& c = v.coord;
            touches = touches || c.x() == box.min().x() || c.y() == box.min().y() || c.z() == box.min().z() ||
                      c.x() == box.max().x() || c.y() == box.max().y() || c.z() == box.max().z();
            all.push_back(std::move(v));
        }
        if (!touches) break;
        done = box;
        const Coord dim = box.dim();
        box.expand(std::max({2, dim.x() / 8, dim.y() / 8, dim.z() / 8}));
    }
    rounds.stats.searchSeconds = since(start) - rounds.stats.modelSeconds - rounds.stats.kacRiceSeconds;
    return finish(std::move(all), o, rounds.stats, progress);
}

}  // namespace gpisvdb
