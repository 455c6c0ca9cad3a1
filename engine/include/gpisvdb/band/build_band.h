#pragma once
// Building the band: a breadth-first search from the samples' voxels (the method), and a scan of the bounding
// box (the baseline it is measured and tested against). Both evaluate the GPIS, then μ and T by Kac–Rice, at
// every voxel they visit, and keep the voxels with μ > η.
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/samples.h"
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

/// How a band's μ and T are sampled at each voxel (docs/band.md#coarse-voxels).
enum class VoxelValues {
    Point,  ///< the values at the voxels' centres (paper Eq. 11, 16)
    /// each voxel's own share, the expected area inside it and its tangent moment over h³, from the centre's Gaussian
    /// linearised across the cube (kacRiceVoxel); the band also keeps every voxel the mean surface crosses
    Voxel,
    /// the means along each voxel's three axes on the Gaussian interpolated between neighbouring centres
    /// (kacRiceColumn). For voxels coarser than μ's width.
    Column,
};
/// "point", "voxel" or "column": the name the CLI, the report and the .vdb metadata use.
const char* voxelValuesName(VoxelValues values);
/// The values of that name; throws ParameterError for any other name.
VoxelValues voxelValuesNamed(const std::string& name);

struct BandOptions {
    double voxelSize = 0;                            ///< h, world units (> 0; see chooseResolution)
    double iso = 0.5;                                ///< iso-value u of the surface φ = u
    double etaRelative = 0.01;                       ///< η relative to the median μ over the samples' voxels (> 0)
    int qmcSamples = 512;                            ///< S, QMC points for μ and T (≥ 1)
    double maxAnisotropy = 20;                       ///< T is regularised to √(λmax/λmin) ≤ this before Selling (≥ 1)
    std::size_t maxVoxels = 0;                       ///< refuse once more voxels than this would be evaluated (0: no limit)
    std::size_t batchVoxels = std::size_t(1) << 17;  ///< voxels evaluated together (≥ 1): bounds the build's transient
                                                     ///< memory (≈ 330 bytes each); the band does not depend on it
    VoxelValues values = VoxelValues::Point;         ///< how μ and T are sampled at each voxel (docs/band.md#coarse-voxels)
};

struct BandStats {
    double etaAbsolute = 0;       ///< η in world units⁻¹
    double medianSampleMu = 0;    ///< median μ over the samples' voxels
    std::size_t evaluated = 0;    ///< voxels where μ was computed (band + rejected frontier)
    std::size_t regularised = 0;  ///< voxels whose T was regularised for anisotropy
    int maxStencilL1 = 0;         ///< max ‖e‖₁ over the band
    int levels = 0;               ///< BFS levels (scan: growth rounds)
    // Wall-clock seconds per stage (they sum to about the whole build):
    double modelSeconds = 0;    ///< evaluating the GPIS at the visited voxels
    double kacRiceSeconds = 0;  ///< μ, T, the channels and the Selling stencils from the Gaussians
    double searchSeconds = 0;   ///< the BFS frontier (or the scan's boxes) and η
    double finishSeconds = 0;   ///< the index tree in leaf order and the channels gathered in that order
};

struct BandResult {
    Band band;
    BandStats stats;
};

/// One voxel's fields, as a builder computes them; also the way to make a band from analytic fields.
struct BandVoxel {
    openvdb::Coord coord;          ///< index space; the centre is h·coord
    double mu = 0;                 ///< μ, world units⁻¹
    Mat3d T = Mat3d::Zero();       ///< T, world units⁻¹ (symmetric positive semi-definite)
    double mean = 0;               ///< γ
    double stddev = 0;             ///< √c₀₀
    Vec3d normal = Vec3d::Zero();  ///< outward unit normal
    bool crossed = false;          ///< voxel values: the mean surface γ = u, linearised at the centre, passes through the voxel
};

/// The band over `voxels` (distinct coordinates): the index tree in leaf order, the channels, and the Selling
/// stencil of T regularised to anisotropy ≤ maxAnisotropy. Fills stats.regularised and stats.maxStencilL1.
/// \param voxels         the voxels' fields (BandVoxel), index space, each coordinate once
/// \param voxelSize      h, world units (> 0)
/// \param maxAnisotropy  T is regularised to √(λmax/λmin) ≤ this before Selling (≥ 1)
/// \param progress       its interrupt stops the build (Cancelled)
/// \return the band and its statistics (the search's fields left 0)
/// \throws ParameterError for h or the cap out of range; Error for a coordinate listed twice or 2³¹ voxels or more;
///         Cancelled when interrupted
/// \par Complexity
///   O(N) for N voxels: the index tree's insertions, the channels in leaf order, Selling's decomposition per voxel;
///   memory about the band's own (kFoundBytesPerVoxel and the index tree's).
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel inside (TBB); the band is the same for any thread
///   count.
BandResult bandFromVoxels(std::vector<BandVoxel> voxels, double voxelSize, double maxAnisotropy, const Progress& progress = {});

/// The band by a breadth-first search from the samples' voxels: each level evaluates the GPIS and μ, T by Kac–Rice at
/// its voxels' unvisited neighbours and keeps those with μ > η (docs/band.md).
/// \param model     the GPIS (either model), world units
/// \param samples   its samples: the search starts from their voxels, and η is relative to the median μ there
/// \param options   h, u, η, S, the anisotropy cap, the voxel budget, the batch size, the voxel values
/// \param progress  reports the voxels evaluated; its interrupt stops the search (Cancelled)
/// \return the band (index space, h·k world units) and its statistics
/// \throws ParameterError for bad options (checkBandOptions) or an h at which an index coordinate would pass 1e9;
///         MemoryLimitError once more than options.maxVoxels would be evaluated; InputError when μ vanishes at the
///         samples' voxels; Cancelled when interrupted
/// \par Complexity
///   O(E) evaluations for E evaluated voxels (≈ 1.5× the band), each a model evaluation (O(log n) with Barnes–Hut
///   over n samples) and Kac–Rice's O(S). Memory bandBuildBytes (default_band.h): the band and a batch in flight.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel over each batch (TBB); the band is the same for any
///   thread count and batch size.
BandResult buildBand(const GpisModel& model, const Samples& samples, const BandOptions& options, const Progress& progress = {});

/// Baseline: evaluates every voxel of the samples' bounding box, grown until no band voxel touches its boundary.
/// \param model     as for buildBand
/// \param samples   as for buildBand: their bounding box is the first one scanned
/// \param options   as for buildBand
/// \param progress  reports the voxels evaluated; its interrupt stops the scan (Cancelled)
/// \return the same band as buildBand's, to the bit (tested), with its statistics
/// \throws as buildBand
/// \par Complexity
///   O(V) evaluations for the V voxels of the final box: far more than buildBand's for a thin band (the box's volume
///   over the band's). Memory O(V).
/// \par Thread safety
///   As buildBand.
BandResult scanBand(const GpisModel& model, const Samples& samples, const BandOptions& options, const Progress& progress = {});

// === The steps buildBand is made of, for builders that distribute them (mpi/, docs/mpi.md)

/// Throws ParameterError for the options buildBand refuses.
void checkBandOptions(const BandOptions& options);

/// The voxels holding samples (index space; sorted, distinct): with their 26 neighbours, the BFS's first level.
/// Throws ParameterError when h is so small that an index coordinate would pass 1e9.
std::vector<openvdb::Coord> sampleVoxels(const Samples& samples, double voxelSize);

/// The offsets of a voxel's 26 neighbours, which a BFS level visits around each voxel it keeps.
constexpr int kBfsNeighbours = 26;
const std::array<openvdb::Coord, kBfsNeighbours>& bfsNeighbourOffsets();

/// The QMC points a band's μ and T take: S, or S/4 (at least 1) with voxel or column values, whose integrands the
/// cube's or the segments' average smooths (voxel values: S/4 = 128 is within 1 % of 8192 points; column values: the
/// sphere soup's area, energy and l = 1 gap within 0.03 % of S's at 2 to 8 w_μ; docs/band.md#coarse-voxels).
inline int bandQmcSamples(const BandOptions& options) {
    return options.values != VoxelValues::Point ? (options.qmcSamples >= 4 ? options.qmcSamples / 4 : 1) : options.qmcSamples;
}

/// Whether a band keeps a voxel: μ > η, or (with voxel values) the mean surface crosses it.
inline bool keepsVoxel(const BandVoxel& v, double eta, VoxelValues values) {
    return v.mu > eta || (values == VoxelValues::Voxel && v.crossed && v.mu > 0);
}

/// η = etaRelative × the median of `mus` (μ at the samples' voxels); sets stats.medianSampleMu and etaAbsolute.
/// Throws InputError when the median is not positive.
double etaFromSampleMus(std::vector<double> mus, double etaRelative, BandStats& stats);

/// Throws MemoryLimitError once `evaluated` voxels pass options.maxVoxels (when set).
void checkVoxelBudget(std::size_t evaluated, const BandOptions& options);

}  // namespace gpisvdb
