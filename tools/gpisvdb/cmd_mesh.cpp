// gpisvdb mesh FILE.vdb --grid NAME -o OUT.ply|OUT.vtp: the mean surface with a grid sampled at its vertices.
#include <limits>
#include <iostream>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"
#include "vdb_file.h"

namespace gpisvdb::cli {

void addMesh(CLI::App& app, Action& action) {
    auto* cmd = app.add_subcommand("mesh", "mean surface of a band file with a grid sampled at its vertices (.ply/.vtp)");
    struct Args {
        std::string input, output;
        std::vector<std::string> grids;
        double iso = std::numeric_limits<double>::quiet_NaN();  // unset: the file's 'iso' metadata, else 0.5
        bool quiet = false;
        int threads = 0;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("FILE", a->input, "a .vdb written by gpisvdb (needs the 'mean' grid)")->required();
    cmd->add_option("--grid", a->grids, "grid(s) to sample at the vertices (float or vec3), e.g. mu, green")->required();
    cmd->add_option("-o,--output", a->output, "output mesh, .ply or .vtp")->required();
    cmd->add_option("--iso", a->iso, "iso-value u of the mean surface gamma = u (default: the file's 'iso', else 0.5)");
    cmd->add_option("--threads", a->threads, "worker threads (0 = all cores)")->capture_default_str();
    cmd->add_flag("--quiet", a->quiet, "no summary line");
    cmd->footer("Example:\n  gpisvdb mesh green.vdb --grid green --grid mu -o green.ply");
    cmd->callback([&action, a] {
        action = [a] {
            const auto threads = limitThreads(a->threads);
            if (!std::isnan(a->iso) && !std::isfinite(a->iso)) throw ParameterError("--iso must be finite");
            const MeshFormat format = meshFormatOf(a->output);
            const VdbFile file = VdbFile::read(a->input);
            if (std::isnan(a->iso)) a->iso = file.iso();  // the level the band was built at (0 for regression)
            const auto mean = file.floatGrid("mean");
            std::vector<openvdb::GridBase::Ptr> sampled;
            for (const std::string& g : a->grids) sampled.push_back(file.grid(g));
            AtomicOutput out(a->output);
            SurfaceMesh mesh = meanSurface(*mean, a->iso);
            if (mesh.triangles.empty())
                throw InputError(a->input + ": the mean field never crosses u = " + std::to_string(a->iso) + " in the band");
            for (const auto& g : sampled) sampleAtVertices(mesh, *g);
            writeMesh(mesh, out.tempPath(), format);
            out.commit();
            if (!a->quiet)
                std::cerr << "mesh: " << mesh.vertices.size() << " vertices, " << mesh.triangles.size() << " triangles -> "
                          << a->output << "\n";
        };
    });
}

}  // namespace gpisvdb::cli
