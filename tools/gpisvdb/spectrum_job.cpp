#include "spectrum_job.h"

#include <algorithm>
#include <cstdio>

#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/tasks/spectrum.h"

namespace gpisvdb::cli {

void eigenBandBudget(BandFlags& flags) {
    flags.maxBandVoxels = kEigenMaxBandVoxels;
    flags.budgetDefaultWhy = "the default of commands that solve for eigenpairs, docs/spectrum.md#budget";
}

void addEigenFlags(CLI::App& cmd, EigenOptions& o) {
    cmd.add_option("-k,--count", o.count, "number of lowest eigenpairs (1 <= k < band voxels)")->capture_default_str();
    cmd.add_option("--subspace", o.subspace, "Lanczos basis size (> k; 0: max(2k, k+20)); memory 16 N ncv bytes")->capture_default_str();
    cmd.add_option("--eigen-tolerance", o.tolerance, "relative tolerance on each Ritz value (> 0)")->capture_default_str();
    cmd.add_option("--max-restarts", o.maxRestarts, "Lanczos restart cap (>= 1)")->capture_default_str();
    cmd.add_option("--eigen-method", o.method,
                   "auto (default: Lanczos on a Cholesky factor where it fits in --max-memory, else LOBPCG), "
                   "lanczos, or lobpcg (multigrid-preconditioned, no factor: far less memory)")
        ->transform(CLI::CheckedTransformer(std::map<std::string, EigenMethod>{
            {"auto", EigenMethod::Automatic}, {"lanczos", EigenMethod::ShiftInvert}, {"lobpcg", EigenMethod::Lobpcg}}));
}

void addSpectrumFlags(CLI::App& cmd, SpectrumArgs& a, const std::string& outputHelp) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    cmd.add_option("-o,--output", a.output, outputHelp)->required();
    addEigenFlags(cmd, a.eigen);
    addBandFlags(cmd, a.flags);
}

std::string eigenGridName(int i) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "eigen_%03d", i);
    return buf;
}

EigenResult runSpectrum(const BandJob& job, const EigenOptions& options, const Progress& progress, nlohmann::json* memory) {
    const Band& band = job.result.band;
    const double n = double(band.size());
    // === The assembled L in double and the mass, counted from the stencils and refused before they are made; the
    //     assembly's own peak (its contributions before each row is merged) is the larger part on small factors
    const LaplacianSize size = laplacianSize(band);
    const double matrix = assembledLaplacianBytes(size, sizeof(double));
    const double assembly = laplacianAssemblyBytes(size, sizeof(double)) - matrix;
    const double mass = 8.0 * n;  // M's diagonal in double
    std::vector<std::pair<std::string, double>> before = {{"laplacian_double", matrix}};
    if (assembly > mass) before.emplace_back("laplacian_assembly", assembly);
    else before.emplace_back("mass", mass);
    MemoryEstimate estimate = estimateStage(job, "assembled Laplacian of the eigen solver", before);
    // === The eigen solver's factor, basis and vectors: refused by the solver after CHOLMOD's symbolic analysis,
    //     within what is left beside L and M
    EigenOptions o = options;
    o.maxBytes = std::max(1.0, job.maxMemory - estimate.baselineBytes - matrix - mass);
    const bool stageOnly = resetPeakResident();
    EigenResult e = spectrum(band, o, progress);
    const double peak = peakResidentBytes();
    // The stage's peak: the assembly's, or L and M beside the solver's
    if (assembly > mass + e.estimatedBytes) estimate.parts = {{"laplacian_double", matrix}, {"laplacian_assembly", assembly}};
    else estimate.parts = {{"laplacian_double", matrix}, {"mass", mass}, {"eigen_solver", e.estimatedBytes}};
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
