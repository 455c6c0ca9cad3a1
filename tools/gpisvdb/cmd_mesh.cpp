// gpisvdb mesh FILE.vdb --grid NAME -o OUT.ply|OUT.vtp: the mean surface with a grid sampled at its vertices.
#include <limits>
#include <iostream>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/mean_surface.h"

namespace gpisvdb::cli {

namespace {

openvdb::GridBase::Ptr readGrid(openvdb::io::File& file, const std::string& path, const std::string& name) {
    if (!file.hasGrid(name)) {
        std::string names;
        for (auto it = file.beginName(); it != file.endName(); ++it) names += (names.empty() ? "" : ", ") + *it;
        throw InputError(path + ": no grid '" + name + "' (the file has: " + names + ")");
    }
    return file.readGrid(name);
}

}  // namespace

void addMesh(CLI::App& app, Action& action) {
    auto* cmd = app.add_subcommand("mesh", "mean surface of a band file with a grid sampled at its vertices (.ply/.vtp)");
    struct Args {
        std::string input, output;
        std::vector<std::string> grids;
        double iso = std::numeric_limits<double>::quiet_NaN();  // unset: the file's 'iso' metadata, else 0.5
        bool quiet = false;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("FILE", a->input, "a .vdb written by gpisvdb (needs the 'mean' grid)")->required();
    cmd->add_option("--grid", a->grids, "grid(s) to sample at the vertices (float or vec3), e.g. mu, green")->required();
    cmd->add_option("-o,--output", a->output, "output mesh, .ply or .vtp")->required();
    cmd->add_option("--iso", a->iso, "iso-value u of the mean surface gamma = u (default: the file's 'iso', else 0.5)");
    cmd->add_flag("--quiet", a->quiet, "no summary line");
    cmd->footer("Example:\n  gpisvdb mesh green.vdb --grid green --grid mu -o green.ply");
    cmd->callback([&action, a] {
        action = [a] {
            if (!std::isnan(a->iso) && !std::isfinite(a->iso)) throw ParameterError("--iso must be finite");
            const MeshFormat format = meshFormatOf(a->output);
            openvdb::initialize();
            openvdb::io::File file(a->input);
            try {
                file.open();
            } catch (const openvdb::Exception& e) {
                throw InputError(a->input + ": cannot be read as an OpenVDB file (" + e.what() + ")");
            }
            if (std::isnan(a->iso)) {  // the level the band was built at (0 for the regression model)
                const auto meta = file.getMetadata();
                const auto stored = meta ? (*meta)["iso"] : openvdb::Metadata::Ptr();
                const auto* value = stored ? dynamic_cast<const openvdb::DoubleMetadata*>(stored.get()) : nullptr;
                a->iso = value ? value->value() : 0.5;
            }
            const auto mean = openvdb::gridPtrCast<openvdb::FloatGrid>(readGrid(file, a->input, "mean"));
            if (!mean) throw InputError(a->input + ": grid 'mean' is not a float grid");
            std::vector<openvdb::GridBase::Ptr> sampled;
            for (const std::string& g : a->grids) sampled.push_back(readGrid(file, a->input, g));
            file.close();
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
