#pragma once
// The band built by several processes (docs/mpi.md#band): each rank evaluates the voxels of its own range of the
// band's linear order (band/tree_partition.h), the BFS frontier is exchanged between ranks level by level, and at
// the end the found voxels move so that every rank holds an equal, contiguous range of the one-process band. The
// voxel set and every channel equal the one-process band's to the bit (a voxel's Gaussians do not depend on the
// voxels evaluated with it), and local index i on rank r is linear index offset + i there.
#include <cstddef>
#include <vector>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/band/tree_partition.h"
#include "gpisvdb/mpi/ranks.h"

namespace gpisvdb::mpi {

struct DistributedBand {
    Band local;                                ///< this rank's voxels, in linear order
    std::size_t offset = 0;                    ///< linear index of local voxel 0 in the whole band
    std::size_t globalSize = 0;                ///< voxels of the whole band
    std::vector<std::size_t> counts;           ///< voxels per rank (after balancing)
    TreePartition partition;                   ///< which rank holds which range (after balancing)
    BandStats stats;                           ///< the whole band's; seconds are the slowest rank's
    std::vector<std::size_t> searchVoxels;     ///< band voxels per rank while searching (the partition from the samples)
    std::vector<std::size_t> searchEvaluated;  ///< voxels each rank evaluated while searching
    double balanceSeconds = 0;                 ///< moving the found voxels to their final rank
};

/// The partition the search starts from: the samples' leaves weighted by their vector areas ‖w_i‖ (the band's
/// voxels per leaf go with the surface area there), cut into ranks.size ranges of equal weight.
TreePartition samplePartition(const Ranks& ranks, const Samples& samples, double voxelSize);

/// buildBand across the ranks (same options, same result). Collective; errors are agreed (together()).
DistributedBand buildBandDistributed(const Ranks& ranks, const GpisModel& model, const Samples& samples, const BandOptions& options,
                                     const Progress& progress = {});

/// The whole band on rank 0 (its index tree rebuilt; channels gathered); an empty band elsewhere. Collective.
Band gatherBand(const Ranks& ranks, const DistributedBand& band);

/// A per-voxel channel of the ranks' local bands, concatenated on rank 0 (empty elsewhere). Collective.
template <class T>
std::vector<T> gatherChannel(const Ranks& ranks, const std::vector<T>& local) {
    return gatherToRoot(ranks, local);
}

}  // namespace gpisvdb::mpi
