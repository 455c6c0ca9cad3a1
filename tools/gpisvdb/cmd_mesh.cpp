// gpisvdb mesh FILE.vdb --grid NAME -o OUT.ply|OUT.vtp: the mean surface with a grid sampled at its vertices.
#include <iostream>
#include <limits>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"
#include "memory_stage.h"
#include "vdb_file.h"

namespace gpisvdb::cli {

namespace {

struct Args {
    std::string input, output;
    std::vector<std::string> grids;
    double iso = std::numeric_limits<double>::quiet_NaN();  // unset: the file's 'iso' metadata, else 0.5
    bool quiet = false;
    int threads = 0;
    StageFlags stage;
};

/// The flags of `gpisvdb mesh`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("FILE", a.input, "a .vdb written by gpisvdb (needs the 'mean' grid)")->required();
    cmd.add_option("--grid", a.grids, "grid(s) to sample at the vertices (float or vec3), e.g. mu, green")->required();
    cmd.add_option("-o,--output", a.output, "output mesh, .ply or .vtp")->required();
    cmd.add_option("--iso", a.iso, "iso-value u of the mean surface gamma = u (default: the file's 'iso', else 0.5)");
    cmd.add_option("--threads", a.threads, "worker threads (0 = all cores)")->capture_default_str();
    cmd.add_flag("--quiet", a.quiet, "no summary line");
    addStageFlags(cmd, a.stage);
}

/// The surface's memory (docs/memory.md#mesh): its parts go as h⁻² (the mesh) to h⁻³ (u − γ over the band), so a
/// band rebuilt at h √(need / available) fits.
MemoryEstimate estimateMesh(double limit, const openvdb::FloatGrid& mean, double iso, int components, MeshFormat format) {
    const double h = mean.voxelSize()[0];
    return estimateStageWithin(limit, "mean surface", "libraries, the .vdb file",
                               meanSurfaceBytes(mean, iso, components, format == MeshFormat::Vtp), [&](double need, double available) {
                                   return "rebuild the band with a voxel size (--voxel-size) of " +
                                          numberText(h * std::sqrt(need / available) * 1.05) + " or larger";
                               });
}

/// `gpisvdb mesh` once its flags are parsed.
void execute(Args& a) {
    if (!std::isnan(a.iso) && !std::isfinite(a.iso)) throw ParameterError("--iso must be finite");
    const MeshFormat format = meshFormatOf(a.output);
    const double limit = memoryLimit(a.stage);
    const VdbFile file = VdbFile::read(a.input);
    if (std::isnan(a.iso)) a.iso = file.iso();  // the level the band was built at (0 for regression)
    const auto mean = file.floatGrid("mean");
    std::vector<openvdb::GridBase::Ptr> sampled;
    int components = 0;  // floats sampled per vertex
    for (const std::string& g : a.grids) {
        sampled.push_back(file.grid(g));
        components += sampled.back()->isType<openvdb::Vec3SGrid>() ? 3 : 1;
    }
    AtomicOutput out(a.output);
    std::unique_ptr<AtomicOutput> reportOut = optionalOutput(a.stage.report);
    const MemoryEstimate memory = estimateMesh(limit, *mean, a.iso, components, format);
    const bool stageOnly = resetPeakResident();
    SurfaceMesh mesh = meanSurface(*mean, a.iso);
    if (mesh.triangles.empty()) throw InputError(a.input + ": the mean field never crosses u = " + std::to_string(a.iso) + " in the band");
    for (const auto& g : sampled) sampleAtVertices(mesh, *g);
    writeMesh(mesh, out.tempPath(), format);
    const double peak = peakResidentBytes();
    out.commit();
    if (reportOut) {
        nlohmann::json report = stageReport("mesh", memoryStageReport(memory, peak, stageOnly));
        report["mesh"] = {
            {"vertices", mesh.vertices.size()}, {"triangles", mesh.triangles.size()}, {"band_voxels", mean->activeVoxelCount()}};
        report["outputs"] = {a.output};
        commitReport(*reportOut, report);
    }
    if (!a.quiet)
        std::cerr << "mesh: " << mesh.vertices.size() << " vertices, " << mesh.triangles.size() << " triangles -> " << a.output << "\n";
}

}  // namespace

void addMesh(CLI::App& app, Action& action) {
    addCommand<Args>(
        app, action, "mesh",
        {"mean surface of a band file with a grid sampled at its vertices (.ply/.vtp)",
         "Example:\n  gpisvdb mesh green.vdb --grid green --grid mu -o green.ply"},
        addFlags, [](Args& a) -> int& { return a.threads; }, [](Args& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
