#pragma once
// Memory of a run, estimated before allocating and measured after (docs/memory.md). Each algorithm states its own
// bytes beside it (e.g. pcgWorkBytes in solve/pcg.h, fastMarchingBytes in solve/fast_marching.h).
//
// An estimate is the process's resident set when the stage starts (its baseline: the libraries, about 100–150 MB,
// the input, the band) plus the bytes the stage allocates, counted from the sizes known before it allocates: the
// baseline is measured, not modelled, because it is set by the loader and the allocator, not by the band. The
// measurement is the peak resident set (VmHWM of /proc/self/status) over the stage, which resetPeakResident()
// restarts at the stage's start where the kernel allows it.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace gpisvdb {

/// Resident set of this process now (VmRSS), bytes; 0 where /proc/self/status cannot be read.
double residentBytes();

/// The resident set after the allocator has handed its free memory back to the kernel (malloc_trim): a stage's
/// baseline. Without the trim, memory an earlier stage freed stays resident and the next stage reuses it, so the
/// resident set would grow by less than the stage allocates and an estimate of baseline + stage would overshoot.
double settledResidentBytes();

/// Peak resident set of this process (VmHWM), bytes; 0 where /proc/self/status cannot be read.
double peakResidentBytes();

/// Restarts the peak resident set at the current one (writes 5 to /proc/self/clear_refs, Linux ≥ 4.0), so that
/// peakResidentBytes() then measures a stage alone. False where the kernel refuses: the peak then spans the run.
bool resetPeakResident();

/// A stage's estimate: the baseline measured at its start and the bytes it will allocate, named by part.
struct MemoryEstimate {
    double baselineBytes = 0;                                          ///< resident set at the stage's start, bytes
    std::vector<std::pair<std::string, double>> parts;                 ///< what the stage allocates, bytes, by name
    double stageBytes() const;                                         ///< Σ parts, bytes
    double peakBytes() const { return baselineBytes + stageBytes(); }  ///< the estimated peak resident set, bytes
};

}  // namespace gpisvdb
