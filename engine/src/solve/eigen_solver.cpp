#include "gpisvdb/solve/eigen_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <Eigen/CholmodSupport>
#include <Spectra/SymGEigsShiftSolver.h>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// y = L⁻¹ x through the Cholesky factor (Spectra's shift-invert operator with the shift fixed at 0: L is
/// positive definite, and the lowest λ are the largest 1/λ, the ones Lanczos finds first).
class InverseOperator {
public:
    using Scalar = double;
    using Factor = Eigen::CholmodSupernodalLLT<SparseMatrixD, Eigen::Lower>;

    InverseOperator(const Factor& factor, const Progress& progress, long expectedSolves, long& solves)
        : factor_(factor), progress_(progress), expected_(expectedSolves), solves_(solves) {}
    Eigen::Index rows() const { return factor_.rows(); }
    Eigen::Index cols() const { return factor_.cols(); }
    void set_shift(double sigma) {
        if (sigma != 0) throw Error("eigen solver: only the shift 0 is factored");
    }
    void perform_op(const double* x, double* y) const {
        progress_.checkInterrupt();
        const Eigen::Index n = rows();
        Eigen::Map<Eigen::VectorXd>(y, n) = factor_.solve(Eigen::Map<const Eigen::VectorXd>(x, n));
        ++solves_;
        progress_.update("eigenpairs", std::min(0.95, double(solves_) / double(expected_)));
    }

private:
    const Factor& factor_;
    const Progress& progress_;
    long expected_;
    long& solves_;
};

/// y = M x for the diagonal mass.
class MassOperator {
public:
    using Scalar = double;
    explicit MassOperator(const Eigen::VectorXd& mass) : mass_(mass) {}
    Eigen::Index rows() const { return mass_.size(); }
    Eigen::Index cols() const { return mass_.size(); }
    void perform_op(const double* x, double* y) const {
        Eigen::Map<Eigen::VectorXd>(y, mass_.size()) = mass_.cwiseProduct(Eigen::Map<const Eigen::VectorXd>(x, mass_.size()));
    }

private:
    const Eigen::VectorXd& mass_;
};

constexpr Eigen::Index kCheckBlock = 16;  // columns per block of the residual and Gram checks (bounds their memory)

/// Signs fixed (the largest |entry| of each vector, lowest index on ties, positive), then the residuals and the
/// M-orthonormality measured, in blocks of columns: the same checks whichever solver ran.
void checkPairs(const SparseMatrixD& L, const Eigen::VectorXd& mass, EigenResult& result, const Progress& progress) {
    const Eigen::Index k = result.values.size();
    for (Eigen::Index i = 0; i < k; ++i) {
        Eigen::Index at = 0;
        result.vectors.col(i).cwiseAbs().maxCoeff(&at);
        if (result.vectors(at, i) < 0) result.vectors.col(i) *= -1;
    }

    // === Check: residuals and M-orthonormality, in blocks of columns
    result.residuals.resize(k);
    Eigen::MatrixXd gram(k, k);
    for (Eigen::Index c = 0; c < k; c += kCheckBlock) {
        progress.checkInterrupt();
        const Eigen::Index w = std::min(kCheckBlock, k - c);
        const auto U = result.vectors.middleCols(c, w);
        const Eigen::MatrixXd MU = mass.asDiagonal() * U;
        const Eigen::MatrixXd LU = L * U;
        for (Eigen::Index j = 0; j < w; ++j) {
            const double lambda = result.values(c + j);
            result.residuals(c + j) = (LU.col(j) - lambda * MU.col(j)).norm() / (std::abs(lambda) * MU.col(j).norm());
        }
        gram.middleCols(c, w) = result.vectors.transpose() * MU;
    }
    result.orthonormalityError = (gram - Eigen::MatrixXd::Identity(k, k)).cwiseAbs().maxCoeff();
}

}  // namespace

double eigenBytes(double factorNonzeros, double n, double subspace, double count) {
    return 12.0 * factorNonzeros + 8.0 * n * (2.0 * subspace + count);
}

EigenResult lowestEigenpairs(const SparseMatrixD& L, const Eigen::VectorXd& mass, const EigenOptions& options, const Progress& progress) {
    const Eigen::Index n = L.rows();
    // === Parameters
    if (L.cols() != n || mass.size() != n) throw ParameterError("eigen solver: L and M must be N × N and N");
    if (options.count < 1 || options.count >= n)
        throw ParameterError("the number of eigenpairs k (EigenOptions::count) = " + std::to_string(options.count) +
                                 " must be between 1 and " + std::to_string(n - 1) + " (one less than the band's " + std::to_string(n) +
                                 " voxels)",
                             {"EigenOptions::count"});
    if (!(mass.array() > 0).all() || !mass.allFinite()) throw ParameterError("eigen solver: the mass M must be positive");
    if (!(options.tolerance > 0) || options.maxRestarts < 1)
        throw ParameterError(
            "eigen solver: the tolerance (EigenOptions::tolerance) must be > 0 and the restart cap "
            "(EigenOptions::maxRestarts) ≥ 1",
            {"EigenOptions::tolerance", "EigenOptions::maxRestarts"});
    const Eigen::Index k = options.count;
    Eigen::Index ncv = options.subspace > 0 ? options.subspace : std::max<Eigen::Index>(2 * k, k + 20);
    ncv = std::min(ncv, n);
    if (ncv <= k)
        throw ParameterError("the Lanczos basis size (EigenOptions::subspace) must exceed k = " + std::to_string(k),
                             {"EigenOptions::subspace"});

    EigenResult result;
    result.subspace = int(ncv);
    result.matrixNonzeros = double(L.nonZeros());
    const double lobpcgNeeds = lobpcgBytes(double(n), int(k), options.lobpcg);
    auto runLobpcg = [&] {
        result.method = EigenMethod::Lobpcg;
        result.subspace = lobpcgBlockSize(int(k), options.lobpcg, double(n));
        result.estimatedBytes = lobpcgNeeds;
        const auto start = Clock::now();
        lobpcg(L, mass, int(k), options.lobpcg, result, progress);
        result.lobpcgSeconds = since(start);
        progress.update("eigenpairs", 1);
        checkPairs(L, mass, result, progress);
        return result;
    };
    if (options.method == EigenMethod::Lobpcg) {
        if (options.maxBytes > 0 && lobpcgNeeds > options.maxBytes)
            throw MemoryLimitError(std::to_string(k) + " eigenpairs by LOBPCG on a band of " + std::to_string(n) + " voxels need about " +
                                       numberText(lobpcgNeeds / 1e9) +
                                       " GB (its blocks and the "
                                       "multigrid), more than the " +
                                       numberText(options.maxBytes / 1e9) +
                                       " GB allowed (EigenOptions::maxBytes): lower the eigenpair count "
                                       "(EigenOptions::count), use a coarser voxel size (BandOptions::voxelSize), or "
                                       "raise the memory limit",
                                   {"EigenOptions::maxBytes", "EigenOptions::count", "BandOptions::voxelSize"});
        return runLobpcg();
    }

    // === Factor L = R Rᵀ (CHOLMOD, supernodal, fill-reducing ordering of its choice), after checking its size
    auto t = Clock::now();
    progress.update("factorize", 0);
    InverseOperator::Factor factor;
    factor.cholmod().print = 0;  // failures are reported by the exceptions below, not on stderr
    progress.checkInterrupt();
    factor.analyzePattern(L);
    const double needed = eigenBytes(factor.cholmod().lnz, double(n), double(ncv), double(k));
    result.estimatedBytes = needed;
    if (options.maxBytes > 0 && needed > options.maxBytes && options.method == EigenMethod::Automatic && lobpcgNeeds <= options.maxBytes)
        return runLobpcg();  // the factor would not fit: no factor at all
    if (options.maxBytes > 0 && needed > options.maxBytes)
        throw MemoryLimitError(std::to_string(k) + " eigenpairs of a band of " + std::to_string(n) + " voxels need about " +
                                   numberText(needed / 1e9) + " GB (Cholesky factor of " + numberText(factor.cholmod().lnz) +
                                   " entries, Lanczos basis and vectors), more than the " + numberText(options.maxBytes / 1e9) +
                                   " GB allowed (EigenOptions::maxBytes)" +
                                   (options.method == EigenMethod::Automatic
                                        ? std::string(", and LOBPCG without a factor about ") + numberText(lobpcgNeeds / 1e9) + " GB"
                                        : std::string()) +
                                   ": lower the eigenpair count (EigenOptions::count), use a coarser "
                                   "voxel size (BandOptions::voxelSize), or raise the memory limit",
                               {"EigenOptions::maxBytes", "EigenOptions::count", "BandOptions::voxelSize"});
    progress.checkInterrupt();
    factor.factorize(L);  // CHOLMOD does not poll: the CLI's watchdog ends the process if a signal comes now
    progress.checkInterrupt();
    if (factor.info() != Eigen::Success)
        throw Error("the Laplacian is not positive definite (CHOLMOD failed to factor it): is the band empty or broken?");
    const cholmod_common& c = factor.cholmod();
    result.factorBytes = std::size_t(c.memory_usage);
    result.factorNonzeros = c.lnz;
    switch (c.method[c.selected].ordering) {
        case CHOLMOD_NATURAL: result.ordering = "natural"; break;
        case CHOLMOD_AMD: result.ordering = "AMD"; break;
        case CHOLMOD_METIS: result.ordering = "METIS"; break;
        case CHOLMOD_NESDIS: result.ordering = "NESDIS"; break;
        default: result.ordering = "other"; break;
    }
    result.factorSeconds = since(t);
    progress.update("factorize", 1);

    // === Lanczos on L⁻¹M in the M inner product
    t = Clock::now();
    InverseOperator op(factor, progress, 4 * long(ncv), result.solves);
    MassOperator bop(mass);
    Spectra::SymGEigsShiftSolver<InverseOperator, MassOperator, Spectra::GEigsMode::ShiftInvert> lanczos(op, bop, k, ncv, 0.0);
    lanczos.init();
    lanczos.compute(Spectra::SortRule::LargestMagn, options.maxRestarts, options.tolerance, Spectra::SortRule::SmallestAlge);
    result.restarts = long(lanczos.num_iterations());
    if (lanczos.info() != Spectra::CompInfo::Successful)
        throw Error("the eigen solver did not converge on the " + std::to_string(k) + " lowest pairs within " +
                    std::to_string(options.maxRestarts) + " restarts: ask for fewer pairs or a larger basis");
    result.values = lanczos.eigenvalues();
    result.vectors = lanczos.eigenvectors();
    result.lanczosSeconds = since(t);
    progress.update("eigenpairs", 1);

    checkPairs(L, mass, result, progress);
    return result;
}

}  // namespace gpisvdb
