#include "memory_stage.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::cli {

double parseBytes(const std::string& s) {
    char* end = nullptr;
    double v = std::strtod(s.c_str(), &end);
    const std::string unit(end);
    if (unit == "K" || unit == "k") v *= 1024.0;
    else if (unit == "M" || unit == "m") v *= 1024.0 * 1024.0;
    else if (unit == "G" || unit == "g") v *= 1024.0 * 1024.0 * 1024.0;
    else if (!unit.empty() || end == s.c_str()) throw ParameterError("--max-memory: expected bytes like 8G, 512M or 1e9, got '" + s + "'");
    if (!(v > 0) || !std::isfinite(v)) throw ParameterError("--max-memory must be > 0");
    return v;
}

void addStageFlags(CLI::App& cmd, StageFlags& f) {
    cmd.add_option("--max-memory", f.maxMemory, "refuse work needing more memory than this, e.g. 8G (default: half the RAM)");
    cmd.add_option("--report", f.report, "write a JSON report (memory)");
}

double memoryLimit(const StageFlags& f) {
    if (!f.maxMemory.empty()) return parseBytes(f.maxMemory);
    return 0.5 * double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));  // as the band's default
}

MemoryEstimate estimateStageWithin(double limit, const std::string& stage, const std::string& held,
                                   std::vector<std::pair<std::string, double>> parts,
                                   const std::function<std::string(double need, double available)>& fits) {
    MemoryEstimate e;
    e.baselineBytes = settledResidentBytes();
    e.parts = std::move(parts);
    if (e.peakBytes() <= limit) return e;
    const double available = limit - e.baselineBytes;
    const std::string need = "the " + stage + " needs about " + numberText(e.stageBytes() / 1e6) + " MB beside the " +
                             numberText(e.baselineBytes / 1e6) + " MB this process holds (" + held +
                             "), more than the memory limit (--max-memory) allows: ";
    throw MemoryLimitError(need + (available <= 0 ? std::string("raise it") : fits(e.stageBytes(), available)));
}

nlohmann::json memoryStageReport(const MemoryEstimate& estimate, double measuredPeak, bool stageOnly) {
    nlohmann::json parts = nlohmann::json::object();
    for (const auto& [name, bytes] : estimate.parts) parts[name] = bytes;
    return {{"baseline_bytes", estimate.baselineBytes},
            {"parts_bytes", parts},
            {"estimate_bytes", estimate.peakBytes()},
            {"measured_peak_bytes", measuredPeak},
            {"stage_only", stageOnly},
            {"estimate_error", measuredPeak > 0 ? estimate.peakBytes() / measuredPeak - 1 : 0.0}};
}

nlohmann::json stageReport(const std::string& stage, const nlohmann::json& measured) {
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    return {{"memory", {{"peak_rss_bytes", double(ru.ru_maxrss) * 1024.0}, {"stages", {{stage, measured}}}}}};
}

void commitReport(AtomicOutput& file, const nlohmann::json& report) {
    std::ofstream out(file.tempPath());
    out << report.dump(2) << "\n";
    out.close();
    if (!out) throw OutputError(file.tempPath() + ": cannot write the report");
    file.commit();
}

}  // namespace gpisvdb::cli
