// gpisvdb demo [-o DIR]: the main job on the built-in input, the idea of paper Fig. 8. A torus soup with a slab of
// its ring cut away (data missing there) is processed at three σ: the band, the Green's function, the geodesic
// distance with a shortest path between points on either side of the gap, and the lowest eigenfunctions. Near the
// data every result follows the mean surface; across the gap it depends on σ (at small σ the GPIS is not closed
// there and the path goes round the ring, at larger σ it bridges the gap and the path crosses it).
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/output/paths.h"
#include "gpisvdb/output/render.h"
#include "gpisvdb/output/slice_contour.h"
#include "gpisvdb/tasks/geodesic.h"
#include "gpisvdb/tasks/green.h"
#include "gpisvdb/tasks/plausible_surfaces.h"
#include "memory_stage.h"
#include "render_memory.h"
#include "spectrum_job.h"

namespace gpisvdb::cli {

namespace {

namespace fs = std::filesystem;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// === The built-in input: torus (ring 1, tube 0.4) without the slab x > 0, |y| < 0.3
const Vec3d kGapLo(0, -0.3, -1), kGapHi(2, 0.3, 1);
constexpr double kDeg = 3.14159265358979323846 / 180;
// Source and target on top of the tube, 40° either side of the gap's middle: the short way crosses the gap.
const Vec3d kSource(std::cos(-40 * kDeg), std::sin(-40 * kDeg), 0.4);
const Vec3d kTarget(std::cos(40 * kDeg), std::sin(40 * kDeg), 0.4);
// The plausible sections: draws of the GPIS cut by the plane z = 0, through the ring and the gap.
const SliceSpec kSection{2, 0.0};
constexpr int kSectionDraws = 8;
constexpr std::uint64_t kSectionSeed = 1;

TriangleSoup demoShape() { return cutBox(torus(64, 24), kGapLo, kGapHi); }

bool crossesGap(const GeodesicPath& p) {
    for (const Vec3d& x : p.points)
        if (x.x() > 0.5 && std::abs(x.y()) < 0.5 * (kGapHi.y() - kGapLo.y())) return true;
    return false;
}

struct DemoArgs {
    std::string dir = "demo-output";
    std::vector<double> sigmas{0.5, 1.5, 3.0};
    double voxelSize = 0;  ///< 0: the default rule at each σ (as every command), else this h for all
    int eigenCount = 4;
    int pictureWidth = 420;
    int threads = 0;
    bool quiet = false;
    bool half = false;
    std::string maxMemory;  ///< --max-memory: "8G", "512M", "1e9"; empty: half the RAM
};

/// One σ's results, kept for the pictures and the summary.
struct SigmaRun {
    double sigmaRel = 0, sigma = 0;
    std::string subdir;
    std::size_t voxels = 0;
    double voxelSize = 0;
    double mass = 0;
    int greenIterations = 0;
    GeodesicPath path;
    bool pathCrossesGap = false;
    std::vector<double> eigenvalues;
    SurfaceMesh surface;
    openvdb::FloatGrid::Ptr mu;
    openvdb::FloatGrid::Ptr occupancy;                          ///< P(inside), for the sections' ground
    std::vector<std::vector<Vec3d>> meanSection;                ///< {γ = u} on the plane kSection
    std::vector<std::vector<std::vector<Vec3d>>> drawSections;  ///< {γ + J ε_k = u} on it, per draw
    nlohmann::json timings;
    nlohmann::json memory;  ///< memory.stages.<green|geodesic|spectrum>: estimated and measured (docs/memory.md#demo)
};

std::string sigmaText(double s) {
    std::ostringstream o;
    o << s;
    return o.str();
}

/// Green's function from the source (Alg. 1); each stage's memory is estimated and refused before it allocates, as
/// the commands do, and measured over it (docs/memory.md#demo).
GreenResult demoGreen(const BandJob& job, SigmaRun& run, const Progress& progress) {
    const auto t = Clock::now();
    const Band& band = job.result.band;
    PcgOptions pcg;
    pcg.tolerance = 1e-5;  // pictures need far less than the default 1e-6
    const MemoryEstimate memory = estimateStage(
        job, "Green's function solve",
        greenSolveBytes(band.size(), pcg,
                        resolvePreconditioner(pcg.preconditioner, band.size(), /*assemblable*/ true, /*bandLaplacian*/ true)));
    const bool stageOnly = resetPeakResident();
    const LaplacianOperator L(band);
    GreenResult green = greensFunction(band, L, kSource, pcg, progress);
    run.memory["green"] = memoryStageReport(memory, peakResidentBytes(), stageOnly);
    requireConverged(green.solver, pcg);
    run.greenIterations = green.solver.iterations;
    run.timings["green"] = since(t);
    return green;
}

/// Geodesic distance from the source, shortest path from the target (Eq. 28).
GeodesicResult demoGeodesic(const BandJob& job, SigmaRun& run, const Progress& progress) {
    const auto t = Clock::now();
    const MemoryEstimate memory = estimateStage(job, "fast march", {{"fast_marching", geodesicMarchBytes(job.result.band)}});
    const bool stageOnly = resetPeakResident();
    GeodesicResult geo = geodesicDistance(job.result.band, {kSource}, {kTarget}, {}, progress);
    run.memory["geodesic"] = memoryStageReport(memory, peakResidentBytes(), stageOnly);
    run.path = geo.paths.front();
    run.pathCrossesGap = crossesGap(run.path);
    run.timings["geodesic"] = since(t);
    return geo;
}

/// Lowest eigenpairs (Sec. 10.1), each vector as a band channel.
std::vector<std::vector<float>> demoSpectrum(const BandJob& job, const DemoArgs& a, SigmaRun& run, const Progress& progress) {
    const auto t = Clock::now();
    EigenOptions eo;
    eo.count = a.eigenCount;
    nlohmann::json spectrumStage;
    const EigenResult eigen = runSpectrum(job, eo, progress, &spectrumStage);
    run.memory["spectrum"] = spectrumStage;
    run.timings["spectrum"] = since(t);
    std::vector<std::vector<float>> vectors(std::size_t(eigen.values.size()));
    for (Eigen::Index i = 0; i < eigen.values.size(); ++i) {
        vectors[std::size_t(i)].assign(eigen.vectors.col(i).data(), eigen.vectors.col(i).data() + eigen.vectors.rows());
        run.eigenvalues.push_back(eigen.values(i));
    }
    return vectors;
}

/// Plausible sections: kSectionDraws draws of the field on the band's layer at z = 0 (a few % of its voxels), each
/// one's level line u there (docs/uncertainty.md#plausible-surfaces).
void demoSections(const BandJob& job, SigmaRun& run, const Progress& progress) {
    const auto t = Clock::now();
    const Band& band = job.result.band;
    const int layer = int(std::lround(kSection.value / band.voxelSize));
    std::vector<std::size_t> layerVoxels;
    for (std::size_t i = 0; i < band.size(); ++i)
        if (band.coord[i][kSection.axis] == layer) layerVoxels.push_back(i);
    SurfaceDrawOptions drawOptions;
    drawOptions.count = kSectionDraws;
    drawOptions.seed = kSectionSeed;
    const Samples& samples = job.model->input.samples;
    std::vector<float> layerMean;
    for (std::size_t i : layerVoxels) layerMean.push_back(band.mean[i]);
    const auto meanLayer = drawGrid(band, layerVoxels, layerMean);
    const MemoryEstimate memory = estimateStage(job, "plausible sections",
                                                {{"draws' noise and tree", SurfaceDraws::bytes(samples.size(), drawOptions)},
                                                 {"draws' values on the slice", 4.0 * kSectionDraws * double(layerVoxels.size())},
                                                 {"draw's grid", double(meanLayer->memUsage())}});  // one at a time, the mean's topology
    const bool stageOnly = resetPeakResident();
    if (!layerVoxels.empty()) {
        const SurfaceDraws draws(samples, job.model->smoothing, drawOptions);
        const std::vector<std::vector<float>> fields = draws.onBand(band, layerVoxels, progress);
        run.meanSection = sliceContour(*meanLayer, kSection, band.iso);
        for (const auto& f : fields) run.drawSections.push_back(sliceContour(*drawGrid(band, layerVoxels, f), kSection, band.iso));
    }
    run.memory["sections"] = memoryStageReport(memory, peakResidentBytes(), stageOnly);
    run.timings["sections"] = since(t);
}

/// Outputs: the .vdb, the mean surface with every scalar field, the path.
void writeDemoOutputs(const BandJob& job, const BandFlags& flags, const std::vector<NamedChannel>& channels,
                      const std::vector<GeodesicPath>& paths, const fs::path& dir, SigmaRun& run) {
    const auto t = Clock::now();
    const openvdb::GridPtrVec grids = bandGrids(job.result.band, channels, {}, flags.vdb);
    openvdb::MetaMap meta = bandMetadata(job, flags);
    meta.insertMeta("green_source", openvdb::Vec3DMetadata(openvdb::Vec3d(kSource.data())));
    meta.insertMeta("geodesic_target", openvdb::Vec3DMetadata(openvdb::Vec3d(kTarget.data())));
    for (std::size_t i = 0; i < run.eigenvalues.size(); ++i)
        meta.insertMeta(eigenGridName(int(i)) + "_eigenvalue", openvdb::DoubleMetadata(run.eigenvalues[i]));
    writeVdb(grids, (dir / "gpis.vdb").string(), meta, flags.vdb);
    openvdb::FloatGrid::Ptr mean;
    for (const auto& g : grids) {
        if (g->getName() == "mean") mean = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        if (g->getName() == "mu") run.mu = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        if (g->getName() == flags.vdb.occupancyName) run.occupancy = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
    }
    run.surface = meanSurface(*mean, job.options.iso);
    for (const auto& g : grids)
        if (g->isType<openvdb::FloatGrid>() && g->getName() != "mean" && g->getName() != "stencil_width") sampleAtVertices(run.surface, *g);
    writeMesh(run.surface, (dir / "surface.vtp").string(), MeshFormat::Vtp);
    writePaths(paths, (dir / "path.vtp").string(), PathFormat::Vtp);
    run.timings["outputs"] = since(t);
}

/// One σ of the demo: the band, then each task on it, then its outputs in `tmp`/sigma-σ.
SigmaRun runSigma(const InputData& data, double sigmaRel, const DemoArgs& a, const fs::path& tmp, const Progress& progress) {
    SigmaRun run;
    run.sigmaRel = sigmaRel;
    run.subdir = "sigma-" + sigmaText(sigmaRel);
    fs::create_directory(tmp / run.subdir);
    BandFlags flags;
    flags.model.sigmaRel = sigmaRel;
    flags.model.quiet = a.quiet;
    flags.band.voxelSize = a.voxelSize;
    flags.vdb.halfFloat = a.half;
    flags.maxMemory = a.maxMemory;
    const BandJob job = runBand(data, flags, progress);
    const Band& band = job.result.band;
    run.sigma = job.model->input.sigma;
    run.voxels = band.size();
    run.voxelSize = job.options.voxelSize;
    run.mass = band.mass();
    run.timings["band"] = job.secondsBand;
    const GreenResult green = demoGreen(job, run, progress);
    const GeodesicResult geo = demoGeodesic(job, run, progress);
    std::vector<float> U(band.size());
    for (std::size_t i = 0; i < band.size(); ++i) U[i] = float(geo.march.distance[i]);
    const std::vector<std::vector<float>> vectors = demoSpectrum(job, a, run, progress);
    std::vector<NamedChannel> channels{{"green", &green.values}, {"geodesic", &U}};
    for (std::size_t i = 0; i < vectors.size(); ++i) channels.push_back({eigenGridName(int(i)), &vectors[i]});
    demoSections(job, run, progress);
    writeDemoOutputs(job, flags, channels, geo.paths, tmp / run.subdir, run);
    return run;
}

/// Rows μ, Green, geodesic with its path, first non-constant eigenfunction, μ on the slice z = 0, the plausible
/// sections over P(inside) on it; columns σ.
void comparisonPicture(const std::vector<SigmaRun>& runs, const DemoArgs& a, const std::string& path) {
    std::vector<RenderPanel> panels;
    auto row = [&](auto make) {
        for (const SigmaRun& r : runs) panels.push_back(make(r));
    };
    const std::string eigen = eigenGridName(a.eigenCount > 1 ? 1 : 0);
    row([](const SigmaRun& r) {
        RenderPanel p;
        p.title = "sigma = " + sigmaText(r.sigmaRel) + " l: density mu";
        p.surface = &r.surface, p.array = "mu", p.colormap = Colormap::Magma;
        return p;
    });
    row([](const SigmaRun& r) {
        RenderPanel p;
        p.title = "Green's function (log)";
        p.surface = &r.surface, p.array = "green", p.logScale = true;
        return p;
    });
    row([](const SigmaRun& r) {
        RenderPanel p;
        std::ostringstream t;
        t << "geodesic distance, path " << std::setprecision(3) << r.path.length
          << (r.pathCrossesGap ? " (across the gap)" : " (round the ring)");
        p.title = t.str();
        p.surface = &r.surface, p.array = "geodesic", p.paths = {r.path.points};
        return p;
    });
    row([&](const SigmaRun& r) {
        RenderPanel p;
        p.title = "eigenfunction " + eigen.substr(6);
        p.surface = &r.surface, p.array = eigen, p.colormap = Colormap::Coolwarm, p.symmetric = true;
        return p;
    });
    row([](const SigmaRun& r) {
        RenderPanel p;
        p.title = "mu on the slice z = 0";
        p.sliceGrid = r.mu.get(), p.slice = kSection, p.colormap = Colormap::Magma;
        return p;
    });
    row([](const SigmaRun& r) {
        // matplotlib's tab10, without its grey: told apart on the light ground
        static const std::array<double, 3> kColours[] = {{0.12, 0.47, 0.71}, {1.00, 0.50, 0.05}, {0.17, 0.63, 0.17}, {0.84, 0.15, 0.16},
                                                         {0.58, 0.40, 0.74}, {0.55, 0.34, 0.29}, {0.89, 0.47, 0.76}, {0.09, 0.75, 0.81}};
        RenderPanel p;
        p.title = "P(inside); " + std::to_string(r.drawSections.size()) + " plausible sections, mean black";
        p.sliceGrid = r.occupancy.get(), p.slice = kSection, p.colormap = Colormap::Greys, p.range = {0.0, 1.0};
        for (std::size_t k = 0; k < r.drawSections.size(); ++k)
            p.sliceLines.push_back({r.drawSections[k], kColours[k % std::size(kColours)], 1.5});
        p.sliceLines.push_back({r.meanSection, {0, 0, 0}, 3.0});
        return p;
    });
    RenderOptions o;
    o.columns = int(runs.size());
    o.panelWidth = a.pictureWidth;
    o.panelHeight = a.pictureWidth * 5 / 6;
    o.caption = "gpisvdb demo: torus with the slab x > 0, |y| < 0.3 cut away; columns: sigma = ";
    for (std::size_t i = 0; i < runs.size(); ++i) o.caption += (i ? ", " : "") + sigmaText(runs[i].sigmaRel);
    o.caption += " x l; voxel size ";
    for (std::size_t i = 0; i < runs.size(); ++i) o.caption += (i ? ", " : "") + sigmaText(runs[i].voxelSize);
    renderPng(panels, o, path, makeProgress(true));
}

void inputPicture(const TriangleSoup& soup, const DemoArgs& a, const std::string& path) {
    SurfaceMesh mesh;
    for (const Vec3d& v : soup.vertices) mesh.vertices.emplace_back(float(v.x()), float(v.y()), float(v.z()));
    mesh.triangles = soup.triangles;
    RenderPanel p;
    p.title = "input: " + std::to_string(soup.triangles.size()) + " triangles, a gap at +x";
    p.surface = &mesh;
    p.paths = {{kSource, kSource + Vec3d(0, 0, 0.15)}, {kTarget, kTarget + Vec3d(0, 0, 0.15)}};
    RenderOptions o;
    o.panelWidth = a.pictureWidth;
    o.panelHeight = a.pictureWidth * 5 / 6;
    renderPng({p}, o, path, makeProgress(true));
}

void writeSummary(const std::vector<SigmaRun>& runs, const DemoArgs& a, double ell, double seconds, const std::string& path) {
    std::ofstream s(path);
    s << "# gpisvdb demo\n\n"
      << "Input: a torus soup (ring radius 1, tube radius 0.4) with the slab x > 0, |y| < 0.3 of its ring cut away "
         "(data missing there); length scale l = "
      << ell
      << ". Each column of the picture is one noise level sigma "
         "(relative to l); voxel size "
      << (a.voxelSize > 0 ? "fixed by --voxel-size" : "by the default rule at each sigma") << ".\n\n"
      << "![input](input.png)\n\n![comparison](comparison.png)\n\n"
      << "| sigma / l | voxel size | band voxels | expected area (sum mu h^3) | Green PCG iterations | path length | path | eigenvalues |\n"
      << "|---|---|---|---|---|---|---|---|\n";
    for (const SigmaRun& r : runs) {
        s << "| " << r.sigmaRel << " | " << r.voxelSize << " | " << r.voxels << " | " << std::setprecision(4) << r.mass << " | "
          << r.greenIterations << " | " << r.path.length << " | " << (r.pathCrossesGap ? "across the gap" : "round the ring") << " |";
        for (double l : r.eigenvalues) s << " " << l;
        s << " |\n";
    }
    s << "\nNear the data every field follows the mean surface whatever sigma; across the gap the GPIS is "
         "uncertain: at small sigma its density mu there is too low for the band to close it, and the shortest path "
         "goes round the ring; at larger sigma the band bridges the gap and the path crosses it. The last row cuts "
         "the plane z = 0: the probability of being inside in grey, the mean surface's trace in black and, in colour, "
         "the traces of "
      << kSectionDraws << " plausible surfaces (draws of the GPIS, seed " << kSectionSeed
      << "): they "
         "agree near the data and scatter across the gap.\n\n"
      << "Files, per sigma in `sigma-<s>/`: `gpis.vdb` (band grids mu, mean, stddev, T_diag, T_offdiag, normal, "
         "stencil_width, and green, geodesic, eigen_000...), `surface.vtp` (the mean surface with every scalar "
         "field), `path.vtp` (the shortest path); `report.json` (all numbers). Ran in "
      << std::setprecision(3) << seconds << " s.\n\nReproduce: `" << commandLine() << "`\n";
    if (!s) throw OutputError(path + ": cannot write the summary");
}

/// The flags of `gpisvdb demo`.
void addFlags(CLI::App& cmd, DemoArgs& a) {
    cmd.add_option("-o,--output", a.dir, "output directory (created if missing; files of the same names are replaced)")
        ->capture_default_str();
    cmd.add_option("--sigma", a.sigmas, "noise levels sigma, relative to the length scale l (> 0; one picture column each)")
        ->expected(1, 6)
        ->capture_default_str();
    cmd.add_option("--voxel-size", a.voxelSize,
                   "voxel size h in world units for every sigma (the torus' ring has radius 1; default: the default rule at each sigma)");
    cmd.add_option("-k,--count", a.eigenCount, "eigenpairs per sigma (1 to 20)")->capture_default_str();
    cmd.add_option("--picture-width", a.pictureWidth, "pixels per picture panel (64 to 2000)")->capture_default_str();
    cmd.add_flag("--half", a.half, "store the .vdb grids as 16-bit floats");
    cmd.add_option("--threads", a.threads, "worker threads (0 = all cores)")->capture_default_str();
    cmd.add_flag("--quiet", a.quiet, "no progress bars or summary lines");
    cmd.add_option("--max-memory", a.maxMemory,
                   "refuse a band, solve or picture needing more memory than this, e.g. 8G (default: half the RAM)");
}

void checkFlags(const DemoArgs& a) {
    for (double s : a.sigmas)
        if (!(s > 0) || !std::isfinite(s)) throw ParameterError("--sigma must be finite and > 0 (got " + numberText(s) + ")");
    if (a.voxelSize != 0 && !(a.voxelSize >= 0.01 && a.voxelSize <= 0.2))
        throw ParameterError("--voxel-size must be in [0.01, 0.2] for the built-in torus");
    if (a.eigenCount < 1 || a.eigenCount > 20) throw ParameterError("-k must be in [1, 20]");
    if (a.pictureWidth < 64 || a.pictureWidth > 2000) throw ParameterError("--picture-width must be in [64, 2000]");
}

/// The comparison's memory (the larger picture): each surface in its 4 surface panels, the window of 6 panels per
/// sigma (docs/memory.md#demo); the input's picture, made after it, holds less.
MemoryEstimate estimatePictures(const std::vector<SigmaRun>& runs, const DemoArgs& a, double limit) {
    double panelVertices = 0;
    for (const SigmaRun& r : runs) panelVertices += 4.0 * double(r.surface.vertices.size());
    const double panelPixels = double(a.pictureWidth) * double(a.pictureWidth * 5 / 6);
    const double pixels = 6.0 * double(runs.size()) * panelPixels;
    return estimateStageWithin(
        limit, "pictures", "libraries, the results of every sigma", renderBytes(panelVertices, pixels), [&](double need, double available) {
            const double window = pixels * kRenderBytesPerPixel, fixed = need - window;
            const double width = available > fixed ? std::floor(a.pictureWidth * std::sqrt((available - fixed) / window) * 0.95) : 0;
            if (width >= 64) return "use --picture-width " + numberText(width) + " or smaller";
            return "raise it (the renderer alone holds about " + numberText(kRenderContextBytes / 1e6) + " MB)";
        });
}

/// The report: the input, the tasks' settings and each sigma's run.
nlohmann::json demoReport(const std::vector<SigmaRun>& runs, const DemoArgs& a, const TriangleSoup& soup, double ell) {
    nlohmann::json report = {{"input",
                              {{"shape", "torus (ring 1, tube 0.4), 64 x 24 quads"},
                               {"gap_box_min", {kGapLo.x(), kGapLo.y(), kGapLo.z()}},
                               {"gap_box_max", {kGapHi.x(), kGapHi.y(), kGapHi.z()}},
                               {"triangles", soup.triangles.size()},
                               {"length_scale", ell}}},
                             {"voxel_size", a.voxelSize > 0 ? nlohmann::json(a.voxelSize) : nlohmann::json("default rule per sigma")},
                             {"source", {kSource.x(), kSource.y(), kSource.z()}},
                             {"target", {kTarget.x(), kTarget.y(), kTarget.z()}},
                             {"plausible_sections", {{"plane", "z = 0"}, {"draws", kSectionDraws}, {"seed", kSectionSeed}}},
                             {"runs", nlohmann::json::array()}};
    for (const SigmaRun& r : runs)
        report["runs"].push_back({{"sigma_rel", r.sigmaRel},
                                  {"sigma", r.sigma},
                                  {"voxel_size", r.voxelSize},
                                  {"directory", r.subdir},
                                  {"band_voxels", r.voxels},
                                  {"band_mass", r.mass},
                                  {"green_pcg_iterations", r.greenIterations},
                                  {"path",
                                   {{"length", r.path.length},
                                    {"distance", r.path.distance},
                                    {"crosses_gap", r.pathCrossesGap},
                                    {"reached_source", r.path.reachedSource}}},
                                  {"eigenvalues", r.eigenvalues},
                                  {"timings_s", r.timings},
                                  {"memory", {{"stages", r.memory}}}});
    return report;
}

/// `gpisvdb demo` once its flags are parsed.
void execute(DemoArgs& a) {
    const auto start = Clock::now();
    checkFlags(a);
    const double limit = memoryLimit(StageFlags{a.maxMemory, ""});
    AtomicDirectory out(a.dir);
    const fs::path tmp(out.tempPath());
    const Progress progress = makeProgress(a.quiet);
    InputData data;
    data.path = "built-in torus with a gap";
    data.soup = demoShape();
    std::vector<SigmaRun> runs;
    for (double s : a.sigmas) {
        runs.push_back(runSigma(data, s, a, tmp, progress));
        const SigmaRun& r = runs.back();
        if (!a.quiet)
            std::cerr << "demo: sigma = " << s << " l: " << r.voxels << " band voxels, Green " << r.greenIterations
                      << " PCG iterations, path " << r.path.length << (r.pathCrossesGap ? " across the gap" : " round the ring")
                      << ", lambda_0 = " << r.eigenvalues.front() << "\n";
    }
    const auto tPictures = Clock::now();
    const MemoryEstimate picturesMemory = estimatePictures(runs, a, limit);
    const bool picturesOnly = resetPeakResident();
    comparisonPicture(runs, a, (tmp / "comparison.png").string());
    const double picturesPeak = peakResidentBytes();
    inputPicture(*data.soup, a, (tmp / "input.png").string());  // after: the renderer's state it leaves is not the comparison's
    const double secondsPictures = since(tPictures);
    const double ell = makeSamples(data, {}).samples.lengthScale;
    const double total = since(start);
    writeSummary(runs, a, ell, total, (tmp / "summary.md").string());
    nlohmann::json report = demoReport(runs, a, *data.soup, ell);
    report["timings_s"] = {{"pictures", secondsPictures}, {"total", total}};
    report["memory"] = stageReport("pictures", memoryStageReport(picturesMemory, picturesPeak, picturesOnly))["memory"];
    report["command_line"] = commandLine();
    std::ofstream((tmp / "report.json").string()) << report.dump(2) << "\n";
    out.commit();
    if (!a.quiet)
        std::cerr << "demo: wrote " << (fs::path(a.dir) / "summary.md").string() << " and the pictures, .vdb files and meshes beside it, "
                  << std::setprecision(3) << total << " s\n";
}

}  // namespace

void addDemo(CLI::App& app, Action& action) {
    addCommand<DemoArgs>(
        app, action, "demo",
        {"the built-in example: a torus with a gap at three noise levels (band, Green, geodesic, eigenfunctions, pictures)",
         "Writes DIR/summary.md, DIR/report.json, DIR/input.png, DIR/comparison.png and, per sigma,\n"
         "DIR/sigma-<s>/{gpis.vdb, surface.vtp, path.vtp}. About a minute on 2 cores.\n"
         "Examples:\n  gpisvdb demo -o demo-output\n  gpisvdb demo -o quick --sigma 1 --sigma 3 --voxel-size 0.08"},
        addFlags, [](DemoArgs& a) -> int& { return a.threads; }, [](DemoArgs& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
