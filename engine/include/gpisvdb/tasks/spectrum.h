#pragma once
// The spectrum of the GPIS Laplacian (paper Sec. 10.1): the k lowest pairs of L u = λ M u on the band, u = 0
// outside it (homogeneous Dirichlet), u M-orthonormal: Σ_x u_i(x) u_j(x) μ(x) h³ = δ_ij, i.e. orthonormal in
// L²(μ). The λ are those of −Δ_φ (world units⁻²); on a thin band about the unit sphere the differences λ − λ₀
// approach l(l+1) (docs/spectrum.md).
#include "gpisvdb/band/band.h"
#include "gpisvdb/solve/eigen_solver.h"

namespace gpisvdb {

/// The default band-voxel budget of the commands that solve for eigenpairs (`spectrum`, `regress`), in place of
/// kDefaultMaxBandVoxels: the eigen solver's time grows like N^1.3 (the factor's fill), so a band the other
/// commands solve in seconds takes it minutes; a few hundred thousand voxels resolve the lowest modes along the
/// surface (docs/spectrum.md#budget).
constexpr double kEigenMaxBandVoxels = 3e5;

/// M's diagonal in double, h³ μ.
Eigen::VectorXd massVector(const Band& band);

/// The k = options.count lowest eigenpairs of L u = λ M u on the band (solve/eigen_solver.h).
/// \param band      the band (its μ and Selling stencils), N voxels
/// \param options   k, the subspace, tolerance, restarts, method (Automatic: shift-invert Lanczos where its factor
///                  fits maxBytes, else LOBPCG) and the memory limit maxBytes
/// \param progress  reports the solver's progress; its interrupt stops it (Cancelled)
/// \return λ ascending (world units⁻²), the M-orthonormal vectors by linear index, residuals and the solve's figures
/// \throws InputError on an empty band; ParameterError for k out of range or a solve that would exceed
///         options.maxBytes (after CHOLMOD's symbolic analysis, before any large allocation); Error when L is not
///         positive definite or the solver does not converge; Cancelled when interrupted
/// \par Complexity
///   Shift-invert Lanczos: one sparse Cholesky factorisation of L (fill and time grow as about N^1.3 on bands,
///   docs/spectrum.md#budget), then O(fill) per solve over (restarts + 1)·subspace solves; memory eigenBytes. LOBPCG:
///   O(k² N + k nnz(L)) per iteration and one multigrid cycle per vector; memory O(k N) and the hierarchy's.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Deterministic (sequential CHOLMOD, a fixed start vector): the
///   result is the same for any thread count.
EigenResult spectrum(const Band& band, const EigenOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
