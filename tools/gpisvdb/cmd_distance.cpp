// gpisvdb distance INPUT --alpha A -o OUT.vdb: the smoothed distance to the GPIS (paper Eq. 31, Fig. 11) on a dense
// grid, with an optional level surface.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/tasks/smoothed_distance.h"

namespace gpisvdb::cli {

namespace {

struct Args {
    std::string input, output, mesh;
    double level = std::nan("");
    bool bruteForce = false;
    BandFlags flags;
    SmoothedDistanceOptions distance;
};

/// The flags of `gpisvdb distance`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    cmd.add_option("--alpha", a.distance.alpha, "sharpness alpha (world units^-1, > 0): d -> distance to the band as alpha grows")
        ->required();
    cmd.add_option("-o,--output", a.output, "output .vdb (smoothed_distance; with --level also smoothed_distance_level)")->required();
    cmd.add_option("--grid-voxel-size", a.distance.gridVoxelSize,
                   "voxel size H of the distance grid (world units; default: padded box / 128)");
    cmd.add_option("--padding", a.distance.padding, "margin around the band's box (world units; default 10% of its longest side)");
    cmd.add_option("--distance-tolerance", a.distance.tolerance, "bound on the error of each value (world units, > 0; default H/100)");
    cmd.add_flag("--brute-force", a.bruteForce, "exact sums over all band voxels (the baseline; slow)");
    auto* level = cmd.add_option("--level", a.level, "level D: writes smoothed_distance_level = d - D as a level set");
    cmd.add_option("--mesh", a.mesh, "with --level: the surface d = D as .ply or .vtp")->needs(level);
    addBandFlags(cmd, a.flags);
}

void checkFlags(const Args& a) {
    if (!(a.distance.alpha > 0) || !std::isfinite(a.distance.alpha))
        throw ParameterError("--alpha must be finite and > 0 (world units^-1)");
    if (a.distance.gridVoxelSize < 0 || !std::isfinite(a.distance.gridVoxelSize))
        throw ParameterError("--grid-voxel-size must be finite and > 0");
    if (a.distance.tolerance < 0 || !std::isfinite(a.distance.tolerance))
        throw ParameterError("--distance-tolerance must be finite and > 0");
    if (!std::isnan(a.level) && !std::isfinite(a.level)) throw ParameterError("--level must be finite");
}

/// The distance grid's memory (the k-d tree over the band's voxels, the values, the dense grid and the level set's
/// copy; docs/memory.md#distance), estimated and refused before any of it is allocated.
MemoryEstimate estimateDistance(const Args& a, const BandJob& job) {
    const Band& band = job.result.band;
    const bool levelCopy = !std::isnan(a.level);
    const double h = job.options.voxelSize;
    return estimateStageWithin(
        job.maxMemory, "distance grid", "libraries, input, band", smoothedDistanceBytes(band, a.distance, levelCopy),
        [&](double need, double available) {
            // The grid's leaves and nodes do not shrink as H⁻³: the size that fits is searched, not scaled
            if (const double H = smoothedDistanceGridVoxelSizeWithin(band, a.distance, levelCopy, available); H > 0)
                return "use a grid voxel size (--grid-voxel-size) of " + numberText(H * 1.001) + " or larger";
            return "use a voxel size (--voxel-size) of " + numberText(h * std::cbrt(need / available) * 1.1) +
                   " or larger (no grid voxel size fits beside the tree over the band's voxels and the grid's top-level nodes)";
        });
}

/// The grid d − D as a level set (negative inside the offset shell: OpenVDB's sign convention).
openvdb::FloatGrid::Ptr levelGrid(const SmoothedDistanceResult& r, double level) {
    auto shifted = r.grid->deepCopy();
    shifted->setName("smoothed_distance_level");
    for (auto it = shifted->beginValueOn(); it; ++it) it.setValue(float(*it - level));
    // Outside the box: "far", i.e. outside the shell (positive), as in smoothed_distance.
    shifted->tree().root().setBackground(float(std::max(r.background - level, r.background)), true);
    shifted->setGridClass(openvdb::GRID_LEVEL_SET);
    return shifted;
}

openvdb::MetaMap distanceMetadata(const Args& a, const BandJob& job, const SmoothedDistanceResult& r) {
    openvdb::MetaMap meta = bandMetadata(job, a.flags);
    meta.insertMeta("distance_alpha", openvdb::DoubleMetadata(a.distance.alpha));
    meta.insertMeta("distance_voxel_size", openvdb::DoubleMetadata(r.voxelSize));
    meta.insertMeta("distance_tolerance", openvdb::DoubleMetadata(r.tolerance));
    meta.insertMeta("distance_background", openvdb::DoubleMetadata(r.background));
    if (!std::isnan(a.level)) meta.insertMeta("distance_level", openvdb::DoubleMetadata(a.level));
    return meta;
}

nlohmann::json distanceSection(const Args& a, const Band& band, const SmoothedDistanceResult& r, const SurfaceMesh& mesh) {
    const openvdb::CoordBBox box = r.grid->evalActiveVoxelBoundingBox();
    nlohmann::json section = {{"alpha", a.distance.alpha},  {"voxel_size", r.voxelSize},
                              {"points", r.points},         {"grid_dims", {box.dim().x(), box.dim().y(), box.dim().z()}},
                              {"tolerance", r.tolerance},   {"brute_force", a.bruteForce},
                              {"background", r.background}, {"mean_terms_per_point", r.meanTerms},
                              {"band_voxels", band.size()}};
    if (!std::isnan(a.level)) section["level"] = a.level;
    if (!a.mesh.empty()) section["mesh_triangles"] = mesh.triangles.size();
    return section;
}

/// `gpisvdb distance` once its flags are parsed.
void execute(Args& a, Clock::time_point start) {
    checkFlags(a);
    a.distance.bruteForce = a.bruteForce;
    std::unique_ptr<AtomicOutput> meshOut;
    if (!a.mesh.empty()) {
        meshFormatOf(a.mesh);
        meshOut = std::make_unique<AtomicOutput>(a.mesh);
    }
    BandCommand run = startBandCommand(a.input, a.output, a.flags);
    const BandJob& job = run.job;
    const MemoryEstimate memory = estimateDistance(a, job);
    const bool stageOnly = resetPeakResident();
    const auto tDistance = Clock::now();
    const SmoothedDistanceResult r = smoothedDistanceGrid(job.result.band, a.distance, run.progress);
    const double secondsDistance = std::chrono::duration<double>(Clock::now() - tDistance).count();
    openvdb::GridPtrVec grids{r.grid};
    SurfaceMesh mesh;
    if (!std::isnan(a.level)) grids.push_back(levelGrid(r, a.level));
    if (!std::isnan(a.level) && meshOut) mesh = isoSurface(*r.grid, a.level);
    writeVdb(grids, run.out->tempPath(), distanceMetadata(a, job, r), a.flags.vdb);
    if (meshOut) writeMesh(mesh, meshOut->tempPath(), meshFormatOf(a.mesh));
    const double peak = peakResidentBytes();
    run.out->commit();
    if (meshOut) meshOut->commit();
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    if (run.report) {
        nlohmann::json report = app::bandReport(job);
        report["distance"] = distanceSection(a, job.result.band, r, mesh);
        report["memory"]["stages"] = {{"distance", memoryStageReport(memory, peak, stageOnly)}};
        report["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"distance", secondsDistance}, {"total", total}};
        report["outputs"] = a.mesh.empty() ? nlohmann::json{a.output} : nlohmann::json{a.output, a.mesh};
        commitReport(*run.report, report);
    }
    if (!a.flags.model.quiet)
        std::cerr << "distance: " << r.points << " points, " << r.meanTerms << " terms per point of " << job.result.band.size()
                  << " voxels, " << secondsDistance << " s\n";
}

}  // namespace

void addDistance(CLI::App& app, Action& action) {
    addCommand<Args>(app, action, "distance",
                     {"Smoothed distance to the GPIS on a grid covering it (paper Eq. 31), as a .vdb",
                      "d(x) = -(1/alpha) log sum_j exp(-alpha |x - x_j|) mu(x_j) h^3, summed with a k-d tree within --distance-tolerance.\n"
                      "Example:\n  gpisvdb distance bunny.obj --alpha 20 --level 0.1 --mesh offset.ply -o distance.vdb --sigma 1"},
                     addFlags, bandThreads<Args>, [](Args& a, Clock::time_point start) { execute(a, start); });
}

}  // namespace gpisvdb::cli
