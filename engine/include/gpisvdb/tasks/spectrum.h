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

/// The k = options.count lowest eigenpairs of the band's L and M (see lowestEigenpairs for the errors).
EigenResult spectrum(const Band& band, const EigenOptions& options = {}, const Progress& progress = {});

}  // namespace gpisvdb
