// gpisvdb surfaces INPUT -n 8 -o DIR/: plausible surfaces, the level sets of draws of the GPIS
// (docs/uncertainty.md#plausible-surfaces).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/output/render.h"
#include "gpisvdb/tasks/plausible_surfaces.h"
#include "render_memory.h"

namespace gpisvdb::cli {

namespace {

/// DIR/surface_0007.ply: the draw's index, zero-padded to 4 digits so that the files sort in draw order.
std::string surfaceFileName(int draw, MeshFormat format) {
    char name[32];
    std::snprintf(name, sizeof name, "surface_%04d.%s", draw, format == MeshFormat::Ply ? "ply" : "vtp");
    return name;
}

/// The mean surface and up to three draws side by side, each coloured by the std of φ (sampled from the band), as
/// a PNG at `path`; its memory estimated and refused before VTK allocates (the render's parts, render_memory.h).
/// Returns the report's memory stage.
nlohmann::json drawPicture(const BandJob& job, const openvdb::FloatGrid::Ptr& meanGrid, std::vector<SurfaceMesh>& draws, int firstDraw,
                           const std::string& path) {
    const Band& band = job.result.band;
    SurfaceMesh mean = meanSurface(*meanGrid, band.iso);
    auto stddev = drawGrid(band, band.stddev);
    stddev->setName("stddev");
    double vertices = double(mean.vertices.size());
    for (const SurfaceMesh& m : draws) vertices += double(m.vertices.size());
    constexpr int kWidth = 480, kHeight = 400;
    const double pixels = double(kWidth) * kHeight * double(draws.size() + 1);
    const MemoryEstimate memory = estimateStage(job, "picture", renderBytes(vertices, pixels));
    const bool stageOnly = resetPeakResident();
    std::vector<RenderPanel> panels;
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (float v : band.stddev) lo = std::min(lo, v), hi = std::max(hi, v);
    const auto panel = [&](SurfaceMesh& m, const std::string& title) {
        sampleAtVertices(m, *stddev);
        RenderPanel p;
        p.title = title;
        p.surface = &m, p.array = "stddev", p.colormap = Colormap::Viridis;
        p.range = {lo, hi};  // one scale for every panel
        panels.push_back(p);
    };
    panel(mean, "mean surface (colour: std of phi)");
    for (std::size_t k = 0; k < draws.size(); ++k) panel(draws[k], "draw " + std::to_string(firstDraw + int(k)));
    RenderOptions o;
    o.panelWidth = kWidth, o.panelHeight = kHeight;
    o.caption = "plausible surfaces: level sets u of draws of the GPIS";
    renderPng(panels, o, path, makeProgress(true));
    return memoryStageReport(memory, peakResidentBytes(), stageOnly);
}

struct Args {
    std::string input, dir, format = "ply", picture;
    SurfaceDrawOptions draws;
    BandFlags flags;
};

/// The flags of `gpisvdb surfaces`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    cmd.add_option("-o,--output", a.dir, "output directory (created; files of the same names in it are replaced)")->required();
    cmd.add_option("-n,--count", a.draws.count, "number of draws (1 to 10000)")->capture_default_str();
    cmd.add_option("--seed", a.draws.seed, "random seed: draw k is the same for a seed whatever n, --first or --threads")
        ->capture_default_str();
    cmd.add_option("--first", a.draws.firstDraw, "index of the first draw (draws --first ... --first + n - 1)")->capture_default_str();
    cmd.add_option("--format", a.format, "mesh format: ply (binary, the draw in its header comment) or vtp")
        ->check(CLI::IsMember({"ply", "vtp"}))
        ->capture_default_str();
    cmd.add_option("--draw-beta", a.draws.openingRatio, "the draws' Barnes-Hut opening ratio (> 1; larger is more accurate and slower)")
        ->capture_default_str();
    cmd.add_option("--picture", a.picture,
                   "also a PNG: the mean surface and the first three draws side by side, coloured by the std of phi");
    addBandFlags(cmd, a.flags);
}

void checkFlags(const Args& a) {
    if (a.flags.model.model != "winding")
        throw ParameterError(
            "plausible surfaces are drawn from the winding-number model only (--model winding): "
            "the regression model's draws would need its posterior's factor");
    if (a.draws.count < 1 || a.draws.count > 10000) throw ParameterError("-n must be between 1 and 10000");
    if (a.draws.firstDraw < 0 || a.draws.firstDraw > std::numeric_limits<int>::max() - a.draws.count)
        throw ParameterError("--first must be >= 0, and --first + n must fit an int");
    if (!(a.draws.openingRatio > 1) || !std::isfinite(a.draws.openingRatio)) throw ParameterError("--draw-beta must be finite and > 1");
}

/// Memory, refused before the draws allocate: the noise and the tree, n fields over the band, and one draw's grid and
/// mesh at a time (the mean surface's as their measure: a draw's mesh has ≈ 4 % more triangles on the bunny).
MemoryEstimate estimateSurfaces(const BandJob& job, const Args& a, const openvdb::FloatGrid& meanGrid, MeshFormat format) {
    const Band& band = job.result.band;
    std::vector<std::pair<std::string, double>> parts = {
        {"draws' noise and tree", SurfaceDraws::bytes(job.model->input.samples.size(), a.draws)},
        {"draws' fields", 4.0 * double(a.draws.count) * double(band.size())},
        {"draw's grid", double(meanGrid.memUsage())}};  // one at a time, the band's topology as the mean's
    for (const auto& part : meanSurfaceBytes(meanGrid, band.iso, 0, format == MeshFormat::Vtp))
        parts.push_back({"mesh: " + part.first, part.second});
    return estimateStage(job, "plausible surfaces", std::move(parts));
}

/// The draws' level sets, written into `dir`: each mesh's row of the report, the first three meshes (for the
/// picture, when asked) and the areas' mean and standard deviation.
struct DrawnMeshes {
    nlohmann::json rows = nlohmann::json::array();
    std::vector<SurfaceMesh> shown;
    double meanArea = 0, areaStd = 0;
};

DrawnMeshes writeDrawnMeshes(const Args& a, const Band& band, const std::vector<std::vector<float>>& fields, MeshFormat format,
                             const std::filesystem::path& dir, const Progress& progress) {
    DrawnMeshes d;
    const int n = a.draws.count;
    double areaSum = 0, areaSum2 = 0;
    for (int k = 0; k < n; ++k) {
        progress.checkInterrupt();
        progress.update("meshes", double(k) / n);
        const int draw = a.draws.firstDraw + k;
        SurfaceMesh mesh = meanSurface(*drawGrid(band, fields[std::size_t(k)]), band.iso);
        mesh.comment = "gpisvdb plausible surface: draw " + std::to_string(draw) + " of seed " + std::to_string(a.draws.seed);
        const std::string name = surfaceFileName(draw, format);
        writeMesh(mesh, (dir / name).string(), format);
        const double area = surfaceArea(mesh);
        areaSum += area;
        areaSum2 += area * area;
        d.rows.push_back(
            {{"draw", draw}, {"file", name}, {"vertices", mesh.vertices.size()}, {"triangles", mesh.triangles.size()}, {"area", area}});
        if (!a.picture.empty() && d.shown.size() < 3) d.shown.push_back(std::move(mesh));
    }
    progress.update("meshes", 1.0);
    d.meanArea = areaSum / n;
    d.areaStd = n > 1 ? std::sqrt(std::max(0.0, (areaSum2 - n * d.meanArea * d.meanArea) / (n - 1))) : 0.0;
    return d;
}

/// The report: the band's, with the stage's memory, the draws and their meshes, the timings and the outputs.
nlohmann::json surfacesReport(const BandJob& job, const Args& a, nlohmann::json stages, DrawnMeshes& d, double secondsDraws,
                              double secondsMeshes, double total) {
    nlohmann::json report = app::bandReport(job);
    report["memory"]["stages"] = std::move(stages);
    report["surfaces"] = {{"count", a.draws.count},
                          {"seed", a.draws.seed},
                          {"first", a.draws.firstDraw},
                          {"draw_beta", a.draws.openingRatio},
                          {"expected_area", job.result.band.mass()},
                          {"mean_area", d.meanArea},
                          {"area_std", d.areaStd},
                          {"meshes", std::move(d.rows)}};
    report["timings_s"] = {
        {"model", job.secondsModel}, {"band", job.secondsBand}, {"draws", secondsDraws}, {"meshes", secondsMeshes}, {"total", total}};
    report["outputs"] = {a.dir};
    if (!a.picture.empty()) report["outputs"].push_back(a.picture);
    return report;
}

/// `gpisvdb surfaces` once its flags are parsed.
void execute(Args& a, Clock::time_point start) {
    checkFlags(a);
    const MeshFormat format = a.format == "ply" ? MeshFormat::Ply : MeshFormat::Vtp;
    const InputData data = readInput(a.input);
    AtomicDirectory out(a.dir);
    std::unique_ptr<AtomicOutput> pictureOut = optionalOutput(a.picture), reportOut = optionalOutput(a.flags.report);
    const Progress progress = makeProgress(a.flags.model.quiet);
    const BandJob job = runBand(data, a.flags, progress);
    const Band& band = job.result.band;
    const auto meanGrid = drawGrid(band, band.mean);
    const MemoryEstimate memory = estimateSurfaces(job, a, *meanGrid, format);
    const bool stageOnly = resetPeakResident();

    // === The draws' fields on the band, then each one's level set u
    const auto tDraws = Clock::now();
    const SurfaceDraws draws(job.model->input.samples, job.model->smoothing, a.draws);
    const std::vector<std::vector<float>> fields = draws.onBand(band, progress);
    const double secondsDraws = std::chrono::duration<double>(Clock::now() - tDraws).count();
    const auto tMeshes = Clock::now();
    DrawnMeshes drawn = writeDrawnMeshes(a, band, fields, format, out.tempPath(), progress);
    const double secondsMeshes = std::chrono::duration<double>(Clock::now() - tMeshes).count();
    const double peak = peakResidentBytes();
    nlohmann::json pictureStage;
    if (pictureOut) pictureStage = drawPicture(job, meanGrid, drawn.shown, a.draws.firstDraw, pictureOut->tempPath());
    out.commit();
    if (pictureOut) pictureOut->commit();
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    if (reportOut) {
        nlohmann::json stages = {{"surfaces", memoryStageReport(memory, peak, stageOnly)}};
        if (!pictureStage.is_null()) stages["picture"] = pictureStage;
        commitReport(*reportOut, surfacesReport(job, a, std::move(stages), drawn, secondsDraws, secondsMeshes, total));
    }
    if (!a.flags.model.quiet)
        std::cerr << "surfaces: " << a.draws.count << " draws on " << band.size() << " voxels, area " << numberText(drawn.meanArea)
                  << " +- " << numberText(drawn.areaStd) << " (expected " << numberText(band.mass()) << ") -> " << a.dir << ", " << total
                  << " s\n";
}

}  // namespace

void addSurfaces(CLI::App& app, Action& action) {
    addCommand<Args>(app, action, "surfaces",
                     {"plausible surfaces: meshes of n draws of the GPIS, in a directory",
                      "Each draw is one sample of the noise of the input (positions and normals), mapped through the\n"
                      "linearised model: its field gamma + J eps is evaluated on the band and meshed at u, to\n"
                      "DIR/surface_<k>.ply (k the draw's index). The winding-number model only.\n"
                      "Example:\n  gpisvdb surfaces bunny.obj -n 8 --seed 3 --sigma 2 -o bunny-draws/"},
                     addFlags, bandThreads<Args>, [](Args& a, Clock::time_point start) { execute(a, start); });
}

}  // namespace gpisvdb::cli
