#pragma once
// The k lowest eigenpairs of L u = λ M u on a distributed band (docs/mpi.md#solvers), by SLEPc: Krylov–Schur on the
// shift-invert operator (L − 0·M)⁻¹ M with L factored by MUMPS's distributed Cholesky (the one-process Lanczos on
// CHOLMOD's factor, across ranks), or LOBPCG preconditioned by hypre's BoomerAMG (no factor: the memory-light path).
// The vectors are M-orthonormal with the one-process signs (the largest |entry| of each positive, lowest index on
// ties), so the grids match gpisvdb spectrum's.
#include <Eigen/Core>
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/mpi/distributed_band.h"
#include "gpisvdb/solve/eigen_solver.h"

namespace gpisvdb::mpi {

/// Above this many voxels of the whole band Automatic takes LOBPCG: a Cholesky factor's fill grows like N^1.4 on a
/// band (CHOLMOD's, measured: docs/spectrum.md#lobpcg) and stopped fitting near 1e6 voxels per 8 GB. MUMPS's is
/// assumed alike; it is not estimated before the factorisation.
constexpr std::size_t kFactorMaxVoxels = 1000000;

struct DistributedSpectrum {
    Eigen::VectorXd values;                         ///< λ_0 ≤ λ_1 ≤ … (k of them), world units⁻²
    std::vector<std::vector<double>> local;         ///< eigenvector i on this rank's voxels (local index)
    Eigen::VectorXd residuals;                      ///< ‖L u_i − λ_i M u_i‖ / (|λ_i| ‖M u_i‖), in double
    double orthonormalityError = 0;                 ///< max |UᵀMU − I|, in double
    EigenMethod method = EigenMethod::ShiftInvert;  ///< ShiftInvert (Krylov–Schur on MUMPS) or Lobpcg
    int iterations = 0;                             ///< SLEPc's outer iterations (restarts for Krylov–Schur)
    std::size_t ghosts = 0;                         ///< this rank's halo of L
    double assembleSeconds = 0, solveSeconds = 0;
};

/// The options.count lowest pairs to options.tolerance (SLEPc's relative residual). ParameterError for k out of
/// [1, N); Error when SLEPc does not converge within options.maxRestarts iterations. Collective.
DistributedSpectrum spectrumSlepc(const Ranks& ranks, const DistributedBand& band, const EigenOptions& options = {},
                                  const Progress& progress = {});

}  // namespace gpisvdb::mpi
