// gpisvdb sample FILE.vdb --at INPUT -o OUT.ply|.vtp: grids of a result sampled at the input's own vertices or
// points (paper Fig. 1 shows results on the input itself).
#include <iostream>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"
#include "memory_stage.h"
#include "vdb_file.h"

namespace gpisvdb::cli {

namespace {

struct Args {
    std::string input, at, output;
    std::vector<std::string> grids;
    bool quiet = false;
    int threads = 0;
    StageFlags stage;
};

/// The flags of `gpisvdb sample`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("FILE", a.input, "a .vdb written by gpisvdb")->required();
    cmd.add_option("--at", a.at, std::string(kInputHelp) + " to sample at")->required();
    cmd.add_option("--grid", a.grids, "grid(s) to sample (float or vec3; default: all of them)");
    cmd.add_option("-o,--output", a.output, "output, .ply or .vtp: the input's vertices (and triangles) with one value per grid")
        ->required();
    cmd.add_option("--threads", a.threads, "worker threads (0 = all cores)")->capture_default_str();
    cmd.add_flag("--quiet", a.quiet, "no summary line");
    addStageFlags(cmd, a.stage);
}

/// The grids to sample: those named, or every float and vec3 grid of the file (their values read now, in the
/// baseline).
std::vector<openvdb::GridBase::Ptr> gridsToSample(const Args& a, const VdbFile& file) {
    std::vector<openvdb::GridBase::Ptr> grids;
    if (!a.grids.empty()) {
        for (const std::string& name : a.grids) grids.push_back(file.grid(name));
        return grids;
    }
    for (const auto& g : *file.grids)
        if (g->isType<openvdb::FloatGrid>() || g->isType<openvdb::Vec3SGrid>()) grids.push_back(file.grid(g->getName()));
    return grids;
}

/// The mesh at the input's points with the grids sampled on it, and VTK's copy for a .vtp: estimated and refused
/// before it is allocated, measured over it (docs/memory.md#sample). The input and the .vdb file are read in whole
/// before: they are the baseline.
MemoryEstimate estimateSample(double limit, double points, double triangles, int components, std::size_t gridCount, bool polyData) {
    double fixedBytes = 0;  // the mesh (and VTK's copy) without any sampled array
    for (const auto& p : surfaceMeshBytes(points, triangles, 0, polyData)) fixedBytes += p.second;
    return estimateStageWithin(
        limit, "sampled mesh", "libraries, the .vdb file, the input", surfaceMeshBytes(points, triangles, components, polyData),
        [&](double need, double available) {
            const double perComponent = components > 0 ? (need - fixedBytes) / components : 0;
            const int fits = components > 0 && available > fixedBytes ? int((available - fixedBytes) / perComponent) : 0;
            if (fits >= 1)
                return "sample at most " + std::to_string(fits) + " float components at a time (--grid; a vec3 grid counts 3, the " +
                       std::to_string(gridCount) + " grids asked for have " + std::to_string(components) + ")";
            return "raise it (the input's " + numberText(points) + " points with one grid need about " +
                   numberText((fixedBytes + perComponent) / 1e6) + " MB)";
        });
}

/// The input's own points: a soup's shared vertices (and its triangles), or the cloud's points.
SurfaceMesh inputPoints(const InputData& data, double points) {
    SurfaceMesh mesh;
    mesh.vertices.reserve(std::size_t(points));  // exactly: what surfaceMeshBytes counts, not up to twice that
    if (data.soup) {
        for (const Vec3d& v : data.soup->vertices) mesh.vertices.emplace_back(float(v.x()), float(v.y()), float(v.z()));
        mesh.triangles = data.soup->triangles;
    } else {
        for (const Vec3d& p : data.cloud->positions) mesh.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
    }
    return mesh;
}

/// `gpisvdb sample` once its flags are parsed.
void execute(Args& a) {
    const MeshFormat format = meshFormatOf(a.output);
    const double limit = memoryLimit(a.stage);
    const VdbFile file = VdbFile::read(a.input);
    const std::vector<openvdb::GridBase::Ptr> grids = gridsToSample(a, file);
    int components = 0;  // floats sampled per point
    for (const auto& g : grids) components += g->isType<openvdb::Vec3SGrid>() ? 3 : 1;
    const InputData data = readInput(a.at);
    AtomicOutput out(a.output);
    std::unique_ptr<AtomicOutput> reportOut = optionalOutput(a.stage.report);
    const double points = double(data.soup ? data.soup->vertices.size() : data.cloud->positions.size());
    const double triangles = double(data.soup ? data.soup->triangles.size() : 0);
    const MemoryEstimate memory = estimateSample(limit, points, triangles, components, grids.size(), format == MeshFormat::Vtp);
    const bool stageOnly = resetPeakResident();
    SurfaceMesh mesh = inputPoints(data, points);
    for (const auto& g : grids) sampleAtVertices(mesh, *g);
    writeMesh(mesh, out.tempPath(), format);
    const double peak = peakResidentBytes();
    out.commit();
    if (reportOut) {
        nlohmann::json report = stageReport("sample", memoryStageReport(memory, peak, stageOnly));
        report["sample"] = {
            {"points", mesh.vertices.size()}, {"triangles", mesh.triangles.size()}, {"grids", grids.size()}, {"components", components}};
        report["outputs"] = {a.output};
        commitReport(*reportOut, report);
    }
    if (!a.quiet) std::cerr << "sample: " << grids.size() << " grid(s) at " << mesh.vertices.size() << " points -> " << a.output << "\n";
}

}  // namespace

void addSample(CLI::App& app, Action& action) {
    addCommand<Args>(
        app, action, "sample",
        {"sample grids of a .vdb at the vertices or points of an input (.ply/.vtp)",
         "Values are trilinear in world space; points outside a grid's band get its background value.\n"
         "Example:\n  gpisvdb sample green.vdb --at bunny.obj --grid green --grid stddev -o bunny_green.ply"},
        addFlags, [](Args& a) -> int& { return a.threads; }, [](Args& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
