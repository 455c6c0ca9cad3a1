#pragma once
// The GPIS, then μ, T, γ, √c₀₀ and the normal by Kac–Rice, at a band's voxels, as its options ask (point, voxel or
// column values; docs/band.md#coarse-voxels): the step buildBand, scanBand, the forecast and the distributed build
// share.
#include <memory>
#include <vector>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

/// The GPIS, then μ, T, γ, √c₀₀ and the normal by Kac–Rice, at voxels, as a band's options ask. A voxel's result
/// depends on its coordinate alone, never on the others evaluated with it. Stateful for column values only: the
/// Gaussians at the centres evaluated in this BFS round and the one before, which the next voxels' face neighbours
/// mostly are (older ones are evaluated again when needed, with the same result); 168 bytes per centre held.
class BandVoxelEvaluator {
public:
    /// The model must outlive the evaluator; options as buildBand's (voxelSize, iso, qmcSamples, values).
    BandVoxelEvaluator(const GpisModel& model, const BandOptions& options);
    ~BandVoxelEvaluator();
    /// The voxels coords[begin, end), in parallel; the seconds of each part are added to stats.modelSeconds and
    /// stats.kacRiceSeconds.
    std::vector<BandVoxel> operator()(const std::vector<openvdb::Coord>& coords, std::size_t begin, std::size_t end,
                                      const Progress& progress, BandStats& stats);
    /// A BFS round is over: the Gaussians of the round before it are let go.
    void nextRound();

private:
    struct Centres;
    const GpisModel& model_;
    double h_, iso_;
    VoxelValues values_;
    QmcRule rule_;
    std::unique_ptr<Centres> centres_;
};

}  // namespace gpisvdb
