#pragma once
// A stage's memory on the command line: estimated and refused beyond --max-memory before it allocates, measured
// over it, reported under memory.stages (docs/memory.md). The band commands take their limit from the band's
// options; the commands that build no band (mesh, render, evaluate) take it from their own --max-memory.
#include <CLI/CLI.hpp>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "common.h"
#include "gpisvdb/core/memory_estimate.h"

namespace gpisvdb::cli {

/// "8G", "512M", "1e9": bytes; throws ParameterError naming --max-memory otherwise.
double parseBytes(const std::string& text);

/// The flags of a command that builds no band: --max-memory (as given; empty: half the RAM) and --report.
struct StageFlags {
    std::string maxMemory;  ///< "8G", "512M", "1e9"; empty: half the RAM
    std::string report;     ///< JSON report path; empty: none
};
void addStageFlags(CLI::App& cmd, StageFlags& flags);
/// --max-memory in bytes: the flag's value, or half the physical memory without it.
double memoryLimit(const StageFlags& flags);

/// The estimate of a stage that allocates `parts` (bytes), the settled resident set now as its baseline (`held`
/// says what it holds, e.g. "libraries, input, band"). When baseline + parts exceed `limit` (bytes), throws
/// MemoryLimitError before the stage allocates: what the stage needs, and "raise it" when the baseline alone is
/// over the limit, else `fits(need, available)`: the largest setting whose stage fits in `available` = limit −
/// baseline bytes when at this setting it needs `need` = Σ parts bytes ("use … of … or larger").
MemoryEstimate estimateStageWithin(double limit, const std::string& stage, const std::string& held,
                                   std::vector<std::pair<std::string, double>> parts,
                                   const std::function<std::string(double need, double available)>& fits);

/// A report's `memory.stages.<stage>`: baseline_bytes, the parts' bytes, estimate_bytes (their sum with the baseline),
/// measured_peak_bytes, stage_only (false: the kernel kept the peak from before the stage, so it may be the
/// band's) and estimate_error (estimate / measured − 1).
nlohmann::json memoryStageReport(const MemoryEstimate& estimate, double measuredPeak, bool stageOnly);

/// The report of a command that builds no band: `memory` (peak_rss_bytes of the whole run, stages.<stage>) with
/// the command's own sections added by the caller.
nlohmann::json stageReport(const std::string& stage, const nlohmann::json& measured);

/// Writes the JSON report into its temporary file and renames it into place.
void commitReport(AtomicOutput& file, const nlohmann::json& report);

}  // namespace gpisvdb::cli
