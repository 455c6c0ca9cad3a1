#include "spectrum_job.h"

#include <algorithm>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/spectrum.h"

namespace gpisvdb::cli {

void addEigenFlags(CLI::App& cmd, EigenOptions& o) {
    cmd.add_option("-k,--count", o.count, "number of lowest eigenpairs (1 <= k < band voxels)")->capture_default_str();
    cmd.add_option("--subspace", o.subspace, "Lanczos basis size (> k; 0: max(2k, k+20)); memory 8 N ncv bytes")
        ->capture_default_str();
    cmd.add_option("--eigen-tolerance", o.tolerance, "relative tolerance on each Ritz value (> 0)")->capture_default_str();
    cmd.add_option("--max-restarts", o.maxRestarts, "Lanczos restart cap (>= 1)")->capture_default_str();
}

EigenResult runSpectrum(const BandJob& job, const EigenOptions& options, const Progress& progress) {
    const double n = double(job.result.band.size());
    if (options.count >= 1 && options.count < n) {
        const double ncv = options.subspace > 0 ? options.subspace : std::max(2.0 * options.count, options.count + 20.0);
        const double bytes = 8.0 * n * (std::min(ncv, n) + options.count);
        if (bytes > job.maxMemory)
            throw ParameterError(std::to_string(options.count) + " eigenvectors of a band of " + std::to_string(std::size_t(n)) +
                                 " voxels need about " + numberText(bytes / 1e9) + " GB (Lanczos basis and vectors), more than " +
                                 "--max-memory allows (" + numberText(job.maxMemory / 1e9) +
                                 " GB): lower -k, use a coarser --voxel-size, or raise --max-memory");
    }
    return spectrum(job.result.band, options, progress);
}

nlohmann::json spectrumReport(const EigenResult& e) {
    std::vector<double> values(e.values.data(), e.values.data() + e.values.size());
    std::vector<double> residuals(e.residuals.data(), e.residuals.data() + e.residuals.size());
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
