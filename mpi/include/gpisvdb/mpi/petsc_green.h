#pragma once
// The Green's function of the GPIS Laplacian on a distributed band (docs/mpi.md#solvers): L f = e_y (tasks/green.h)
// solved by PETSc's conjugate gradients, preconditioned by hypre's BoomerAMG (set as the one-process multigrid is,
// solve/boomer_amg.h) or by Jacobi, in double throughout.
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/mpi/distributed_band.h"
#include "gpisvdb/solve/pcg.h"

namespace gpisvdb::mpi {

/// The band voxel nearest a world-space point over all ranks (ties: the lowest linear index), as a linear index of
/// the whole band: tasks/green.h's nearestBandVoxel of the one-process band. Collective.
std::size_t nearestBandVoxel(const Ranks& ranks, const DistributedBand& band, const Vec3d& point);

struct DistributedGreen {
    std::vector<float> local;                                ///< G(·, y) on this rank's voxels (local index)
    std::size_t sourceIndex = 0;                             ///< y's linear index in the whole band
    Preconditioner preconditioner = Preconditioner::Jacobi;  ///< as used (Multigrid or Jacobi)
    int iterations = 0;
    double relativeResidual = 0;  ///< ‖e_y − L f‖ / ‖e_y‖, recomputed from f in double
    bool converged = false;
    std::size_t ghosts = 0;  ///< this rank's halo: other ranks' unknowns each product reads
    double assembleSeconds = 0, setupSeconds = 0, solveSeconds = 0;
};

/// Solves L f = e_y to options.tolerance (‖r‖ ≤ tolerance ‖b‖, unpreconditioned) within options.maxIterations.
/// Automatic picks the multigrid from kMultigridMinUnknowns voxels of the whole band, Jacobi below; the incomplete
/// Cholesky has no distributed form and is refused (ParameterError). PETSc's options database (PETSC_OPTIONS) can
/// override the solver's settings (prefix green_). Collective.
DistributedGreen greensFunctionPetsc(const Ranks& ranks, const DistributedBand& band, const Vec3d& source, const PcgOptions& options = {},
                                     const Progress& progress = {});

}  // namespace gpisvdb::mpi
