// gpisvdb render FILE.vdb --grid NAME -o OUT.png: a picture of a grid on the mean surface (and on a slice), with a
// colour bar and shortest paths, rendered offscreen by VTK.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/paths.h"
#include "gpisvdb/output/render.h"
#include "memory_stage.h"
#include "render_memory.h"
#include "vdb_file.h"

namespace gpisvdb::cli {

namespace {
constexpr double kMinPanelPixels = 64, kMaxPanelPixels = 8192;

struct Args {
    std::string input, grid, output, colormap = "viridis", slice, paths, title;
    bool logScale = false, symmetric = false, quiet = false;
    int threads = 0;
    std::vector<double> range, view{-35, 35}, size{800, 650};
    double iso = std::numeric_limits<double>::quiet_NaN();
    StageFlags stage;
};

/// The flags of `gpisvdb render`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("FILE", a.input, "a .vdb written by gpisvdb")->required();
    cmd.add_option("--grid", a.grid, "float grid to show, e.g. mu, stddev, green, geodesic, eigen_001")->required();
    cmd.add_option("-o,--output", a.output, "output picture (.png)")->required();
    cmd.add_option("--colormap", a.colormap, "viridis, magma, coolwarm (diverging) or gray")->capture_default_str();
    cmd.add_flag("--log", a.logScale, "colour by log10 of the value (positive values)");
    cmd.add_flag("--symmetric", a.symmetric, "colour range -max|v| .. max|v| (signed fields, e.g. eigenfunctions)");
    cmd.add_option("--range", a.range, "colour range LO,HI (default: the values' range)")->delimiter(',')->expected(2);
    cmd.add_option("--slice", a.slice, "also show the grid on the plane axis=value, head-on (e.g. z=0)");
    cmd.add_option("--paths", a.paths, "polylines (.vtp, e.g. from 'geodesic --paths') drawn over the surface");
    cmd.add_option("--view", a.view, "camera azimuth,elevation in degrees (azimuth about +z from +x)")
        ->delimiter(',')
        ->expected(2)
        ->capture_default_str();
    cmd.add_option("--size", a.size, "picture width,height in pixels per panel")->delimiter(',')->expected(2)->capture_default_str();
    cmd.add_option("--iso", a.iso, "iso-value u of the mean surface gamma = u (default: the file's 'iso', else 0.5)");
    cmd.add_option("--title", a.title, "title above the picture (default: the grid's name)");
    cmd.add_option("--threads", a.threads, "worker threads (0 = all cores)")->capture_default_str();
    cmd.add_flag("--quiet", a.quiet, "no summary line");
    addStageFlags(cmd, a.stage);
}

/// The flags checked, before the file is read: the panel every picture starts from, and the slice asked for.
RenderPanel checkedBasePanel(const Args& a, std::optional<SliceSpec>& slice) {
    RenderPanel base;
    base.array = a.grid;
    base.colormap = colormapOf(a.colormap);
    base.logScale = a.logScale;
    base.symmetric = a.symmetric;
    if (a.range.size() == 2) {
        if (!(a.range[0] < a.range[1]) || !std::isfinite(a.range[0]) || !std::isfinite(a.range[1]))
            throw ParameterError("--range needs finite LO < HI");
        if (a.logScale && !(a.range[0] > 0)) throw ParameterError("--range with --log needs LO > 0");
        base.range = {a.range[0], a.range[1]};
    }
    if (!a.slice.empty()) slice = sliceOf(a.slice);
    for (double v : a.view)
        if (!std::isfinite(v)) throw ParameterError("--view needs finite angles");
    if (!std::isnan(a.iso) && !std::isfinite(a.iso)) throw ParameterError("--iso must be finite");
    // Before any attempt (and before the int conversion): a 1e6 x 1e6 request is refused here.
    for (double v : a.size)
        if (!(v >= kMinPanelPixels && v <= kMaxPanelPixels) || v != std::floor(v))
            throw ParameterError("--size: picture panels must be whole numbers of 64 to 8192 pixels wide and high, got " +
                                 numberText(a.size[0]) + "," + numberText(a.size[1]));
    if (std::filesystem::path(a.output).extension() != ".png") throw ParameterError(a.output + ": the picture is written as .png");
    return base;
}

/// Memory (docs/memory.md#render): the mean surface with the grid sampled on it and VTK's copy, the offscreen window
/// (8 samples of colour and depth per pixel) and the picture, per panel, and the OpenGL context; estimated and
/// refused before any of it is allocated.
MemoryEstimate estimateRender(const Args& a, double limit, const VdbFile& file, bool hasMean, double iso, double pixels, double h) {
    std::vector<std::pair<std::string, double>> parts;
    double vertices = 0;
    if (hasMean) parts = meanSurfaceBytes(*file.floatGrid("mean"), iso, 1, true, &vertices);
    parts.emplace_back("vtk_surface", vertices * kRenderBytesPerVertex);
    parts.emplace_back("gl_context", kRenderContextBytes);
    double fixedBytes = 0;  // what a smaller picture does not shrink
    for (const auto& p : parts) fixedBytes += p.second;
    parts.emplace_back("window", pixels * kRenderBytesPerPixel);
    return estimateStageWithin(limit, "render", "libraries, the .vdb file", std::move(parts), [&](double, double available) {
        const double window = pixels * kRenderBytesPerPixel, surface = fixedBytes - kRenderContextBytes;
        const double scale = available > fixedBytes ? std::sqrt((available - fixedBytes) / window) * 0.95 : 0;
        if (std::floor(a.size[0] * scale) >= 64 && std::floor(a.size[1] * scale) >= 64) {
            // the window's bytes go as the pixels; --size takes 64 pixels at least
            return "use --size " + numberText(std::floor(a.size[0] * scale)) + "," + numberText(std::floor(a.size[1] * scale)) +
                   " or smaller";
        }
        if (available > kRenderContextBytes + window)  // the surface's go as h⁻² to h⁻³
            return "rebuild the band with a voxel size (--voxel-size) of " +
                   numberText(h * std::sqrt(surface / (available - kRenderContextBytes - window)) * 1.05) + " or larger";
        return "raise it (the renderer alone holds about " + numberText(kRenderContextBytes / 1e6) + " MB)";
    });
}

/// The surface's panel (which fills `surface`) and the slice's, each as asked.
std::vector<RenderPanel> makePanels(const Args& a, const RenderPanel& base, const VdbFile& file, const openvdb::FloatGrid& grid,
                                    bool hasMean, double iso, const std::optional<SliceSpec>& slice, std::vector<std::vector<Vec3d>> paths,
                                    SurfaceMesh& surface) {
    std::vector<RenderPanel> panels;
    if (hasMean) {
        surface = meanSurface(*file.floatGrid("mean"), iso);
        if (surface.triangles.empty()) throw InputError(a.input + ": the mean field never crosses the iso-value in the band");
        sampleAtVertices(surface, grid);
        RenderPanel p = base;
        p.title = a.title.empty() ? a.grid : a.title;
        p.surface = &surface;
        p.paths = std::move(paths);
        panels.push_back(p);
    }
    if (slice) {
        RenderPanel p = base;
        p.title = a.grid + " on the slice " + a.slice;
        if (!hasMean && !a.title.empty()) p.title = a.title;
        p.sliceGrid = &grid;
        p.slice = *slice;
        panels.push_back(p);
    }
    if (panels.size() == 2 && !(a.range.size() == 2)) {  // surface and slice share the grid's colours
        float lo = std::numeric_limits<float>::infinity(), hi = -lo;
        for (auto v = grid.cbeginValueOn(); v; ++v)
            if (std::isfinite(*v) && (!a.logScale || *v > 0)) lo = std::min(lo, *v), hi = std::max(hi, *v);
        if (a.symmetric) hi = std::max(std::abs(lo), std::abs(hi)), lo = -hi;
        if (lo < hi)
            for (RenderPanel& p : panels) p.range = {lo, hi};
    }
    return panels;
}

/// `gpisvdb render` once its flags are parsed.
void execute(Args& a) {
    std::optional<SliceSpec> slice;
    const RenderPanel base = checkedBasePanel(a, slice);
    const double limit = memoryLimit(a.stage);
    const VdbFile file = VdbFile::read(a.input);
    const auto grid = file.floatGrid(a.grid);
    bool hasMean = false;
    for (const auto& g : *file.grids) hasMean |= g->getName() == "mean" && g->isType<openvdb::FloatGrid>();
    if (!hasMean && !slice) throw InputError(a.input + ": no 'mean' grid to draw the surface from: show a slice with --slice axis=value");
    std::vector<std::vector<Vec3d>> paths;
    if (!a.paths.empty()) paths = readPolylines(a.paths);
    AtomicOutput out(a.output);
    std::unique_ptr<AtomicOutput> reportOut = optionalOutput(a.stage.report);

    const double iso = std::isnan(a.iso) ? file.iso() : a.iso;
    const double pixels = a.size[0] * a.size[1] * double(int(hasMean) + int(bool(slice)));
    const MemoryEstimate memory = estimateRender(a, limit, file, hasMean, iso, pixels, grid->voxelSize()[0]);
    const bool stageOnly = resetPeakResident();

    SurfaceMesh surface;
    const std::vector<RenderPanel> panels = makePanels(a, base, file, *grid, hasMean, iso, slice, std::move(paths), surface);
    RenderOptions o;
    o.azimuth = a.view[0], o.elevation = a.view[1];
    o.panelWidth = int(a.size[0]), o.panelHeight = int(a.size[1]);
    renderPng(panels, o, out.tempPath(), makeProgress(true));
    const double peak = peakResidentBytes();
    out.commit();
    if (reportOut) {
        nlohmann::json report = stageReport("render", memoryStageReport(memory, peak, stageOnly));
        report["render"] = {{"panels", panels.size()}, {"pixels", pixels}, {"surface_vertices", surface.vertices.size()}};
        report["outputs"] = {a.output};
        commitReport(*reportOut, report);
    }
    if (!a.quiet) std::cerr << "render: " << a.grid << " -> " << a.output << "\n";
}

}  // namespace

void addRender(CLI::App& app, Action& action) {
    addCommand<Args>(
        app, action, "render",
        {"a PNG picture of a grid on the mean surface (and a slice), with a colour bar",
         "Starts its own Xvfb when no X display answers (tools/setup installs it).\n"
         "Examples:\n  gpisvdb render green.vdb --grid green --log -o green.png\n"
         "  gpisvdb render geo.vdb --grid geodesic --paths path.vtp --slice z=0.4 -o geo.png"},
        addFlags, [](Args& a) -> int& { return a.threads; }, [](Args& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
