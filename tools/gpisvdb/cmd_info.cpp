// gpisvdb info INPUT: what the input holds once read, and the absolute noise and smoothing it implies.
#include <iostream>

#include "commands.h"
#include "common.h"

namespace gpisvdb::cli {

void addInfo(CLI::App& app, Action& action) {
    auto* cmd = app.add_subcommand("info", "describe an input: samples, length scale, bounding box, what was skipped");
    auto input = std::make_shared<std::string>();
    auto flags = std::make_shared<ModelFlags>();
    cmd->add_option("INPUT", *input, "mesh (.obj .off .ply .stl .vtp) or oriented cloud (.xyz .ply .vtp)")->required();
    cmd->add_option("--sigma", flags->sigmaRel, "noise std σ relative to ℓ (> 0)")->capture_default_str();
    cmd->add_option("--smoothing", flags->smoothingRel, "kernel smoothing s relative to ℓ (> 0)")->capture_default_str();
    cmd->footer("Example:\n  gpisvdb info bunny.obj --sigma 0.25");
    cmd->callback([&action, input, flags] {
        action = [input, flags] {
            if (!(flags->smoothingRel > 0)) throw ParameterError("--smoothing must be > 0");
            const InputData data = readInput(*input);
            const InputSamples s = makeSamples(data, {flags->sigmaRel});
            Vec3d lo = s.samples.position[0], hi = lo;
            for (const auto& p : s.samples.position) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
            const double ell = s.samples.lengthScale;
            std::cout << "input:        " << data.path << " (" << (s.isSoup ? "triangle soup" : "oriented point cloud") << ")\n"
                      << "samples:      " << s.samples.size() << "\n"
                      << "length scale: " << ell << (s.isSoup ? " (mean edge length)" : " (mean nearest-neighbour spacing)") << "\n"
                      << "bbox min:     " << lo.transpose() << "\n"
                      << "bbox max:     " << hi.transpose() << "\n"
                      << "sigma:        " << flags->sigmaRel << " x l = " << s.sigma << "\n"
                      << "smoothing:    " << flags->smoothingRel << " x l = " << flags->smoothingRel * ell << "\n"
                      << "skipped:      " << s.degenerateSkipped << " zero-area triangles\n"
                      << "triangulated: " << data.polygonsTriangulated << " polygons with more than 3 corners (fans)\n";
        };
    });
}

}  // namespace gpisvdb::cli
