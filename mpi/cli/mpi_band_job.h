#pragma once
// What gpisvdb-mpi's band commands share (docs/mpi.md): the input read and the outputs opened (rank 0) with every
// rank agreeing on failure, the band built across the ranks, gathered on rank 0 for the .vdb, and the report's
// `mpi` section.
#include <memory>
#include <string>

#include "band_job.h"
#include "gpisvdb/mpi/distributed_band.h"
#include "gpisvdb/mpi/slepc_spectrum.h"

namespace gpisvdb::cli {

struct MpiBandCommand {
    std::unique_ptr<AtomicOutput> out;     ///< rank 0 only
    std::unique_ptr<AtomicOutput> report;  ///< rank 0 with --report only
    Progress progress;                     ///< a bar on rank 0 (unless --quiet); Ctrl-C polled on every rank
    BandJob job;                           ///< its band: empty until gatherWholeBand, then the whole band on rank 0
    mpi::DistributedBand band;             ///< this rank's part
};

/// Reads the input, opens the outputs and builds the band across `ranks`. Collective; errors are agreed
/// (mpi::together). An output ending in .nvdb sets flags.vdb.nanoVdb.
MpiBandCommand startMpiBandCommand(const mpi::Ranks& ranks, const std::string& input, const std::string& output, BandFlags& flags);

/// The whole band on rank 0 (c.job.result.band), for the .vdb or a task that runs there, and the band's warnings
/// printed by rank 0. Called as late as the command allows (after its distributed solve), so that rank 0 does not
/// hold the whole band beside the solver. Without `keepLocal` every rank's part is freed. Collective.
void gatherWholeBand(const mpi::Ranks& ranks, MpiBandCommand& command, const BandFlags& flags, bool keepLocal = false);

/// The report's `mpi` section: ranks, voxels per rank (while searching and after balancing), voxels evaluated per
/// rank, bytes sent in exchanges (summed over ranks) and the longest time a rank spent in them, each rank's peak
/// resident set so far, and `extra` (e.g. the solver's halo). Collective.
nlohmann::json mpiReport(const mpi::Ranks& ranks, const mpi::DistributedBand& band, nlohmann::json extra = {});

/// The report's `spectrum` section for SLEPc's eigenpairs: method, eigenvalues, residuals, orthonormality, iterations.
nlohmann::json slepcSpectrumReport(const mpi::DistributedSpectrum& spectrum);

}  // namespace gpisvdb::cli
