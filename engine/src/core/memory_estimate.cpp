#include "gpisvdb/core/memory_estimate.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <malloc.h>
#include <sstream>

#include "gpisvdb/solve/fast_marching.h"
#include "gpisvdb/solve/pcg.h"

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

double fastMarchingBytes(std::size_t n, std::size_t entries, double frontShare) {
    const double voxels = double(n);
    const double tables = 4.0 * double(entries) + 4.0 * (voxels + 1);
    const double march = FastMarching::kMarchBytesPerVoxel * voxels;
    // The pool and the heap grow by doubling: on average 1.5× what they hold at their peak.
    const double pool = 1.5 * FastMarching::kTouchedBytes * frontShare * voxels;
    return tables + march + pool;
}

double fastMarchingFrontShare(std::size_t n) {
    // Measured peak touched share (bench_geodesic, bench/results/geodesic.json): from a point source in a solid
    // block the front is a sphere's surface, N^(2/3) voxels: 0.0119, 0.0079, 0.0059 on the 100³, 150³, 200³ boxes
    // (1.19 N^(−1/3)), 0.0147 on the 200³ box with a varying metric. In a band (a shell across which T is small) it
    // is a ring that sweeps the surface, swept across the shell's thickness slowly: 0.091 and 0.084 on the bunny's
    // 80 k-voxel bands, 0.056 on its 300 k-voxel band (26–31 N^(−1/2)). The larger of the two bounds both shapes up
    // to 1e8 voxels, where the pool is under 1 B per voxel either way.
    const double voxels = double(std::max<std::size_t>(1, n));
    return std::min(1.0, std::max(1.5 / std::cbrt(voxels), 32.0 / std::sqrt(voxels)));
}

double laplacianOperatorBytes(std::size_t n) { return (12.0 * 4.0 + 8.0) * double(n); }

double pcgWorkBytes(std::size_t n, const PcgOptions& options, bool includeFallback) {
    const double floats = 5.0 * 4.0 * double(n);
    const bool refines = options.refinement == Refinement::Always ||
                         (options.refinement == Refinement::Automatic && (options.tolerance < kFloatPcgReach || includeFallback));
    return floats + (refines ? 24.0 * double(n) : 0.0);
}

// Measured: the green stage's peak over its baseline, less the operator, the PCG and the right-hand side counted
// above, 436 bytes per voxel on the bunny (σ_rel 1, h 0.06 and 0.04: 0.77 M and 2.6 M voxels; docs/memory.md): the
// assembled L while hypre copies it, then hypre's matrix and hierarchy.
const double kMultigridBytesPerVoxel = 440;

double multigridBytes(std::size_t n) { return kMultigridBytesPerVoxel * double(n); }

// Measured: the green stage's peak with --preconditioner aggregation over its baseline, less the operator, the PCG
// and the right-hand side counted above, 33 bytes per voxel on the bunny at σ_rel 1 (h 0.05: 1.3 M voxels, ≈ 7
// voxels per aggregate) and 52 at σ_rel 0.25 (h 0.0239: 2.4 M voxels, a thinner band: ≈ 4 per aggregate);
// docs/memory.md#aggregation. The middle keeps both stages within ±6 %.
const double kAggregationBytesPerVoxel = 40;

double aggregationBytes(std::size_t n) { return kAggregationBytesPerVoxel * double(n); }

// Measured: the green stage's peak with --preconditioner ic over its baseline, less the operator, the PCG and the
// right-hand side counted above, 565–572 bytes per voxel on the bunny (σ_rel 2, h 0.25; σ_rel 1, h 0.1 and 0.07:
// 20 k, 167 k and 486 k voxels; docs/memory.md#incomplete-cholesky).
const double kIncompleteCholeskyBytesPerVoxel = 570;

double incompleteCholeskyBytes(std::size_t n) { return kIncompleteCholeskyBytesPerVoxel * double(n); }

}  // namespace gpisvdb
