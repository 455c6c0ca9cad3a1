// gpisvdb geodesic INPUT --source X,Y,Z -o OUT.vdb: geodesic distance on the GPIS by Hamiltonian fast marching
// (paper Sec. 10.2, Eq. 28) and shortest paths to target points.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/paths.h"
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

void addGeodesic(CLI::App& app, Action& action) {
    auto* cmd = app.add_subcommand("geodesic", "Geodesic distance on the GPIS from source points, and shortest paths, as a .vdb");
    struct Args {
        std::string input, output, paths;
        std::vector<std::vector<double>> sources, targets;
        bool stopAtTargets = false;
        BandFlags flags;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("INPUT", a->input, "mesh (.obj .off .ply .stl .vtp) or oriented cloud (.xyz .ply .vtp)")->required();
    cmd->add_option("--source", a->sources, "source point X,Y,Z (world units; repeat for several), snapped to the nearest band voxel")
        ->required()
        ->delimiter(',');
    cmd->add_option("--target", a->targets, "target point X,Y,Z (world units; repeat for several): a shortest path from each");
    cmd->get_option("--target")->delimiter(',');
    cmd->add_option("-o,--output", a->output, "output .vdb (band grids and 'geodesic')")->required();
    cmd->add_option("--paths", a->paths, "shortest paths from the targets, as polylines (.vtp, .obj or .json)");
    cmd->add_flag("--stop-at-targets", a->stopAtTargets, "stop the march once every target is reached (faster; 'geodesic' is then partial)");
    addBandFlags(*cmd, a->flags);
    cmd->footer("Solves sqrt(grad U . T grad U) = 1 with U = 0 at the sources: U is about the surface distance over\n"
                "sqrt(mu), so it grows faster where the surface is uncertain. Voxels not reached are inactive in\n"
                "'geodesic' (background: the largest distance reached) and counted in the report.\n"
                "Example:\n  gpisvdb geodesic bunny.obj --source 0.5,6,1 --target -2,9,0 -o geo.vdb --paths path.vtp --sigma 1");
    cmd->callback([&action, a] {
        action = [a] {
            using Clock = std::chrono::steady_clock;
            const auto start = Clock::now();
            const auto threads = limitThreads(a->flags.model.threads);
            const std::vector<Vec3d> sources = points(a->sources, "--source");
            const std::vector<Vec3d> targets = points(a->targets, "--target");
            if (!a->paths.empty() && targets.empty()) throw ParameterError("--paths needs at least one --target");
            if (a->stopAtTargets && targets.empty()) throw ParameterError("--stop-at-targets needs at least one --target");
            const PathFormat pathFormat = a->paths.empty() ? PathFormat::Json : pathFormatOf(a->paths);
            std::unique_ptr<AtomicOutput> pathsOut;
            if (!a->paths.empty()) pathsOut = std::make_unique<AtomicOutput>(a->paths);
            BandCommand run = startBandCommand(a->input, a->output, a->flags);
            const BandJob& job = run.job;
            const Band& band = job.result.band;

            // === U by fast marching, paths by backtracking
            const auto tSolve = Clock::now();
            GeodesicOptions options;
            options.stopAtTargets = a->stopAtTargets;
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
            const GeodesicResult g = geodesicDistance(band, sources, targets, options, run.progress);
            const double marchPeak = peakResidentBytes();
            const double secondsSolve = std::chrono::duration<double>(Clock::now() - tSolve).count();
            if (g.march.accepted == g.sourceIndex.size() && band.size() > g.sourceIndex.size() && !a->stopAtTargets)
                throw Error("the march did not leave the sources: their stencils reach no band voxel (a band too thin "
                            "for its stencils; try a smaller --voxel-size or a larger --sigma)");

            // === Outputs
            std::vector<float> U(band.size());
            double farthest = 0;
            for (std::size_t i = 0; i < band.size(); ++i) {
                U[i] = float(g.march.distance[i]);
                if (std::isfinite(g.march.distance[i])) farthest = std::max(farthest, g.march.distance[i]);
            }
            openvdb::MetaMap meta = bandMetadata(job, a->flags);
            meta.insertMeta("geodesic_reached", openvdb::Int64Metadata(openvdb::Int64(g.march.accepted)));
            meta.insertMeta("geodesic_unreached", openvdb::Int64Metadata(openvdb::Int64(g.march.unreached)));
            meta.insertMeta("geodesic_sources", openvdb::Int32Metadata(int(sources.size())));
            writeBandVdb(band, run.out->tempPath(), meta, {{"geodesic", &U, float(farthest)}}, {}, a->flags.vdb);
            if (pathsOut) writePaths(g.paths, pathsOut->tempPath(), pathFormat);
            run.out->commit();
            if (pathsOut) pathsOut->commit();
            const double total = std::chrono::duration<double>(Clock::now() - start).count();
            if (run.report) {
                nlohmann::json report = bandReport(job, a->flags);
                nlohmann::json paths = nlohmann::json::array();
                for (std::size_t k = 0; k < g.paths.size(); ++k) {
                    const GeodesicPath& p = g.paths[k];
                    paths.push_back({{"target", {targets[k].x(), targets[k].y(), targets[k].z()}},
                                     {"target_index", g.targetIndex[k]}, {"distance", finiteOrNull(p.distance)},
                                     {"length", p.length}, {"points", p.points.size()}, {"reached_source", p.reachedSource}});
                }
                nlohmann::json src = nlohmann::json::array();
                for (std::size_t k = 0; k < sources.size(); ++k) {
                    const openvdb::Coord c = band.coord[g.sourceIndex[k]];
                    src.push_back({{"point", {sources[k].x(), sources[k].y(), sources[k].z()}},
                                   {"voxel", {c.x(), c.y(), c.z()}}, {"index", g.sourceIndex[k]}});
                }
                report["geodesic"] = {{"method", "Hamiltonian fast marching on Selling stencils, first order"},
                                      {"reached", g.march.accepted}, {"unreached", g.march.unreached},
                                      {"stopped_at_targets", g.march.stoppedEarly}, {"max_distance", farthest},
                                      {"sources", src}, {"paths", paths}};
                report["memory"]["stages"] = {{"geodesic", memoryStageReport(memory, marchPeak, stageOnly)}};
                report["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"solve", secondsSolve},
                                       {"total", total}};
                report["outputs"] = {a->output};
                if (!a->paths.empty()) report["outputs"].push_back(a->paths);
                commitReport(*run.report, report);
            }
            if (!a->flags.model.quiet) {
                std::cerr << "geodesic: " << band.size() << " voxels, " << g.march.accepted << " reached";
                if (g.march.unreached) std::cerr << ", " << g.march.unreached << " not reached";
                for (const GeodesicPath& p : g.paths)
                    std::cerr << "; path length " << p.length << (p.reachedSource ? "" : " (did not reach a source)");
                std::cerr << ", " << total << " s\n";
            }
        };
    });
}

}  // namespace gpisvdb::cli
