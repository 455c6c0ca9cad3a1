#include "gpisvdb/solve/lobpcg.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <vector>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/memory_estimate.h"
#include "gpisvdb/solve/eigen_solver.h"

namespace gpisvdb {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

/// Below this share of the largest M-Gram eigenvalue a direction of [X, W, P] is dependent on the others: dropped.
constexpr double kRankTolerance = 1e-13;

/// Y = L X for the first `cols` columns (L symmetric: row j of L is its column j), rows in parallel, each row's sum
/// in the order of its entries.
void applyL(const SparseMatrixD& L, const MatrixXd& X, Index cols, MatrixXd& Y) {
    const Index n = L.cols();
    tbb::parallel_for(tbb::blocked_range<Index>(0, n, 2048), [&](const tbb::blocked_range<Index>& r) {
        std::vector<double> row(std::size_t(cols), 0.0);
        for (Index j = r.begin(); j != r.end(); ++j) {
            std::fill(row.begin(), row.end(), 0.0);
            for (SparseMatrixD::InnerIterator it(L, j); it; ++it)
                for (Index c = 0; c < cols; ++c) row[std::size_t(c)] += it.value() * X(it.index(), c);
            for (Index c = 0; c < cols; ++c) Y(j, c) = row[std::size_t(c)];
        }
    });
}

/// Aᵀ B for column blocks of n rows, in a fixed order whatever the thread count (Eigen's product, single-threaded).
MatrixXd gram(const MatrixXd& A, Index aCols, const MatrixXd& B, Index bCols) {
    return A.leftCols(aCols).transpose() * B.leftCols(bCols);
}

}  // namespace

int lobpcgBlockSize(int count, const LobpcgOptions& options, double n) {
    const int guard = options.guard > 0 ? options.guard : std::max(4, count / 4);
    return int(std::min(double(count + guard), n));
}

double lobpcgBytes(double n, int count, const LobpcgOptions& options) {
    return 5.0 * 8.0 * n * double(lobpcgBlockSize(count, options, n)) + kMultigridBytesPerVoxel * n;
}

void lobpcg(const SparseMatrixD& L, const VectorXd& mass, int count, const LobpcgOptions& options, EigenResult& result,
            const Progress& progress) {
    const Index n = L.rows();
    if (!(options.tolerance > 0) || options.maxIterations < 1 || options.guard < 0)
        throw ParameterError("LOBPCG: the tolerance (LobpcgOptions::tolerance) must be > 0, the iteration cap "
                             "(LobpcgOptions::maxIterations) ≥ 1 and the guard vectors (LobpcgOptions::guard) ≥ 0",
                             {"LobpcgOptions::tolerance", "LobpcgOptions::maxIterations", "LobpcgOptions::guard"});
    const Index k = count;
    const Index m = lobpcgBlockSize(count, options, double(n));
    if (3 * m > n) throw ParameterError("LOBPCG needs a band of more than 3 (k + guard) voxels: use the Lanczos path");

    // === The preconditioner: one V-cycle of the multigrid on L
    progress.update("multigrid set-up", 0);
    const BoomerAmg amg(L, options.multigrid);
    progress.checkInterrupt();
    result.multigridLevels = amg.levels();
    result.multigridComplexity = amg.operatorComplexity();

    // === Blocks: X (Ritz vectors), W (preconditioned residuals), P (directions), T1 and T2 (work)
    MatrixXd X(n, m), W(n, m), P(n, m), T1(n, m), T2(n, m);
    {
        std::mt19937_64 random(20011);  // fixed start: deterministic results
        std::uniform_real_distribution<double> uniform(-1.0, 1.0);
        for (Index c = 0; c < m; ++c)
            for (Index i = 0; i < n; ++i) X(i, c) = uniform(random);
    }
    const auto massTimes = [&](const MatrixXd& A, Index cols, MatrixXd& out) {
        tbb::parallel_for(tbb::blocked_range<Index>(0, n, 4096), [&](const tbb::blocked_range<Index>& r) {
            for (Index c = 0; c < cols; ++c)
                for (Index i = r.begin(); i != r.end(); ++i) out(i, c) = mass(i) * A(i, c);
        });
    };

    // Rayleigh–Ritz on span of the blocks (X: m, W: a, P: p columns) given their Gram matrices in L and M; returns
    // the coefficients C of the m lowest Ritz vectors (rows: X, W, P) and their values.
    VectorXd lambda(m);
    auto rayleighRitz = [&](const MatrixXd& GA, const MatrixXd& GB) {
        Eigen::SelfAdjointEigenSolver<MatrixXd> b(GB);
        const VectorXd& d = b.eigenvalues();
        const double largest = d.maxCoeff();
        std::vector<Index> keep;
        for (Index i = 0; i < d.size(); ++i)
            if (d(i) > kRankTolerance * largest) keep.push_back(i);
        if (Index(keep.size()) < m) throw Error("LOBPCG: the search space lost rank; use the Lanczos path (--eigen-method lanczos)");
        MatrixXd Q(GB.rows(), Index(keep.size()));
        for (Index c = 0; c < Index(keep.size()); ++c) Q.col(c) = b.eigenvectors().col(keep[std::size_t(c)]) / std::sqrt(d(keep[std::size_t(c)]));
        MatrixXd H = Q.transpose() * GA * Q;
        H = 0.5 * (H + H.transpose()).eval();
        Eigen::SelfAdjointEigenSolver<MatrixXd> h(H);
        lambda = h.eigenvalues().head(m);
        return MatrixXd(Q * h.eigenvectors().leftCols(m));
    };

    // === Start: Rayleigh–Ritz on X alone
    applyL(L, X, m, T1);
    massTimes(X, m, T2);
    {
        const MatrixXd C = rayleighRitz(gram(X, m, T1, m), gram(X, m, T2, m));
        T1.noalias() = X * C;
        X.swap(T1);
    }

    std::vector<double> z(static_cast<std::size_t>(n));  // one V-cycle's output
    Index previous = 0;  // columns of P in use
    std::vector<Index> active;
    VectorXd residual(m);
    for (int iteration = 1;; ++iteration) {
        progress.checkInterrupt();
        // === Residuals R = L X − M X Λ (into W), their norms relative to |λ| ‖M x‖
        applyL(L, X, m, T1);
        massTimes(X, m, T2);
        active.clear();
        for (Index c = 0; c < m; ++c) {
            W.col(c) = T1.col(c) - lambda(c) * T2.col(c);
            residual(c) = W.col(c).norm() / (std::abs(lambda(c)) * T2.col(c).norm());
        }
        Index converged = 0;
        while (converged < k && residual(converged) <= options.tolerance) ++converged;
        result.iterations = iteration - 1;
        progress.update("eigenpairs", std::min(0.95, std::log(residual.head(k).maxCoeff()) / std::log(options.tolerance)));
        if (converged == k) break;
        if (iteration > options.maxIterations)
            throw Error("LOBPCG did not converge on the " + std::to_string(k) + " lowest pairs within " +
                        std::to_string(options.maxIterations) + " iterations (largest residual " +
                        numberText(residual.head(k).maxCoeff()) + "): raise LobpcgOptions::maxIterations or use the "
                        "Lanczos path");
        // Soft locking: pairs converged in order keep their place in X but get no new direction.
        for (Index c = 0; c < m; ++c)
            if (c >= k || residual(c) > options.tolerance) active.push_back(c);
        const Index a = Index(active.size());

        // === W = B R for the active pairs (compacted to W's first a columns)
        for (Index j = 0; j < a; ++j) {
            progress.checkInterrupt();
            amg.apply(W.col(active[std::size_t(j)]).data(), z.data());
            W.col(j) = Eigen::Map<const VectorXd>(z.data(), n);
        }
        // P's columns of the pairs still active, compacted likewise (none on the first iteration)
        const Index p = previous > 0 ? a : 0;
        for (Index j = 0; j < p; ++j)
            if (active[std::size_t(j)] != j) P.col(j) = P.col(active[std::size_t(j)]);

        // === W and P made M-orthogonal to X and of unit M-norm: as the residuals shrink, the Gram matrices of raw
        //     blocks lose the digits that carry them and the iteration stagnates (measured: near 1e-4 here)
        const auto conditionBlock = [&](MatrixXd& B, Index cols) {
            if (cols == 0) return;
            const MatrixXd XtMB = T2.transpose() * B.leftCols(cols);  // T2 = M X; m × cols
            B.leftCols(cols).noalias() -= X * XtMB;                    // no N-row temporary
            for (Index c = 0; c < cols; ++c) {
                const double norm = std::sqrt((B.col(c).array().square() * mass.array()).sum());
                if (norm > 0) B.col(c) /= norm;
            }
        };
        conditionBlock(W, a);
        conditionBlock(P, p);

        // === Gram matrices of S = [X, W, P] in L and M, one work block at a time
        const Index s = m + a + p;
        MatrixXd GA(s, s), GB(s, s);
        // L X is in T1, M X in T2
        GA.block(0, 0, m, m) = gram(X, m, T1, m);
        GA.block(m, 0, a, m) = gram(W, a, T1, m);
        if (p) GA.block(m + a, 0, p, m) = gram(P, p, T1, m);
        GB.block(0, 0, m, m) = gram(X, m, T2, m);
        GB.block(m, 0, a, m) = gram(W, a, T2, m);
        if (p) GB.block(m + a, 0, p, m) = gram(P, p, T2, m);
        applyL(L, W, a, T1);
        massTimes(W, a, T2);
        GA.block(m, m, a, a) = gram(W, a, T1, a);
        GB.block(m, m, a, a) = gram(W, a, T2, a);
        if (p) {
            GA.block(m + a, m, p, a) = gram(P, p, T1, a);
            GB.block(m + a, m, p, a) = gram(P, p, T2, a);
            applyL(L, P, p, T1);
            massTimes(P, p, T2);
            GA.block(m + a, m + a, p, p) = gram(P, p, T1, p);
            GB.block(m + a, m + a, p, p) = gram(P, p, T2, p);
        }
        GA = GA.triangularView<Eigen::Lower>();
        GB = GB.triangularView<Eigen::Lower>();
        GA = GA.selfadjointView<Eigen::Lower>();
        GB = GB.selfadjointView<Eigen::Lower>();

        // === Rayleigh–Ritz; P ← W C_W + P C_P, X ← X C_X + P (blocks swapped, not copied)
        const MatrixXd C = rayleighRitz(GA, GB);
        T2.leftCols(m).noalias() = W.leftCols(a) * C.middleRows(m, a);
        if (p) T2.leftCols(m).noalias() += P.leftCols(p) * C.middleRows(m + a, p);
        T1.noalias() = X * C.topRows(m);
        T1 += T2;
        X.swap(T1);
        // The next P: one direction per Ritz vector, in the order of X's columns.
        P.swap(T2);
        previous = m;
    }

    result.values = lambda.head(k);
    result.vectors = X.leftCols(k);
}

}  // namespace gpisvdb
