#pragma once
// Matérn kernels on the GPIS from its Laplacian eigenpairs (paper Eq. 26, Borovitskiy et al. 2020) and
// Gaussian-process regression of scalar data with them (paper Fig. 9):
//   k(x, x') = Σ_i w_i u_i(x) u_i(x'),   w_i = a · A · ρ(λ_i) / Σ_j ρ(λ_j),
//   ρ_ν(λ) = (2ν/κ² + λ)^(−ν−d/2),  ρ_∞(λ) = exp(−κ²λ/2),
// u_i the M-orthonormal eigenvectors, A = ∫ dμ = Σ M (the expected area) and a the prior variance. Eq. 26's
// C = Σ ρ(λ_i) makes the mean prior variance 1/A (it depends on the size of the shape); the factor a·A makes it a:
// ∫ k(x, x) dμ / A = a. d is the dimension of the surface the kernel lives on (2), as in Borovitskiy et al.
// Because T vanishes across the surface and μ weighs L², the u_i — and so the prior variance k(x, x) — are
// larger where μ is small: where the shape itself is uncertain.
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/point_data.h"
#include "gpisvdb/solve/eigen_solver.h"

namespace gpisvdb {

struct MaternOptions {
    double nu = 1.5;       ///< smoothness ν > 0 (1/2, 3/2, 5/2 usual); +infinity gives the squared-exponential ρ_∞
    double kappa = 0;      ///< κ, length scale in world units (> 0); 0: 0.1 √A (a tenth of the shape's size)
    double dimension = 2;  ///< d in ρ_ν: the dimension of the surface
    double amplitude = 1;  ///< a, the mean prior variance (data units²)
};

/// κ's default for a band of expected area A = Σ M: 0.1 √A.
double defaultKappa(double area);

/// The weights w_i of Eq. 26 for eigenvalues λ (ascending) and area A = Σ M; ρ is evaluated in log space so
/// that no weight overflows or underflows to NaN. Throws ParameterError for ν ≤ 0, κ ≤ 0, a ≤ 0, d ≤ 0, A ≤ 0.
Eigen::VectorXd maternWeights(const Eigen::VectorXd& eigenvalues, double area, const MaternOptions& options);

/// The eigenvectors (N × k, band order) at world points, trilinearly interpolated from the voxel centres
/// (0 outside the band, like the Dirichlet condition): m × k. Throws ParameterError for a point whose eight
/// surrounding voxels all lie outside the band, or one that is not finite.
Eigen::MatrixXd eigenFeatures(const Band& band, const Eigen::MatrixXd& vectors, const std::vector<Vec3d>& points);

/// k(a_r, b_c) for feature rows a (m × k) and b (n × k): a W bᵀ.
Eigen::MatrixXd maternKernel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const Eigen::VectorXd& weights);

struct RegressionOptions {
    MaternOptions kernel;
    bool amplitudeFromData = true;  ///< a = the variance of the data values (1 when all equal), not kernel.amplitude
    bool weightSpace = false;       ///< force the k × k weight-space solve (needs every noise > 0); else chosen by size
};

struct RegressionResult {
    std::vector<float> mean;      ///< posterior mean per band voxel
    std::vector<float> variance;  ///< posterior variance per band voxel (≥ 0)
    Eigen::VectorXd meanAtData;   ///< posterior mean and variance at the data points (interpolated like the data)
    Eigen::VectorXd varianceAtData;
    double priorMean = 0;             ///< the constant prior mean: the mean of the data values
    double amplitude = 0, kappa = 0;  ///< the a and κ used
    bool weightSpace = false;         ///< which exact solve ran: k × k weight space, or m × m function space
};

/// What gpRegression allocates at its peak beside the eigenpairs, for a band of `voxels`, `data` and `k` eigenpairs,
/// bytes by part (docs/memory.md#regression): the features Φ (m × k double), then the larger of the posterior's
/// solve (function space: ΦW and V, m × k, K and its Cholesky factor, m × m, and P with two k × k temporaries;
/// weight space: B, k × m, A and its factor and P with three k × k temporaries) and its evaluation over the band
/// (mean and variance in double while computed and in float as returned, 24 B per voxel; P; in each thread a block
/// of U P, kRowBlock × k, and Eigen's packed copy of those rows of U).
std::vector<std::pair<std::string, double>> regressionBytes(std::size_t voxels, const PointData& data, int k,
                                                            const RegressionOptions& options = {});

/// The GP posterior with the Matérn kernel of `eigen` given `data`: constant prior mean (the data mean), noise
/// variances from data.noise (0: exact data, interpolated). Function space (m × m Cholesky) when some noise is
/// 0 or m ≤ k, weight space (k × k) otherwise; both exact.
/// \param band      the band the eigenpairs were computed on, N voxels
/// \param eigen     its k lowest eigenpairs (spectrum)
/// \param data      m points (world units) with values and noise standard deviations
/// \param options   the Matérn kernel's ν, κ and amplitude, and the solve's space
/// \param progress  reports the posterior's evaluation over the band; its interrupt stops it (Cancelled)
/// \return the posterior mean and variance by linear index, and the solve's figures
/// \throws ParameterError for empty data, a point that is not finite or off the band, eigenpairs of another band, a
///         bad kernel, or more than 20 000 exact (noise-free) points; Error when the kernel matrix cannot be factored;
///         Cancelled when interrupted
/// \par Complexity
///   Features O(m k); the solve O(m³ + m² k) in function space, O(m k² + k³) in weight space; the evaluation over
///   the band O(N k²). Memory regressionBytes(N, data, k, options) beside the eigenpairs.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel inside (TBB); the result is the same for any thread
///   count.
RegressionResult gpRegression(const Band& band, const EigenResult& eigen, const PointData& data, const RegressionOptions& options = {},
                              const Progress& progress = {});

}  // namespace gpisvdb
