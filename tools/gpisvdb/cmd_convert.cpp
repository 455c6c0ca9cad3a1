// gpisvdb convert INPUT -o OUT.gdp: the input's samples with their noise as Gaussian dipoles, the format of the paper's
// own implementation (docs/guide.md#gdp), for running it on our inputs.
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/gdp.h"
#include "gpisvdb/input/read_input.h"
#include "memory_stage.h"

namespace gpisvdb::cli {

namespace {

struct Args {
    std::string input, output, maxMemory;
    ModelFlags model;
};

/// The flags of `gpisvdb convert`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    cmd.add_option("-o,--output", a.output, "output .gdp: per sample its position, vector area and the 6x6 covariance of both")->required();
    addModelFlags(cmd, a.model, /*withModel*/ false);
    cmd.add_option("--max-memory", a.maxMemory, "refuse inputs whose samples need more memory than this, e.g. 8G (default: half the RAM)");
}

/// `gpisvdb convert` once its flags are parsed.
void execute(const Args& a) {
    std::string ext = std::filesystem::path(a.output).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext != ".gdp") throw ParameterError("-o must name a .gdp file, the only format convert writes (got '" + a.output + "')");
    const double limit = memoryLimit({a.maxMemory, ""});
    const InputData data = readInput(a.input);
    AtomicOutput out(a.output);
    estimateStageWithin(limit, "sampling of the input", "libraries, the input", makeSamplesBytes(data),
                        [](double, double) { return std::string("raise it"); });
    const InputSamples s = makeSamples(data, {a.model.sigmaRel});
    writeGdp(s.samples, out.tempPath());
    out.commit();
    if (!a.model.quiet)
        std::cerr << "convert: " << s.samples.size() << " dipoles from the " << (s.isSoup ? "triangle soup" : "point cloud")
                  << (s.absoluteNoise ? " with its own noise" : ", sigma " + numberText(s.sigma)) << " to " << a.output << "\n";
}

}  // namespace

void addConvert(CLI::App& app, Action& action) {
    addCommand<Args>(
        app, action, "convert",
        {"write the input's samples and their noise as Gaussian dipoles (.gdp), the paper's own format",
         "Each triangle or point becomes one dipole, with the noise the model gives it (--sigma for inputs\n"
         "without their own). Numbers are written in the shortest form that reads back to the same value.\n"
         "Example:\n  gpisvdb convert bunny.obj --sigma 0.25 -o bunny.gdp"},
        addFlags, [](Args& a) -> int& { return a.model.threads; }, [](Args& a, Clock::time_point) { execute(a); });
}

}  // namespace gpisvdb::cli
