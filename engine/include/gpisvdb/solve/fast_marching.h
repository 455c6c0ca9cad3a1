#pragma once
// Hamiltonian fast marching (Mirebeau–Portegies 2019; paper Eq. 28; docs/math.md#fast-marching) for the generalised eikonal
// equation ‖∇U‖_T = √(∇U·T∇U) = 1 on a band, with T given by the band's Selling stencils T = Σ λ_k e_k e_kᵀ.
// At each voxel x the upwind scheme
//     Σ_k λ_k max(0, U(x) − U(x − h e_k), U(x) − U(x + h e_k))² = h²
// is solved in acceptance order (Dijkstra-like): a voxel's value is recomputed from its accepted stencil
// neighbours whenever one of them is accepted (found through a reverse-stencil table). Voxels outside the band are
// never accepted; a voxel whose whole stencil leaves the band, or that no front reaches, keeps U = +∞ and is
// counted. U is computed in double. Single-threaded, so the result does not depend on the thread count.
// With T = c I, U is the Euclidean distance over √c; with a constant T, U(x) → √((x − s)ᵀ T⁻¹ (x − s)).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/core/progress.h"

namespace gpisvdb {

struct FastMarchingOptions {
    bool stopAtTargets = true;  ///< stop once every target is accepted (when targets are given)
};

struct FastMarchingResult {
    std::vector<double> distance;  ///< U by linear index, world units × T^(−1/2); +∞ where not reached
    std::size_t accepted = 0;      ///< voxels accepted (their U is final)
    std::size_t unreached = 0;     ///< voxels left at +∞ (never reached, or not reached before an early stop)
    bool stoppedEarly = false;     ///< the march ended at the targets, before the band was exhausted
    std::size_t peakTouched = 0;   ///< most voxels touched but not yet accepted at once (the march's pool; ≈ the front)
};

/// The band's reverse-stencil table (for each voxel y, the voxels x and terms k with x ± h e_k = y; 4 B per entry,
/// ≤ 12 entries, plus a 4 B start: measured 47–52 B per voxel), built once for several marches on one band. The
/// band must outlive it. A march holds kMarchBytesPerVoxel = 13 B per voxel more while it runs (U 8, a slot or
/// "accepted" mark 4, the target flag 1), plus kTouchedBytes per voxel touched but not yet accepted (the front;
/// FastMarchingResult::peakTouched): about 65 B per voxel in all, where runReference holds 136
/// (docs/memory.md).
class FastMarching {
public:
    explicit FastMarching(const Band& band);

    /// U from the given source voxels (linear indices, U = 0 there). Throws ParameterError on an empty source
    /// list or an index outside the band.
    FastMarchingResult run(const std::vector<std::size_t>& sources, const std::vector<std::size_t>& targets = {},
                           const FastMarchingOptions& options = {}, const Progress& progress = {}) const;

    /// The same march as run(), by the plain algorithm (a 72 B record for every band voxel, 85 B per voxel beside
    /// the tables, no pool): kept as the reference the tests and bench_geodesic compare run() with, bit for bit.
    FastMarchingResult runReference(const std::vector<std::size_t>& sources, const std::vector<std::size_t>& targets = {},
                                    const FastMarchingOptions& options = {}, const Progress& progress = {}) const;

    /// Bytes held by the tables, per band voxel.
    double bytesPerVoxel() const;

    /// Per-voxel bytes of a march beside the tables: U (8), the slot map (4), the target flags (1).
    static constexpr double kMarchBytesPerVoxel = 13;
    /// Bytes per touched, unaccepted voxel: its pool record (88), its heap entry (16), a free-slot entry (4).
    static constexpr double kTouchedBytes = 108;

private:
    const Band& band_;
    std::vector<std::uint32_t> reverseStart_;  // voxels whose stencil reaches y: reverse_[reverseStart_[y] …]
    std::vector<std::uint32_t> reverse_;       // x << 3 | k: term k of x's stencil reaches y
};

/// One march: FastMarching(band).run(…): U with ‖∇U‖_T = 1 (paper Eq. 28) from the sources.
/// \param band      the band (its Selling stencils), N voxels
/// \param sources   source voxels, linear indices (U = 0 there)
/// \param targets   target voxels, linear indices (options.stopAtTargets ends the march once all are accepted)
/// \param options   whether to stop once every target is accepted
/// \param progress  reports the voxels accepted; its interrupt stops the march (Cancelled)
/// \return U by linear index (+∞ where not reached) and the counts of accepted and unreached voxels
/// \throws ParameterError without a source, for an index outside the band, or above 5.4e8 voxels; Cancelled when
///         interrupted
/// \par Complexity
///   O(N log N): each voxel accepted once from a heap, each acceptance updating the voxels whose stencils reach it
///   (≤ 12 per voxel on average). Memory fastMarchingBytes: the reverse-stencil table, U and the front (measured
///   62–66 B per voxel).
/// \par Thread safety
///   Reads the band only: concurrent calls are safe. The march is sequential (the table is built in parallel); the
///   result is the same for any thread count.
FastMarchingResult fastMarching(const Band& band, const std::vector<std::size_t>& sources, const std::vector<std::size_t>& targets = {},
                                const FastMarchingOptions& options = {}, const Progress& progress = {});

/// The bytes a fast march over n band voxels allocates beside the band: the reverse-stencil table (4 B per entry,
/// `entries` of them: the stencil terms that stay in the band, ≤ 12 n; 4 B per voxel of offsets), U, the slot map
/// and the target flags (FastMarching::kMarchBytesPerVoxel), and the pool of touched voxels, `frontShare` n of
/// them at FastMarching::kTouchedBytes, the vectors' growth by doubling included.
double fastMarchingBytes(std::size_t n, std::size_t entries, double frontShare);

/// The share of a band's voxels a march holds in its pool at once, bound from measurements (docs/memory.md): the
/// front of a march is a surface of the accepted region, so the share falls with the band's size.
double fastMarchingFrontShare(std::size_t n);

}  // namespace gpisvdb
