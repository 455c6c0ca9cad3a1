#include "spectrum_job.h"

#include <algorithm>
#include <cstdio>

#include "gpisvdb/tasks/spectrum.h"

namespace gpisvdb::cli {

void addEigenFlags(CLI::App& cmd, EigenOptions& o) {
    cmd.add_option("-k,--count", o.count, "number of lowest eigenpairs (1 <= k < band voxels)")->capture_default_str();
    cmd.add_option("--subspace", o.subspace, "Lanczos basis size (> k; 0: max(2k, k+20)); memory 16 N ncv bytes")
        ->capture_default_str();
    cmd.add_option("--eigen-tolerance", o.tolerance, "relative tolerance on each Ritz value (> 0)")->capture_default_str();
    cmd.add_option("--max-restarts", o.maxRestarts, "Lanczos restart cap (>= 1)")->capture_default_str();
    cmd.add_option("--eigen-method", o.method,
                   "auto (default: Lanczos on a Cholesky factor where it fits in --max-memory, else LOBPCG), "
                   "lanczos, or lobpcg (multigrid-preconditioned, no factor: far less memory)")
        ->transform(CLI::CheckedTransformer(std::map<std::string, EigenMethod>{
            {"auto", EigenMethod::Automatic}, {"lanczos", EigenMethod::ShiftInvert}, {"lobpcg", EigenMethod::Lobpcg}}));
}

std::string eigenGridName(int i) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "eigen_%03d", i);
    return buf;
}

EigenResult runSpectrum(const BandJob& job, const EigenOptions& options, const Progress& progress, nlohmann::json* memory) {
    EigenOptions o = options;
    o.maxBytes = std::max(1.0, job.maxMemory - double(job.result.band.size()) * job.result.band.bytesPerVoxel());
    MemoryEstimate estimate;
    estimate.baselineBytes = settledResidentBytes();
    const bool stageOnly = resetPeakResident();
    EigenResult e = spectrum(job.result.band, o, progress);
    const double peak = peakResidentBytes();
    const double n = double(job.result.band.size());
    // CSR in double: 8 B value + 4 B column index per entry, 4 B per row start; the mass: 8 B per voxel
    estimate.parts = {{"laplacian_double", 12.0 * e.matrixNonzeros + 4.0 * (n + 1)}, {"mass", 8.0 * n},
                      {"eigen_solver", e.estimatedBytes}};
    if (memory) *memory = memoryStageReport(estimate, peak, stageOnly);
    return e;
}

nlohmann::json spectrumReport(const EigenResult& e) {
    std::vector<double> values(e.values.data(), e.values.data() + e.values.size());
    std::vector<double> residuals(e.residuals.data(), e.residuals.data() + e.residuals.size());
    if (e.method == EigenMethod::Lobpcg)
        return {{"method", "LOBPCG preconditioned by the multigrid (hypre BoomerAMG)"},
                {"count", values.size()},
                {"eigenvalues", values},
                {"residuals", residuals},
                {"orthonormality_error", e.orthonormalityError},
                {"block", e.subspace},
                {"iterations", e.iterations},
                {"multigrid", {{"levels", e.multigridLevels}, {"operator_complexity", e.multigridComplexity}}},
                {"lobpcg_s", e.lobpcgSeconds}};
    return {{"method", "Lanczos (Spectra) on L^-1 M, CHOLMOD supernodal Cholesky of L"},
            {"count", values.size()},
            {"eigenvalues", values},
            {"residuals", residuals},
            {"orthonormality_error", e.orthonormalityError},
            {"subspace", e.subspace},
            {"restarts", e.restarts},
            {"solves", e.solves},
            {"factor_bytes", e.factorBytes},
            {"factor_nonzeros", e.factorNonzeros},
            {"ordering", e.ordering},
            {"factor_s", e.factorSeconds},
            {"lanczos_s", e.lanczosSeconds}};
}

}  // namespace gpisvdb::cli
