// gpisvdb geodesic INPUT --source X,Y,Z -o OUT.vdb: geodesic distance on the GPIS by Hamiltonian fast marching
// (paper Sec. 10.2, Eq. 28) and shortest paths to target points.
#include <chrono>

#include "commands.h"
#include "geodesic_job.h"

namespace gpisvdb::cli {

void addGeodesic(CLI::App& app, Action& action) {
    addCommand<GeodesicArgs>(
        app, action, "geodesic",
        {"Geodesic distance on the GPIS from source points, and shortest paths, as a .vdb",
         "Solves sqrt(grad U . T grad U) = 1 with U = 0 at the sources: U is about the surface distance over\n"
         "sqrt(mu), so it grows faster where the surface is uncertain. Voxels not reached are inactive in\n"
         "'geodesic' (background: the largest distance reached) and counted in the report.\n"
         "Example:\n  gpisvdb geodesic bunny.obj --source 0.5,6,1 --target -2,9,0 -o geo.vdb --paths path.vtp --sigma 1"},
        addGeodesicFlags, bandThreads<GeodesicArgs>, [](GeodesicArgs& a, Clock::time_point start) {
            GeodesicRequest request = geodesicRequest(a);
            BandCommand run = startBandCommand(a.input, a.output, a.flags);
            finishGeodesic(run.job, a, request, *run.out, run.report.get(), run.progress, start);
        });
}

}  // namespace gpisvdb::cli
