#pragma once
// What `spectrum` and `regress` share: the eigen solver's flags, its memory check, and its report section.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "band_job.h"
#include "gpisvdb/solve/eigen_solver.h"

namespace gpisvdb::cli {

/// The band-voxel budget of commands that solve for eigenpairs (kEigenMaxBandVoxels) as the flags' default.
void eigenBandBudget(BandFlags& flags);

/// -k, --subspace, --eigen-tolerance, --max-restarts.
void addEigenFlags(CLI::App& cmd, EigenOptions& options);

/// `spectrum`'s flags, gpisvdb's and gpisvdb-mpi's alike.
struct SpectrumArgs {
    SpectrumArgs() { eigenBandBudget(flags); }
    std::string input, output;
    BandFlags flags;
    EigenOptions eigen;
};
/// INPUT, -o (described by `outputHelp`), the eigen solver's flags and the band's.
void addSpectrumFlags(CLI::App& cmd, SpectrumArgs& a, const std::string& outputHelp);

/// "eigen_000", "eigen_001", … (more digits past 999): the grid of eigenvector i.
std::string eigenGridName(int i);

/// The k lowest eigenpairs of the job's band. Refused beyond --max-memory before L is assembled when L in double,
/// M and the assembly's peak would not fit beside what the process holds (naming the voxel size that fits), and
/// by the eigen solver before its numeric factorisation when the factor, the Lanczos basis and the vectors would
/// not fit beside L and M. With `memory`: the stage's estimate (the settled resident set at its start; the larger
/// of the assembly's peak and L, M and the solver's factor, basis and vectors as estimated before the
/// factorisation) and the peak measured over it, as memoryStageReport writes them.
EigenResult runSpectrum(const BandJob& job, const EigenOptions& options, const Progress& progress, nlohmann::json* memory = nullptr);

/// The report's "spectrum" section: method, eigenvalues, residuals, orthonormality, solver counts and memory.
nlohmann::json spectrumReport(const EigenResult& eigen);

}  // namespace gpisvdb::cli
