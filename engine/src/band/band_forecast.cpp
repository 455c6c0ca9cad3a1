#include "gpisvdb/band/band_forecast.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "gpisvdb/band/band_voxel_evaluator.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb {

using openvdb::Coord;
using openvdb::CoordBBox;

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
}  // namespace

PilotRegion pilotRegion(const std::vector<Coord>& seeds, int radius, int patches) {
    PilotRegion r;
    if (seeds.empty()) return r;
    // A centre every 1/patches of the seeds, which sampleVoxels sorts by x first: spread along x.
    for (int p = 0; p < patches; ++p) {
        const Coord c = seeds[(2 * std::size_t(p) + 1) * seeds.size() / (2 * std::size_t(patches))];
        r.boxes.emplace_back(c.offsetBy(-radius), c.offsetBy(radius));
    }
    for (const Coord& s : seeds)
        if (r.contains(s)) r.seeds.push_back(s);
    return r;
}

bool PilotRegion::contains(const Coord& c) const {
    return std::any_of(boxes.begin(), boxes.end(), [&](const CoordBBox& b) { return b.isInside(c); });
}

BandForecast forecastBand(const GpisModel& model, const Samples& samples, const DefaultBandPlan& plan, const BandForecastOptions& options,
                          const Progress& progress) {
    if (options.pilotVoxels < 256)
        throw ParameterError(
            "the pilot (BandForecastOptions::pilotVoxels) needs at least 256 voxels (got " + std::to_string(options.pilotVoxels) + ")",
            {"BandForecastOptions::pilotVoxels"});
    if (options.patches < 1)
        throw ParameterError("the pilot needs at least one patch (BandForecastOptions::patches)", {"BandForecastOptions::patches"});
    const BandOptions& o = plan.options;
    const double modelCache = model.expectedDenseCacheBytes();  // before the pilot fills some of it
    const std::vector<Coord> seeds = sampleVoxels(samples, o.voxelSize);
    // === The boxes' size: about pilotVoxels / patches evaluated voxels each, at the plan's estimate of the evaluated
    //     voxels per column across the surface (within 2×: enough to size them), and as wide as the band is thick
    const double h = o.voxelSize;
    const double perColumn = plan.estimate.evaluated * h * h / std::max(plan.resolution.area, 1e-300);
    const double side = std::sqrt(double(options.pilotVoxels) / double(options.patches) / std::max(perColumn, 1.0));
    const int radius = int(std::ceil(std::max({0.5 * side, perColumn, 2.0})));
    const PilotRegion region = pilotRegion(seeds, radius, options.patches);

    // === The pilot: buildBand's search inside the region's boxes, η from the region's seeds
    BandVoxelEvaluator evaluate(model, o);
    const Progress quiet = progress.interruptOnly();
    BandStats stats;
    openvdb::MaskGrid visited(false);
    auto seen = visited.getAccessor();
    std::vector<Coord> frontier;
    const auto visit = [&](const Coord& c) {
        if (region.contains(c) && !seen.isValueOn(c)) seen.setValueOn(c), frontier.push_back(c);
    };
    for (const Coord& s : region.seeds) {
        visit(s);
        for (const Coord& d : bfsNeighbourOffsets()) visit(s + d);
    }
    const std::size_t firstLevel = frontier.size();
    double eta = 0;
    std::size_t kept = 0;
    std::vector<Coord> evaluated;
    while (!frontier.empty()) {
        progress.checkInterrupt();
        const std::vector<BandVoxel> values = evaluate(frontier, 0, frontier.size(), quiet, stats);
        evaluate.nextRound();
        evaluated.insert(evaluated.end(), frontier.begin(), frontier.end());
        if (eta == 0) {
            std::vector<double> mus;
            for (const BandVoxel& v : values)
                if (std::binary_search(region.seeds.begin(), region.seeds.end(), v.coord)) mus.push_back(v.mu);
            eta = etaFromSampleMus(std::move(mus), o.etaRelative, stats);
        }
        frontier.clear();
        for (const BandVoxel& v : values)
            if (keepsVoxel(v, eta, o.values)) {
                ++kept;
                for (const Coord& d : bfsNeighbourOffsets()) visit(v.coord + d);
            }
    }
    // === The time per voxel: the pilot's voxels again, in one call, with the cells' far fields made, as the band's
    //     batches of 2^17 voxels mostly find them (a BFS level of a small box is too small a batch to time); the
    //     faster of two such calls, as other work on the machine only slows one down
    double seconds = std::numeric_limits<double>::infinity();
    for (int repeat = 0; repeat < 2; ++repeat) {
        const auto start = Clock::now();
        BandVoxelEvaluator again(model, o);  // nothing held: the column values' neighbours are evaluated as in the band
        again(evaluated, 0, evaluated.size(), quiet, stats);
        seconds = std::min(seconds, since(start));
    }

    // === The whole band: the pilot's voxels per seed, over all the seeds
    const double perSeed = double(seeds.size()) / double(region.seeds.size());
    BandForecast f;
    f.voxels = double(kept) * perSeed;
    f.evaluated = double(evaluated.size()) * perSeed;
    f.pilotVoxels = evaluated.size();
    f.pilotSeconds = seconds;
    f.secondsPerEvaluated = seconds / double(std::max<std::size_t>(evaluated.size(), 1));
    const double build = bandBuildBytes(f.voxels, f.evaluated, o.batchVoxels, double(firstLevel) * perSeed);
    const double write = bandWriteBytes(f.voxels);
    f.peakBytes = plan.estimate.memory.baselineBytes + std::max(build, write) + modelCache;
    f.buildSeconds = f.evaluated * (f.secondsPerEvaluated + kSearchSecondsPerEvaluatedVoxel) + f.voxels * kFinishSecondsPerBandVoxel;
    f.writeSeconds = f.voxels * kVdbWriteSecondsPerBandVoxel;
    return f;
}

}  // namespace gpisvdb
