#include "gpisvdb/app/solver_report.h"

#include <string>

namespace gpisvdb::app {

nlohmann::json solverReport(const PcgResult& r, const PcgOptions& options) {
    std::string method = std::string("PCG, ") + preconditionerName(r.preconditioner);
    if (r.preconditioner == Preconditioner::Multigrid) method += " (hypre BoomerAMG)";
    if (r.refinements > 0) method += ", refined in double";
    nlohmann::json report = {{"method", method},
                             {"preconditioner", preconditionerName(r.preconditioner)},
                             {"preconditioner_requested", preconditionerName(options.preconditioner)},
                             {"iterations", r.iterations},
                             {"restarts", r.restarts},
                             {"refinements", r.refinements},
                             {"inner_iterations", r.innerIterations},
                             {"relative_residual", r.relativeResidual},
                             {"float_residual", r.floatResidual},
                             {"tolerance", options.tolerance}};
    if (r.preconditioner == Preconditioner::Multigrid || r.preconditioner == Preconditioner::Aggregation)
        report["multigrid"] = {{"levels", r.multigridLevels}, {"operator_complexity", r.multigridComplexity}};
    return report;
}

}  // namespace gpisvdb::app
