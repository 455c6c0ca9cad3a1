#include "geodesic_job.h"

#include <algorithm>
#include <cmath>
#include <iostream>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/tasks/geodesic.h"

namespace gpisvdb::cli {

namespace {

std::vector<Vec3d> points(const std::vector<std::vector<double>>& flags, const char* name) {
    if (flags.size() > kMaxGeodesicPoints)
        throw ParameterError(std::string(name) + ": at most " + numberText(double(kMaxGeodesicPoints)) + " points, got " +
                             std::to_string(flags.size()));
    std::vector<Vec3d> p;
    for (const auto& v : flags) {
        if (v.size() != 3 || !Vec3d(v[0], v[1], v[2]).allFinite())
            throw ParameterError(std::string(name) + " needs three finite numbers X,Y,Z");
        p.emplace_back(v[0], v[1], v[2]);
    }
    return p;
}

nlohmann::json finiteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

void addGeodesicFlags(CLI::App& cmd_, GeodesicArgs& args) {
    CLI::App* cmd = &cmd_;
    GeodesicArgs* a = &args;
    cmd->add_option("INPUT", a->input, kInputHelp)->required();
    cmd->add_option("--source", a->sources, "source point X,Y,Z (world units; repeat for several), snapped to the nearest band voxel")
        ->required()
        ->delimiter(',');
    cmd->add_option("--target", a->targets, "target point X,Y,Z (world units; repeat for several): a shortest path from each");
    cmd->get_option("--target")->delimiter(',');
    cmd->add_option("-o,--output", a->output, "output .vdb (band grids and 'geodesic')")->required();
    cmd->add_option("--paths", a->paths, "shortest paths from the targets, as polylines (.vtp, .obj or .json)");
    cmd->add_flag("--stop-at-targets", a->stopAtTargets,
                  "stop the march once every target is reached (faster; 'geodesic' is then partial)");
    addBandFlags(*cmd, a->flags);
}

GeodesicRequest geodesicRequest(const GeodesicArgs& a, bool openPaths) {
    GeodesicRequest r;
    r.sources = points(a.sources, "--source");
    r.targets = points(a.targets, "--target");
    if (!a.paths.empty() && r.targets.empty()) throw ParameterError("--paths needs at least one --target");
    if (a.stopAtTargets && r.targets.empty()) throw ParameterError("--stop-at-targets needs at least one --target");
    r.pathFormat = a.paths.empty() ? PathFormat::Json : pathFormatOf(a.paths);
    if (openPaths && !a.paths.empty()) r.pathsOut = std::make_unique<AtomicOutput>(a.paths);
    return r;
}

void finishGeodesic(const BandJob& job, const GeodesicArgs& args, GeodesicRequest& request, AtomicOutput& out, AtomicOutput* report,
                    const Progress& progress, std::chrono::steady_clock::time_point start, const nlohmann::json& extra) {
    const Band& band = job.result.band;
    // === U by fast marching, paths by backtracking
    const auto tSolve = Clock::now();
    GeodesicOptions options;
    options.stopAtTargets = args.stopAtTargets;
    // The march's memory: estimated before it allocates (the resident set now, band included, plus what
    // it allocates), refused beyond --max-memory, and measured over the march (docs/memory.md)
    MemoryEstimate memory;
    memory.baselineBytes = settledResidentBytes();
    memory.parts = {{"fast_marching", geodesicMarchBytes(band)}};
    if (memory.baselineBytes >= job.maxMemory)
        throw MemoryLimitError("before the march this process already holds " + numberText(memory.baselineBytes / 1e6) +
                                   " MB (libraries, input, band), more than the " + numberText(job.maxMemory / 1e6) +
                                   " MB the memory limit (GeodesicOptions::maxBytes) allows: raise it",
                               {"GeodesicOptions::maxBytes"});
    options.maxBytes = job.maxMemory - memory.baselineBytes;
    const bool stageOnly = resetPeakResident();
    const GeodesicResult g = geodesicDistance(band, request.sources, request.targets, options, progress);
    const double marchPeak = peakResidentBytes();
    const double secondsSolve = std::chrono::duration<double>(Clock::now() - tSolve).count();
    if (g.march.accepted == g.sourceIndex.size() && band.size() > g.sourceIndex.size() && !args.stopAtTargets)
        throw Error(
            "the march did not leave the sources: their stencils reach no band voxel (a band too thin "
            "for its stencils; try a smaller --voxel-size or a larger --sigma)");

    // === Outputs
    std::vector<float> U(band.size());
    double farthest = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        U[i] = float(g.march.distance[i]);
        if (std::isfinite(g.march.distance[i])) farthest = std::max(farthest, g.march.distance[i]);
    }
    openvdb::MetaMap meta = bandMetadata(job, args.flags);
    meta.insertMeta("geodesic_reached", openvdb::Int64Metadata(openvdb::Int64(g.march.accepted)));
    meta.insertMeta("geodesic_unreached", openvdb::Int64Metadata(openvdb::Int64(g.march.unreached)));
    meta.insertMeta("geodesic_sources", openvdb::Int32Metadata(int(request.sources.size())));
    writeBandVdb(band, out.tempPath(), meta, {{"geodesic", &U, float(farthest)}}, {}, args.flags.vdb);
    if (request.pathsOut) writePaths(g.paths, request.pathsOut->tempPath(), request.pathFormat);
    out.commit();
    if (request.pathsOut) request.pathsOut->commit();
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    if (report) {
        nlohmann::json json = app::bandReport(job);
        nlohmann::json paths = nlohmann::json::array();
        for (std::size_t k = 0; k < g.paths.size(); ++k) {
            const GeodesicPath& p = g.paths[k];
            paths.push_back({{"target", {request.targets[k].x(), request.targets[k].y(), request.targets[k].z()}},
                             {"target_index", g.targetIndex[k]},
                             {"distance", finiteOrNull(p.distance)},
                             {"length", p.length},
                             {"points", p.points.size()},
                             {"reached_source", p.reachedSource}});
        }
        nlohmann::json src = nlohmann::json::array();
        for (std::size_t k = 0; k < request.sources.size(); ++k) {
            const openvdb::Coord c = band.coord[g.sourceIndex[k]];
            src.push_back({{"point", {request.sources[k].x(), request.sources[k].y(), request.sources[k].z()}},
                           {"voxel", {c.x(), c.y(), c.z()}},
                           {"index", g.sourceIndex[k]}});
        }
        json["geodesic"] = {{"method", "Hamiltonian fast marching on Selling stencils, first order"},
                            {"reached", g.march.accepted},
                            {"unreached", g.march.unreached},
                            {"stopped_at_targets", g.march.stoppedEarly},
                            {"max_distance", farthest},
                            {"sources", src},
                            {"paths", paths}};
        json["memory"]["stages"] = {{"geodesic", memoryStageReport(memory, marchPeak, stageOnly)}};
        json["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"solve", secondsSolve}, {"total", total}};
        json["outputs"] = {args.output};
        if (!args.paths.empty()) json["outputs"].push_back(args.paths);
        for (auto it = extra.begin(); it != extra.end(); ++it) json[it.key()] = it.value();
        commitReport(*report, json);
    }
    if (!args.flags.model.quiet) {
        std::cerr << "geodesic: " << band.size() << " voxels, " << g.march.accepted << " reached";
        if (g.march.unreached) std::cerr << ", " << g.march.unreached << " not reached";
        for (const GeodesicPath& p : g.paths)
            std::cerr << "; path length " << p.length << (p.reachedSource ? "" : " (did not reach a source)");
        std::cerr << ", " << total << " s\n";
    }
}

}  // namespace gpisvdb::cli
