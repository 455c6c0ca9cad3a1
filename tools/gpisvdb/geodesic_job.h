#pragma once
// What gpisvdb geodesic and gpisvdb-mpi geodesic share: the flags, their checks, and the march, paths and outputs on
// a built band (docs/geodesic.md; across ranks the band is gathered on rank 0 and marched there, docs/mpi.md).
#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "band_job.h"
#include "gpisvdb/output/paths.h"

namespace gpisvdb::cli {

struct GeodesicArgs {
    std::string input, output, paths;
    std::vector<std::vector<double>> sources, targets;
    bool stopAtTargets = false;
    BandFlags flags;
};

/// INPUT, --source, --target, -o, --paths, --stop-at-targets and the band flags.
void addGeodesicFlags(CLI::App& cmd, GeodesicArgs& args);

/// The flags checked (ParameterError) and resolved; the paths file opened (a command's outputs open before its band).
struct GeodesicRequest {
    std::vector<Vec3d> sources, targets;
    PathFormat pathFormat = PathFormat::Json;
    std::unique_ptr<AtomicOutput> pathsOut;  ///< null without --paths
};
GeodesicRequest geodesicRequest(const GeodesicArgs& args, bool openPaths = true);

/// The march on the job's band, the paths by backtracking, the .vdb, the paths file and the report (with `extra`
/// merged into it), committed in that order.
void finishGeodesic(const BandJob& job, const GeodesicArgs& args, GeodesicRequest& request, AtomicOutput& out, AtomicOutput* report,
                    const Progress& progress, std::chrono::steady_clock::time_point start, const nlohmann::json& extra = {});

}  // namespace gpisvdb::cli
