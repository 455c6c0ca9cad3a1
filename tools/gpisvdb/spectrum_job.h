#pragma once
// What `spectrum` and `regress` share: the eigen solver's flags, its memory check, and its report section.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "band_job.h"
#include "gpisvdb/solve/eigen_solver.h"

namespace gpisvdb::cli {

/// -k, --subspace, --eigen-tolerance, --max-restarts.
void addEigenFlags(CLI::App& cmd, EigenOptions& options);

/// "eigen_000", "eigen_001", … (more digits past 999): the grid of eigenvector i.
std::string eigenGridName(int i);

/// The k lowest eigenpairs of the job's band, refused before the numeric factorisation when the factor, the Lanczos
/// basis and the vectors would not fit in --max-memory beside the band.
/// With `memory`: the stage's estimate (the settled resident set at its start; the assembled L in double, the mass,
/// and the eigen solver's factor, basis and vectors as estimated before the factorisation) and the peak measured
/// over it, as memoryStageReport writes them.
EigenResult runSpectrum(const BandJob& job, const EigenOptions& options, const Progress& progress,
                        nlohmann::json* memory = nullptr);

/// The report's "spectrum" section: method, eigenvalues, residuals, orthonormality, solver counts and memory.
nlohmann::json spectrumReport(const EigenResult& eigen);

}  // namespace gpisvdb::cli
