#pragma once
// What gpisvdb regress and gpisvdb-mpi regress share: the flags, their checks, and the regression, outputs and
// report once the band and its eigenpairs are there (docs/spectrum.md; across ranks the eigenpairs are SLEPc's,
// gathered on rank 0 with the band, docs/mpi.md).
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>

#include "band_job.h"
#include "gpisvdb/input/point_data.h"
#include "gpisvdb/tasks/matern.h"
#include "spectrum_job.h"

namespace gpisvdb::cli {

struct RegressArgs {
    RegressArgs() {
        eigen.count = 200;
        eigenBandBudget(flags);
    }
    std::string input, output, data, nu = "1.5";
    double kappa = 0, amplitude = 0;
    BandFlags flags;
    EigenOptions eigen;
};

/// INPUT, --data, -o, --nu, --kappa, --amplitude, the eigen solver's flags and the band flags.
void addRegressFlags(CLI::App& cmd, RegressArgs& args);

/// The regression's options from the flags; ParameterError for a bad one (nothing has run yet).
RegressionOptions regressionOptions(const RegressArgs& args);

/// The posterior's memory (regressionBytes for `voxels` band voxels, the data points and k eigenpairs) beside what
/// this process holds now and `ahead`: what is allocated before the posterior but not yet held (the k eigenvectors,
/// on gpisvdb-mpi the whole band gathered on rank 0), so that the posterior can be refused before the eigen solver
/// runs. `stage` and `held` name the stage and what the process holds in the refusal. Throws MemoryLimitError beyond
/// --max-memory, naming fewer data points or eigenpairs where those bytes alone do not fit, else the voxel size.
MemoryEstimate estimateRegression(const BandJob& job, const RegressionOptions& options, const PointData& points, std::size_t voxels, int k,
                                  std::vector<std::pair<std::string, double>> ahead, const std::string& stage, const std::string& held);

/// The posterior on the job's band from its eigenpairs `e` (computed in `secondsSpectrum`, their memory stage in
/// `spectrumStage`), the .vdb and the report (with `extra` merged into it).
void finishRegress(const BandJob& job, const RegressArgs& args, const RegressionOptions& options, const PointData& points,
                   const EigenResult& e, const nlohmann::json& spectrumStage, double secondsSpectrum, AtomicOutput& out,
                   AtomicOutput* report, const Progress& progress, std::chrono::steady_clock::time_point start,
                   const nlohmann::json& extra = {});

}  // namespace gpisvdb::cli
