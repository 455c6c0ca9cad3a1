#include "gpisvdb/band/band_voxel_evaluator.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/kac_rice_column.h"
#include "gpisvdb/kacrice/kac_rice_voxel.h"

namespace gpisvdb {

namespace {

using openvdb::Coord;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

}  // namespace

/// The Gaussians at voxel centres, in two generations: this round's and the round before's.
struct BandVoxelEvaluator::Centres {
    struct Generation {
        openvdb::Int32Grid::Ptr slot = openvdb::Int32Grid::create(-1);  ///< index into values; −1: not held
        std::vector<ValueGradient> values;
    };
    Generation current, previous;

    const ValueGradient* find(const Coord& c) const {
        for (const Generation* g : {&current, &previous}) {
            const int i = g->slot->tree().getValue(c);
            if (i >= 0) return &g->values[std::size_t(i)];
        }
        return nullptr;
    }
};

BandVoxelEvaluator::BandVoxelEvaluator(const GpisModel& model, const BandOptions& options)
    : model_(model),
      h_(options.voxelSize),
      iso_(options.iso),
      values_(options.values),
      rule_(bandQmcSamples(options)),
      centres_(options.values == VoxelValues::Column ? std::make_unique<Centres>() : nullptr) {}

BandVoxelEvaluator::~BandVoxelEvaluator() = default;

void BandVoxelEvaluator::nextRound() {
    if (!centres_) return;
    centres_->previous = std::move(centres_->current);
    centres_->current = Centres::Generation();
}

namespace {

const std::array<Coord, 6> kFaceOffsets = {Coord(-1, 0, 0), Coord(1, 0, 0),  Coord(0, -1, 0),
                                           Coord(0, 1, 0),  Coord(0, 0, -1), Coord(0, 0, 1)};

std::vector<Vec3d> centresOf(const std::vector<Coord>& coords, std::size_t begin, std::size_t end, double h) {
    std::vector<Vec3d> xs(end - begin);
    for (std::size_t i = begin; i < end; ++i) xs[i - begin] = h * Vec3d(coords[i].x(), coords[i].y(), coords[i].z());
    return xs;
}

BandVoxel bandVoxelOf(const Coord& c, const ValueGradient& z, const SurfaceDensity& d, bool crossed) {
    const double g = d.meanGradient.norm();
    return {c, d.mu, d.T, z.mean[0], std::sqrt(std::max(0.0, z.cov(0, 0))), g > 0 ? Vec3d(-d.meanGradient / g) : Vec3d::Zero(), crossed};
}

}  // namespace

std::vector<BandVoxel> BandVoxelEvaluator::operator()(const std::vector<Coord>& coords, std::size_t begin, std::size_t end,
                                                      const Progress& progress, BandStats& stats) {
    auto t = Clock::now();
    const std::size_t n = end - begin;
    std::vector<BandVoxel> out(n);
    if (values_ != VoxelValues::Column) {
        const std::vector<ValueGradient> z = model_.evaluateDense(centresOf(coords, begin, end, h_), progress);
        stats.modelSeconds += since(t);
        t = Clock::now();
        const bool voxel = values_ == VoxelValues::Voxel;
        tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
            progress.checkInterruptAt(i);
            const SurfaceDensity d = voxel ? kacRiceVoxel(z[i], iso_, h_, rule_) : kacRice(z[i], iso_, rule_);
            out[i] = bandVoxelOf(coords[begin + i], z[i], d, voxel && meanSurfaceCrosses(z[i], iso_, h_));
        });
        stats.kacRiceSeconds += since(t);
        return out;
    }
    // === The Gaussians the columns need: the voxels' own and their face neighbours', where not held yet
    Centres& held = *centres_;
    constexpr int kStencil = 7;  // the voxel and its 6 face neighbours
    std::vector<Coord> need(kStencil * n);
    std::vector<std::uint8_t> missing(kStencil * n);
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
        for (int k = 0; k < kStencil; ++k) {
            const Coord c = k == 0 ? coords[begin + i] : coords[begin + i] + kFaceOffsets[std::size_t(k - 1)];
            need[kStencil * i + std::size_t(k)] = c;
            missing[kStencil * i + std::size_t(k)] = held.find(c) == nullptr;
        }
    });
    std::size_t m = 0;
    for (std::size_t k = 0; k < need.size(); ++k)
        if (missing[k]) need[m++] = need[k];
    need.resize(m);
    tbb::parallel_sort(need.begin(), need.end());
    need.erase(std::unique(need.begin(), need.end()), need.end());
    std::vector<ValueGradient> z = model_.evaluateDense(centresOf(need, 0, need.size(), h_), progress);
    {
        auto slot = held.current.slot->getAccessor();
        const std::size_t first = held.current.values.size();
        for (std::size_t k = 0; k < need.size(); ++k) slot.setValue(need[k], int(first + k));
        if (first == 0) held.current.values = std::move(z);
        else held.current.values.insert(held.current.values.end(), z.begin(), z.end());
    }
    stats.modelSeconds += since(t);
    // === Kac–Rice along each voxel's three axes (kacRiceColumn)
    t = Clock::now();
    const MeanScale scale = model_.meanScale();
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
        progress.checkInterruptAt(i);
        const Coord& c = coords[begin + i];
        ColumnGaussians g;
        g.centre = held.find(c);
        for (std::size_t k = 0; k < 6; ++k) g.neighbour[k] = held.find(c + kFaceOffsets[k]);
        const SurfaceDensity d = kacRiceColumn(g, iso_, scale, rule_);
        out[i] = bandVoxelOf(c, *g.centre, d, false);
    });
    stats.kacRiceSeconds += since(t);
    return out;
}

}  // namespace gpisvdb
