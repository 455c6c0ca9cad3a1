// gpisvdb info INPUT: what the input holds once read, and the absolute noise and smoothing it implies.
#include <iostream>

#include "commands.h"
#include "common.h"
#include "memory_stage.h"

namespace gpisvdb::cli {

void addInfo(CLI::App& app, Action& action) {
    auto* cmd = app.add_subcommand("info", "describe an input: samples, length scale, bounding box, what was skipped");
    auto input = std::make_shared<std::string>();
    auto flags = std::make_shared<ModelFlags>();
    auto stage = std::make_shared<StageFlags>();
    cmd->add_option("INPUT", *input, "mesh (.obj .off .ply .stl .vtp) or oriented cloud (.xyz .ply .vtp)")->required();
    cmd->add_option("--sigma", flags->sigmaRel, "noise std σ relative to ℓ (> 0)")->capture_default_str();
    cmd->add_option("--smoothing", flags->smoothingRel, "kernel smoothing s relative to ℓ (> 0)")->capture_default_str();
    addStageFlags(*cmd, *stage);
    cmd->footer("Example:\n  gpisvdb info bunny.obj --sigma 0.25");
    cmd->callback([&action, input, flags, stage] {
        action = [input, flags, stage] {
            if (!(flags->smoothingRel > 0)) throw ParameterError("--smoothing must be > 0");
            const double limit = memoryLimit(*stage);
            const InputData data = readInput(*input);
            std::unique_ptr<AtomicOutput> reportOut;
            if (!stage->report.empty()) reportOut = std::make_unique<AtomicOutput>(stage->report);
            // === The samples (a triangle's or a point's position, normal and their covariances): estimated and
            //     refused before they are made, measured over it (docs/memory.md#info). The input, read in whole
            //     before, is the baseline; no setting makes fewer samples.
            const MemoryEstimate memory = estimateStageWithin(limit, "sampling of the input", "libraries, the input", makeSamplesBytes(data),
                                                              [](double, double) { return std::string("raise it"); });
            const bool stageOnly = resetPeakResident();
            const InputSamples s = makeSamples(data, {flags->sigmaRel});
            const double peak = peakResidentBytes();
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
            if (reportOut) {
                nlohmann::json report = stageReport("samples", memoryStageReport(memory, peak, stageOnly));
                report["input"] = {{"path", data.path}, {"samples", s.samples.size()},
                                   {"kind", s.isSoup ? "triangle soup" : "oriented point cloud"}};
                commitReport(*reportOut, report);
            }
        };
    });
}

}  // namespace gpisvdb::cli
