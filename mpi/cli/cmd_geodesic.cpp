// gpisvdb-mpi geodesic INPUT --source X,Y,Z -o OUT.vdb: the band built across MPI ranks, then gathered on rank 0 and
// marched there (fast marching is sequential; docs/mpi.md#geodesic).
#include <chrono>

#include "geodesic_job.h"
#include "mpi_band_job.h"
#include "mpi_commands.h"

namespace gpisvdb::cli {

void addMpiGeodesic(CLI::App& app, Action& action, const mpi::Ranks& ranks) {
    addCommand<GeodesicArgs>(
        app, action, "geodesic",
        {"geodesic distance and shortest paths (as gpisvdb geodesic): the band built across the MPI ranks, the march on rank 0",
         "The band is built across the ranks and gathered on rank 0, which marches: its memory bounds the band\n"
         "(the band and about 65 bytes per voxel for the march).\n"
         "Example:\n  mpirun -n 4 gpisvdb-mpi geodesic bunny.obj --source 0.5,6,1 --target -2,9,0 -o geo.vdb --threads 1"},
        addGeodesicFlags, bandThreads<GeodesicArgs>, [&ranks](GeodesicArgs& a, Clock::time_point start) {
            GeodesicRequest request;
            mpi::together(ranks, [&] { request = geodesicRequest(a, ranks.rank == 0); });
            MpiBandCommand run = startMpiBandCommand(ranks, a.input, a.output, a.flags);
            const nlohmann::json mpiSection = mpiReport(ranks, run.band);
            gatherWholeBand(ranks, run, a.flags);  // rank 0 marches on it
            mpi::together(ranks, [&] {
                if (ranks.rank == 0)
                    finishGeodesic(run.job, a, request, *run.out, run.report.get(), run.progress, start, {{"mpi", mpiSection}});
            });
        });
}

}  // namespace gpisvdb::cli
