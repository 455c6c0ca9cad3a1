#pragma once
// What the memory tests share (test_memory_estimate.cpp, test_memory_stages.cpp): an estimate checked against a
// measurement, a child gpisvdb's memory stage, and bunny bands for the commands that read a .vdb.
#include <catch2/catch.hpp>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli_run.h"
#include "helpers.h"

namespace gpisvdb::test::memory {

using namespace gpisvdb::test::cli;

/// The estimate within 15 % of the measured bytes: checked where memory measures the code (test::kMemoryChecked),
/// reported in sanitizer builds.
inline void checkWithin15Percent(double estimate, double measured) {
    if (!test::kMemoryChecked) {
        WARN("estimate " << estimate << " bytes, measured " << measured << " (not checked in this build)");
        return;
    }
    CHECK(estimate > 0.85 * measured);
    CHECK(estimate < 1.15 * measured);
}

/// `args` in a child gpisvdb with `--report R.json`, required to succeed: its report's memory.stages.<stage>.
inline nlohmann::json childStage(const std::string& args, const std::string& stage) {
    const std::string json = temp("memory_stage.json");
    const Run r = run(args + " --report " + json);
    INFO(args << ": " << r.err);
    REQUIRE(r.code == 0);
    return nlohmann::json::parse(std::ifstream(json))["memory"]["stages"][stage];
}

/// The stage's estimate within 15 % of the peak measured over it, the peak the stage's own (not the run's); and,
/// since on these small inputs the baseline alone comes within 15 % of the peak, the stage's own bytes within a
/// factor of 2 of what it added (where it added 2 MB or more: below, the 1–3 MB of thread and allocator start-up
/// no estimate counts dominate, docs/memory.md).
inline void checkStage(const nlohmann::json& stage) {
    const double estimate = stage["estimate_bytes"], measured = stage["measured_peak_bytes"], baseline = stage["baseline_bytes"];
    INFO("estimate " << estimate << ", measured " << measured << ": " << stage.dump());
    checkWithin15Percent(estimate, measured);
    if (!test::kMemoryChecked) return;
    CHECK(stage["stage_only"] == true);
    if (measured - baseline >= 2e6) {
        CHECK(estimate - baseline >= 0.5 * (measured - baseline));
        CHECK(estimate - baseline <= 2.0 * (measured - baseline));
    }
}

/// Bunny bands (σ_rel 2) at two voxel sizes, as .vdb files (mean, mu, …) for the mesh and render commands.
inline const std::vector<std::string>& bunnyBands() {
    static const std::vector<std::string> files = [] {
        std::vector<std::string> out;
        for (const char* h : {"0.25", "0.15"}) {
            out.push_back(temp(std::string("memory_band_") + h + ".vdb"));
            const Run r =
                run("band " + gpisvdb::test::dataPath("bunny.obj") + " --sigma 2 --voxel-size " + h + " --quiet -o " + out.back());
            if (r.code != 0) throw std::runtime_error("band: " + r.err);
        }
        return out;
    }();
    return files;
}

}  // namespace gpisvdb::test::memory
