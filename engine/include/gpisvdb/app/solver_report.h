#pragma once
// A PCG solve as every front end reports it (docs/operators.md, "Green's function"): the same keys from `gpisvdb green` and
// `hodge`, gpisvdb-mpi's green and the Python module's `green` and `hodge`.
#include <nlohmann/json.hpp>

#include "gpisvdb/solve/pcg.h"

namespace gpisvdb::app {

/// The report's `solver` section: method, preconditioner (as used and as asked), iterations, restarts, refinements,
/// inner_iterations, relative_residual (of the double solution when refined), float_residual (of the float values
/// returned), tolerance, and for the multigrids their levels and operator complexity.
nlohmann::json solverReport(const PcgResult& result, const PcgOptions& options);

}  // namespace gpisvdb::app
