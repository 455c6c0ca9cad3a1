// gpisvdb sample FILE.vdb --at INPUT -o OUT.ply|.vtp: grids of a result sampled at the input's own vertices or
// points (paper Fig. 1 shows results on the input itself).
#include <iostream>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"
#include "vdb_file.h"

namespace gpisvdb::cli {

void addSample(CLI::App& app, Action& action) {
    auto* cmd = app.add_subcommand("sample", "sample grids of a .vdb at the vertices or points of an input (.ply/.vtp)");
    struct Args {
        std::string input, at, output;
        std::vector<std::string> grids;
        bool quiet = false;
        int threads = 0;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("FILE", a->input, "a .vdb written by gpisvdb")->required();
    cmd->add_option("--at", a->at, "mesh (.obj .off .ply .stl .vtp) or oriented cloud (.xyz .ply .vtp) to sample at")->required();
    cmd->add_option("--grid", a->grids, "grid(s) to sample (float or vec3; default: all of them)");
    cmd->add_option("-o,--output", a->output, "output, .ply or .vtp: the input's vertices (and triangles) with one value per grid")->required();
    cmd->add_option("--threads", a->threads, "worker threads (0 = all cores)")->capture_default_str();
    cmd->add_flag("--quiet", a->quiet, "no summary line");
    cmd->footer("Values are trilinear in world space; points outside a grid's band get its background value.\n"
                "Example:\n  gpisvdb sample green.vdb --at bunny.obj --grid green --grid stddev -o bunny_green.ply");
    cmd->callback([&action, a] {
        action = [a] {
            const auto threads = limitThreads(a->threads);
            const MeshFormat format = meshFormatOf(a->output);
            const VdbFile file = VdbFile::read(a->input);
            std::vector<openvdb::GridBase::Ptr> grids;
            if (a->grids.empty()) {
                for (const auto& g : *file.grids)
                    if (g->isType<openvdb::FloatGrid>() || g->isType<openvdb::Vec3SGrid>()) grids.push_back(g);
            } else {
                for (const std::string& name : a->grids) grids.push_back(file.grid(name));
            }
            const InputData data = readInput(a->at);
            AtomicOutput out(a->output);

            // === The input's own points: a soup's shared vertices (and its triangles), or the cloud's points
            SurfaceMesh mesh;
            if (data.soup) {
                for (const Vec3d& v : data.soup->vertices) mesh.vertices.emplace_back(float(v.x()), float(v.y()), float(v.z()));
                mesh.triangles = data.soup->triangles;
            } else {
                for (const Vec3d& p : data.cloud->positions) mesh.vertices.emplace_back(float(p.x()), float(p.y()), float(p.z()));
            }
            for (const auto& g : grids) sampleAtVertices(mesh, *g);
            writeMesh(mesh, out.tempPath(), format);
            out.commit();
            if (!a->quiet)
                std::cerr << "sample: " << grids.size() << " grid(s) at " << mesh.vertices.size() << " points -> " << a->output << "\n";
        };
    });
}

}  // namespace gpisvdb::cli
