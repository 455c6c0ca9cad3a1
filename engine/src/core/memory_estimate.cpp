#include "gpisvdb/core/memory_estimate.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <malloc.h>
#include <sstream>

namespace gpisvdb {

namespace {

/// A "Name:   1234 kB" line of /proc/self/status, bytes; 0 when absent.
double statusField(const std::string& name) {
    std::ifstream in("/proc/self/status");
    for (std::string line; std::getline(in, line);)
        if (line.compare(0, name.size(), name) == 0 && line.size() > name.size() && line[name.size()] == ':') {
            std::istringstream s(line.substr(name.size() + 1));
            double kb = 0;
            s >> kb;
            return kb * 1024.0;
        }
    return 0;
}

}  // namespace

double residentBytes() { return statusField("VmRSS"); }

double settledResidentBytes() {
    malloc_trim(0);
    return residentBytes();
}

double peakResidentBytes() { return statusField("VmHWM"); }

bool resetPeakResident() {
    std::ofstream out("/proc/self/clear_refs");
    out << "5";
    out.close();
    return bool(out);
}

double MemoryEstimate::stageBytes() const {
    double sum = 0;
    for (const auto& p : parts) sum += p.second;
    return sum;
}

}  // namespace gpisvdb
