#pragma once
// Memory of a run, estimated before allocating and measured after (issue 18 item 2; docs/memory.md).
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

struct PcgOptions;

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
    double baselineBytes = 0;                               ///< resident set at the stage's start, bytes
    std::vector<std::pair<std::string, double>> parts;     ///< what the stage allocates, bytes, by name
    double stageBytes() const;                              ///< Σ parts, bytes
    double peakBytes() const { return baselineBytes + stageBytes(); }  ///< the estimated peak resident set, bytes
};

/// The bytes a fast march over n band voxels allocates beside the band: the reverse-stencil table (4 B per entry,
/// `entries` of them: the stencil terms that stay in the band, ≤ 12 n; 4 B per voxel of offsets), U, the slot map
/// and the target flags (FastMarching::kMarchBytesPerVoxel), and the pool of touched voxels, `frontShare` n of
/// them at FastMarching::kTouchedBytes, the vectors' growth by doubling included.
double fastMarchingBytes(std::size_t n, std::size_t entries, double frontShare);

/// The share of a band's voxels a march holds in its pool at once, bound from measurements (docs/memory.md): the
/// front of a march is a surface of the accepted region, so the share falls with the band's size.
double fastMarchingFrontShare(std::size_t n);

/// Bytes the matrix-free Laplacian (ops/laplacian.h) allocates for n band voxels: its neighbour table (12 int32
/// per voxel) and its per-voxel sums in double, 56 B per voxel; the scatter schedule (a few bytes per leaf) is
/// below the measurement's resolution and not counted.
double laplacianOperatorBytes(std::size_t n);

/// Bytes a PcgSolver allocates for n unknowns with these options, Jacobi preconditioned (solve/pcg.h): r, z, p,
/// A p and the inverse diagonal in float (20 B per unknown), plus the refinement's residual in double, its inner
/// right-hand side and solution in float and the solution in double (24 B) when the tolerance is below what
/// float reaches (kFloatPcgReach) or refinement is Always. With Refinement::Automatic above kFloatPcgReach a float
/// solve that stalls refines too, and then allocates those 24 B after all: not counted, since it is the exception
/// (`includeFallback` counts it). Other preconditioners' own memory (IC's factor, a multigrid hierarchy) is not
/// counted here.
double pcgWorkBytes(std::size_t n, const PcgOptions& options, bool includeFallback = false);

/// Peak bytes the multigrid preconditioner (solve/boomer_amg.h) adds for n unknowns of the band Laplacian while it is
/// set up and kept: the assembled L (float), hypre's copy of it and the hierarchy; measured per voxel on bunny bands
/// (kMultigridBytesPerVoxel, docs/memory.md).
double multigridBytes(std::size_t n);

/// The multigrid's peak per unknown (above), measured.
extern const double kMultigridBytesPerVoxel;

/// Peak bytes the aggregation multigrid (solve/aggregation_multigrid.h) adds for n band voxels while it is set up
/// and kept: aggregates, coarse operators (its set-up holds the first coarse level twice), smoother and cycle
/// vectors; measured per voxel on bunny bands (kAggregationBytesPerVoxel, docs/memory.md).
double aggregationBytes(std::size_t n);

/// The aggregation multigrid's peak per band voxel (above), measured.
extern const double kAggregationBytesPerVoxel;

/// Peak bytes the incomplete Cholesky preconditioner (solve/pcg.h) adds for n unknowns of the band Laplacian while
/// it is set up and kept: the assembled L (float CSR), Eigen's column-major copy, its permuted lower triangle,
/// AMD ordering and column lists, and the factor; measured per voxel on bunny bands
/// (kIncompleteCholeskyBytesPerVoxel, docs/memory.md#incomplete-cholesky).
double incompleteCholeskyBytes(std::size_t n);

/// The incomplete Cholesky's peak per unknown (above), measured.
extern const double kIncompleteCholeskyBytesPerVoxel;

}  // namespace gpisvdb
