#include "gpisvdb/tasks/matern.h"

#include <algorithm>
#include <cmath>
#include <Eigen/Cholesky>
#include <limits>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr std::size_t kMaxExactPoints = 20000;  // an m × m Cholesky of doubles: 3.2 GB
constexpr double kNugget = 1e-10;               // relative diagonal added to K: keeps exact, redundant data solvable
constexpr Eigen::Index kRowBlock = 4096;        // band rows per task when evaluating the posterior

/// The posterior of the coefficients w of f = ȳ + Σ w_i u_i: mean c and covariance P (prior N(0, diag W)).
struct Posterior {
    Eigen::VectorXd c;
    Eigen::MatrixXd P;
};

/// m × m: K = Φ W Φᵀ + S², α = K⁻¹ r, c = W Φᵀ α, P = W − (ΦW)ᵀ K⁻¹ (ΦW).
Posterior functionSpace(const Eigen::MatrixXd& Phi, const Eigen::VectorXd& W, const Eigen::VectorXd& noise, const Eigen::VectorXd& r) {
    const Eigen::MatrixXd PhiW = Phi * W.asDiagonal();
    Eigen::MatrixXd K = PhiW * Phi.transpose();
    K.diagonal() += noise.cwiseAbs2();
    K.diagonal().array() += kNugget * std::max(K.diagonal().mean(), std::numeric_limits<double>::min());
    const Eigen::LLT<Eigen::MatrixXd> llt(K);
    if (llt.info() != Eigen::Success) throw Error("the regression's kernel matrix could not be factored");
    Posterior post;
    post.c = PhiW.transpose() * llt.solve(r);
    const Eigen::MatrixXd V = llt.matrixL().solve(PhiW);
    post.P = Eigen::MatrixXd(W.asDiagonal()) - V.transpose() * V;
    return post;
}

/// k × k (every noise > 0): B = W^½ Φᵀ S⁻¹, A = I + B Bᵀ, P = W^½ A⁻¹ W^½, c = W^½ A⁻¹ B S⁻¹ r.
Posterior weightSpace(const Eigen::MatrixXd& Phi, const Eigen::VectorXd& W, const Eigen::VectorXd& noise, const Eigen::VectorXd& r) {
    const Eigen::VectorXd sqrtW = W.cwiseSqrt();
    const Eigen::VectorXd invS = noise.cwiseInverse();
    const Eigen::MatrixXd B = sqrtW.asDiagonal() * Phi.transpose() * invS.asDiagonal();
    Eigen::MatrixXd A = B * B.transpose();
    A.diagonal().array() += 1.0;
    const Eigen::LLT<Eigen::MatrixXd> llt(A);
    if (llt.info() != Eigen::Success) throw Error("the regression's weight-space system could not be factored");
    Posterior post;
    post.c = sqrtW.asDiagonal() * llt.solve(B * invS.cwiseProduct(r));
    post.P = sqrtW.asDiagonal() * llt.solve(Eigen::MatrixXd(sqrtW.asDiagonal()));
    post.P = 0.5 * (post.P + post.P.transpose()).eval();
    return post;
}

/// Mean ȳ + U c and variance diag(U P Uᵀ) (clamped at 0) for rows of U, in fixed blocks (thread-count independent).
void evaluate(const Eigen::MatrixXd& U, const Posterior& post, double priorMean, double* mean, double* variance, const Progress& progress) {
    const Eigen::Index n = U.rows();
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, (n + kRowBlock - 1) / kRowBlock),
                      [&](const tbb::blocked_range<Eigen::Index>& blocks) {
                          for (Eigen::Index b = blocks.begin(); b != blocks.end(); ++b) {
                              progress.checkInterrupt();
                              const Eigen::Index r0 = b * kRowBlock, rows = std::min(kRowBlock, n - r0);
                              const auto Ub = U.middleRows(r0, rows);
                              const Eigen::VectorXd m = Ub * post.c;
                              const Eigen::VectorXd v = (Ub * post.P).cwiseProduct(Ub).rowwise().sum();
                              for (Eigen::Index i = 0; i < rows; ++i) {
                                  mean[r0 + i] = priorMean + m(i);
                                  variance[r0 + i] = std::max(0.0, v(i));
                              }
                          }
                      });
}

/// The k × k weight-space solve: forced, or every noise > 0 and more points than eigenpairs.
bool usesWeightSpace(const PointData& data, Eigen::Index k, const RegressionOptions& options) {
    bool allNoisy = true;
    for (double s : data.noise) allNoisy = allNoisy && s > 0;
    return options.weightSpace || (allNoisy && Eigen::Index(data.value.size()) > k);
}

}  // namespace

std::vector<std::pair<std::string, double>> regressionBytes(std::size_t voxels, const PointData& data, int k,
                                                            const RegressionOptions& options) {
    const double n = double(voxels), m = double(data.value.size()), K = double(k), d = sizeof(double);
    const double features = d * m * K;
    const double solve = usesWeightSpace(data, k, options) ? d * (m * K + 5 * K * K) : d * (2 * m * K + 2 * m * m + 3 * K * K);
    const double threads = double(tbb::this_task_arena::max_concurrency());
    // Per thread: a block of U P (rows × k) and Eigen's packed copy of those rows of U for the product
    const double block = d * double(std::min<Eigen::Index>(kRowBlock, Eigen::Index(voxels))) * K;
    const double evaluation = d * K * K + 24.0 * n + threads * 2 * block;
    if (solve > evaluation) return {{"features", features}, {"posterior_solve", solve}};
    return {{"features", features}, {"posterior_on_band", evaluation}};
}

double defaultKappa(double area) { return 0.1 * std::sqrt(area); }

Eigen::VectorXd maternWeights(const Eigen::VectorXd& eigenvalues, double area, const MaternOptions& o) {
    if (!(o.nu > 0))
        throw ParameterError("the Matérn smoothness ν (MaternOptions::nu) must be > 0 (1/2, 3/2, 5/2 or infinity), got " + numberText(o.nu),
                             {"MaternOptions::nu"});
    if (!(o.kappa > 0) || !std::isfinite(o.kappa))
        throw ParameterError("the Matérn length scale κ (MaternOptions::kappa) must be finite and > 0, got " + numberText(o.kappa),
                             {"MaternOptions::kappa"});
    if (!(o.amplitude > 0) || !std::isfinite(o.amplitude))
        throw ParameterError("the prior variance (MaternOptions::amplitude) must be finite and > 0, got " + numberText(o.amplitude),
                             {"MaternOptions::amplitude"});
    if (!(o.dimension > 0)) throw ParameterError("the kernel dimension d must be > 0");
    if (!(area > 0) || !std::isfinite(area)) throw ParameterError("the band's area Σ M must be > 0");
    // === log ρ(λ_i) (Eq. 26), then normalise in log space
    Eigen::VectorXd logRho(eigenvalues.size());
    for (Eigen::Index i = 0; i < eigenvalues.size(); ++i) {
        const double l = eigenvalues(i);
        logRho(i) =
            std::isinf(o.nu) ? -0.5 * o.kappa * o.kappa * l : -(o.nu + 0.5 * o.dimension) * std::log(2 * o.nu / (o.kappa * o.kappa) + l);
    }
    const Eigen::VectorXd rho = (logRho.array() - logRho.maxCoeff()).exp().matrix();
    return (o.amplitude * area / rho.sum()) * rho;
}

Eigen::MatrixXd eigenFeatures(const Band& band, const Eigen::MatrixXd& vectors, const std::vector<Vec3d>& points) {
    const Eigen::Index k = vectors.cols();
    Eigen::MatrixXd F = Eigen::MatrixXd::Zero(Eigen::Index(points.size()), k);
    auto acc = band.index->getConstAccessor();
    for (std::size_t p = 0; p < points.size(); ++p) {
        const Vec3d& x = points[p];
        if (!x.allFinite()) throw ParameterError("data point " + std::to_string(p + 1) + " is not three finite numbers");
        // === Trilinear weights about the voxel centres h·k (index space x / h)
        const Vec3d q = x / band.voxelSize;
        const Vec3d base = q.array().floor();
        const Vec3d t = q - base;
        bool inside = false;
        for (int c = 0; c < 8; ++c) {
            const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
            const openvdb::Coord ijk(int(base.x()) + dx, int(base.y()) + dy, int(base.z()) + dz);
            const int j = acc.getValue(ijk);
            if (j < 0) continue;
            inside = true;
            const double w = (dx ? t.x() : 1 - t.x()) * (dy ? t.y() : 1 - t.y()) * (dz ? t.z() : 1 - t.z());
            F.row(Eigen::Index(p)) += w * vectors.row(j);
        }
        if (!inside)
            throw ParameterError("data point " + std::to_string(p + 1) + " (" + numberText(x.x()) + ", " + numberText(x.y()) + ", " +
                                 numberText(x.z()) + ") lies outside the band: give points on the shape");
    }
    return F;
}

Eigen::MatrixXd maternKernel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const Eigen::VectorXd& weights) {
    return a * weights.asDiagonal() * b.transpose();
}

RegressionResult gpRegression(const Band& band, const EigenResult& eigen, const PointData& data, const RegressionOptions& options,
                              const Progress& progress) {
    const std::size_t m = data.value.size();
    if (m == 0) throw ParameterError("regression needs at least one data point");
    if (data.position.size() != m || data.noise.size() != m) throw ParameterError("data positions, values and noise differ in length");
    if (eigen.vectors.rows() != Eigen::Index(band.size())) throw ParameterError("the eigenvectors do not belong to this band");
    RegressionResult result;

    // === Prior: constant mean ȳ, amplitude a, Matérn weights (Eq. 26)
    const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(data.value.data(), Eigen::Index(m));
    const Eigen::VectorXd noise = Eigen::Map<const Eigen::VectorXd>(data.noise.data(), Eigen::Index(m));
    result.priorMean = y.mean();
    MaternOptions kernel = options.kernel;
    if (options.amplitudeFromData) {
        const double var = (y.array() - result.priorMean).square().mean();
        kernel.amplitude = var > 0 ? var : 1.0;
    }
    double area = 0;
    for (float mu : band.mu) area += double(mu);
    area *= band.voxelSize * band.voxelSize * band.voxelSize;
    if (kernel.kappa == 0) kernel.kappa = defaultKappa(area);
    result.amplitude = kernel.amplitude;
    result.kappa = kernel.kappa;
    const Eigen::VectorXd W = maternWeights(eigen.values, area, kernel);

    // === Condition on the data
    const Eigen::MatrixXd Phi = eigenFeatures(band, eigen.vectors, data.position);
    const Eigen::VectorXd r = y.array() - result.priorMean;
    const bool allNoisy = (noise.array() > 0).all();
    if (options.weightSpace && !allNoisy) throw ParameterError("the weight-space solve needs a noise > 0 at every data point");
    result.weightSpace = usesWeightSpace(data, eigen.values.size(), options);
    if (!result.weightSpace && m > kMaxExactPoints)
        throw ParameterError(std::to_string(m) + " data points without noise are too many for the exact m × m solve (at most " +
                             std::to_string(kMaxExactPoints) + "): give every point a noise > 0");
    const Posterior post = result.weightSpace ? weightSpace(Phi, W, noise, r) : functionSpace(Phi, W, noise, r);

    // === Posterior on the band and at the data
    const std::size_t n = band.size();
    std::vector<double> mean(n), variance(n);
    evaluate(eigen.vectors, post, result.priorMean, mean.data(), variance.data(), progress);
    result.mean.assign(mean.begin(), mean.end());
    result.variance.assign(variance.begin(), variance.end());
    result.meanAtData.resize(Eigen::Index(m));
    result.varianceAtData.resize(Eigen::Index(m));
    evaluate(Phi, post, result.priorMean, result.meanAtData.data(), result.varianceAtData.data(), progress);
    return result;
}

}  // namespace gpisvdb
