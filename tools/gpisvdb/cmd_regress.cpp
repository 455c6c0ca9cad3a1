// gpisvdb regress INPUT --data DATA.csv -o OUT.vdb: Gaussian-process regression of scalar data on the GPIS with
// the Matérn kernel of its Laplacian eigenpairs (paper Eq. 26, Fig. 9).
#include <chrono>

#include "commands.h"
#include "regress_job.h"
#include "spectrum_job.h"

namespace gpisvdb::cli {

void addRegress(CLI::App& app, Action& action) {
    addCommand<RegressArgs>(
        app, action, "regress",
        {"Gaussian-process regression of scalar data on the GPIS (Matern kernel), as a .vdb",
         "Prior: constant mean (the data mean) + a Matern GP built from the k lowest eigenpairs (-k, default 200).\n"
         "Data points must lie in the band (on the shape); the eigenvectors are interpolated trilinearly there.\n"
         "Example:\n  gpisvdb regress bunny.obj --data temperature.csv --nu 1.5 -o regression.vdb --sigma 1"},
        addRegressFlags, bandThreads<RegressArgs>, [](RegressArgs& a, Clock::time_point start) {
            const RegressionOptions options = regressionOptions(a);  // nothing runs on a bad flag
            const PointData points = readPointData(a.data);
            BandCommand run = startBandCommand(a.input, a.output, a.flags);
            // === The posterior's memory, refused before the eigen solver runs: m, k and the band are known now, and
            //     beside them the posterior holds the k eigenvectors (8 B per voxel each)
            const std::size_t voxels = run.job.result.band.size();
            estimateRegression(run.job, options, points, voxels, a.eigen.count,
                               {{"eigenvectors", 8.0 * double(voxels) * double(a.eigen.count)}},
                               "regression (with its eigenvectors, before the eigen solver runs)", "libraries, input, band");
            // === Eigenpairs, then the posterior
            const auto tSolve = Clock::now();
            nlohmann::json spectrumStage;
            const EigenResult e = runSpectrum(run.job, a.eigen, run.progress, &spectrumStage);
            const double secondsSpectrum = std::chrono::duration<double>(Clock::now() - tSolve).count();
            finishRegress(run.job, a, options, points, e, spectrumStage, secondsSpectrum, *run.out, run.report.get(), run.progress, start);
        });
}

}  // namespace gpisvdb::cli
