#pragma once
// The Green's function of the GPIS Laplacian (paper Alg. 1, Fig. 5): L f = M δ_y, y the band voxel nearest the
// source point, δ_y the Dirac of the measure μ at y (∫ δ_y u dμ = u(y), i.e. M δ_y = e_y). With this δ the
// result f(x) = G(x, y) = (L⁻¹)_xy is symmetric in x and y. (The Lebesgue Dirac e_y/h³ would give
// μ(y) G(x, y): not symmetric wherever μ(x) ≠ μ(y); multiply by μ(y) to get that scaling. docs/math.md#green.)
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/solve/pcg.h"

namespace gpisvdb {

struct GreenResult {
    std::vector<float> values;    ///< G(·, y) by linear index (rounded to float when the solve refined in double)
    std::size_t sourceIndex = 0;  ///< y's linear index
    /// The solve. Below float's reach the PCG refines in double (solve/pcg.h): solver.relativeResidual is then that
    /// of the double solution, solver.floatResidual that of `values`.
    PcgResult solver;
};

/// Band voxel nearest to a world-space point (ties: lowest linear index). Throws on an empty band.
std::size_t nearestBandVoxel(const Band& band, const Vec3d& point);

/// The Green's function G(·, y): solves L f = e_y with the PCG (solve/pcg.h).
/// \param band      the band (its μ and Selling stencils), N voxels
/// \param L         the band's Laplacian: LaplacianOperator, or AssembledOperator over assembleLaplacian for the
///                  incomplete Cholesky preconditioner
/// \param source    the source point, world units; y is the band voxel nearest it (nearestBandVoxel)
/// \param options   tolerance, iteration cap, preconditioner (Automatic: the measured choice by N)
/// \param progress  reports the PCG's iterations; its interrupt stops the solve (Cancelled)
/// \return G(·, y) by linear index, y's index and the solve; the caller checks solver.converged
/// \throws ParameterError for bad options (checkPcgOptions) or a non-finite source, InputError on an empty band,
///         Cancelled when interrupted
/// \par Complexity
///   O(nnz(L)) per PCG iteration, nnz(L) ≤ 13 N; the iterations grow as N^(1/3) with Jacobi and stay nearly flat with
///   the multigrids (docs/operators.md#multigrid). Memory beside the band: pcgWorkBytes plus the preconditioner's
///   (docs/memory.md).
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel inside (TBB); the result is the same for any thread
///   count.
GreenResult greensFunction(const Band& band, const SymmetricOperator& L, const Vec3d& source, const PcgOptions& options = {},
                           const Progress& progress = {});

}  // namespace gpisvdb
