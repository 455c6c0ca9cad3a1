#include "gpisvdb/solve/lobpcg.h"

#include <algorithm>
#include <cmath>
#include <Eigen/Eigenvalues>
#include <random>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>
#include <vector>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/solve/boomer_amg.h"
#include "gpisvdb/solve/eigen_solver.h"

namespace gpisvdb {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

/// Below this share of the largest M-Gram eigenvalue a direction of [X, W, P] is dependent on the others: dropped.
constexpr double kRankTolerance = 1e-13;

/// Rows of a chunk: the blocks are swept a chunk of rows at a time, so that L X, M X and their kin exist only a chunk
/// at a time (N × m doubles saved per product). Fixed, so that every sum is taken in the same order for any thread
/// count.
constexpr Index kChunkRows = 2048;

/// The chunks of n rows: chunk c is rows [c kChunkRows, min(n, (c + 1) kChunkRows)).
struct Chunks {
    Index n;
    Index count() const { return (n + kChunkRows - 1) / kChunkRows; }
    Index begin(Index c) const { return c * kChunkRows; }
    Index rows(Index c) const { return std::min(n, (c + 1) * kChunkRows) - c * kChunkRows; }
};

/// Rows [r0, r0 + out.rows()) of L B for B's first out.cols() columns (L symmetric: row j of L is its column j),
/// each row's sum in the order of its entries.
void applyLRows(const SparseMatrixD& L, const MatrixXd& B, Index r0, Eigen::Ref<MatrixXd> out) {
    const Index cols = out.cols();
    std::vector<double> row(static_cast<std::size_t>(cols));  // a local sum: `out` may alias B for the compiler, `row` cannot
    for (Index r = 0; r < out.rows(); ++r) {
        std::fill(row.begin(), row.end(), 0.0);
        for (SparseMatrixD::InnerIterator it(L, r0 + r); it; ++it)
            for (Index c = 0; c < cols; ++c) row[std::size_t(c)] += it.value() * B(it.index(), c);
        for (Index c = 0; c < cols; ++c) out(r, c) = row[std::size_t(c)];
    }
}

/// Σ over the chunks of perChunk(chunk's first row, its rows) (each a rows × cols matrix), in a split-and-join
/// pattern fixed by the chunk count alone (tbb::parallel_deterministic_reduce): bitwise the same for any thread
/// count, with only the partial sums in flight alive.
template <class F>
MatrixXd sumOverChunks(const Chunks& chunks, Index rows, Index cols, const F& perChunk) {
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<Index>(0, chunks.count(), 1), MatrixXd(MatrixXd::Zero(rows, cols)),
        [&](const tbb::blocked_range<Index>& range, MatrixXd sum) {
            for (Index c = range.begin(); c != range.end(); ++c) sum += perChunk(chunks.begin(c), chunks.rows(c));
            return sum;
        },
        [](const MatrixXd& a, const MatrixXd& b) { return MatrixXd(a + b); });
}

/// A thread's work space for a chunk's products, reused from chunk to chunk: a fresh temporary per chunk would be
/// mapped and unmapped by malloc each time (it is above glibc's mmap threshold), a page fault per page (12 % of the
/// time, measured).
/// Aligned as Eigen aligns its own storage: a reduction over a view starts its vector loop at the data's alignment,
/// which must not depend on the thread that ran the chunk.
using ScratchVector = std::vector<double, Eigen::aligned_allocator<double>>;
struct Scratch {
    ScratchVector a, b;
};

Eigen::Map<MatrixXd, Eigen::Aligned16> view(ScratchVector& storage, Index rows, Index cols) {
    if (storage.size() < std::size_t(rows * cols)) storage.resize(std::size_t(rows * cols));
    return {storage.data(), rows, cols};
}

/// Calls perChunk(first row, rows) for every chunk, in parallel: for row-local updates.
template <class F>
void forEachChunk(const Chunks& chunks, const F& perChunk) {
    tbb::parallel_for(tbb::blocked_range<Index>(0, chunks.count(), 1), [&](const tbb::blocked_range<Index>& range) {
        for (Index c = range.begin(); c != range.end(); ++c) perChunk(chunks.begin(c), chunks.rows(c));
    });
}

}  // namespace

int lobpcgBlockSize(int count, const LobpcgOptions& options, double n) {
    const int guard = options.guard > 0 ? options.guard : std::max(4, count / 4);
    return int(std::min(double(count + guard), n));
}

double lobpcgBytes(double n, int count, const LobpcgOptions& options) {
    const double m = lobpcgBlockSize(count, options, n);
    // Per thread, a chunk's products (at most [L B, M B] for B = [W P], 4m columns, beside an m-column one) and two
    // partial sums in flight (Sᵀ [L B, M B]: 3m × 4m)
    const double chunkBytes = 8.0 * double(kChunkRows) * 5.0 * m + 2.0 * 8.0 * 12.0 * m * m;
    const double threads = double(tbb::this_task_arena::max_concurrency());
    return 3.0 * 8.0 * n * m + 8.0 * n + threads * chunkBytes + kMultigridBytesPerVoxel * n;
}

void lobpcg(const SparseMatrixD& L, const VectorXd& mass, int count, const LobpcgOptions& options, EigenResult& result,
            const Progress& progress) {
    const Index n = L.rows();
    if (!(options.tolerance > 0) || options.maxIterations < 1 || options.guard < 0)
        throw ParameterError(
            "LOBPCG: the tolerance (LobpcgOptions::tolerance) must be > 0, the iteration cap "
            "(LobpcgOptions::maxIterations) ≥ 1 and the guard vectors (LobpcgOptions::guard) ≥ 0",
            {"LobpcgOptions::tolerance", "LobpcgOptions::maxIterations", "LobpcgOptions::guard"});
    const Index k = count;
    const Index m = lobpcgBlockSize(count, options, double(n));
    if (3 * m > n) throw ParameterError("LOBPCG needs a band of more than 3 (k + guard) voxels: use the Lanczos path");
    const Chunks chunks{n};
    tbb::enumerable_thread_specific<Scratch> scratch;

    // === The preconditioner: one V-cycle of the multigrid on L
    progress.update("multigrid set-up", 0);
    const BoomerAmg amg(L, options.multigrid);
    progress.checkInterrupt();
    result.multigridLevels = amg.levels();
    result.multigridComplexity = amg.operatorComplexity();

    // === Blocks: X (Ritz vectors), W (residuals, then preconditioned), P (directions). Products with L and M are
    //     formed a chunk of rows at a time and reduced at once to the Gram matrices they feed.
    MatrixXd X(n, m), W(n, m), P(n, m);
    {
        std::mt19937_64 random(20011);  // fixed start: deterministic results
        std::uniform_real_distribution<double> uniform(-1.0, 1.0);
        for (Index c = 0; c < m; ++c)
            for (Index i = 0; i < n; ++i) X(i, c) = uniform(random);
    }

    // Xᵀ L X, Xᵀ M X, and W = L X − M X Λ with the squared norms of W's and M X's columns, in one sweep; returned
    // side by side (m × (2m + 2)).
    VectorXd lambda = VectorXd::Zero(m);
    const auto residualSweep = [&] {
        return sumOverChunks(chunks, m, 2 * m + 2, [&](Index r0, Index rows) {
            Scratch& work = scratch.local();
            auto LX = view(work.a, rows, m);
            applyLRows(L, X, r0, LX);
            auto MX = view(work.b, rows, m);
            MX.noalias() = mass.segment(r0, rows).asDiagonal() * X.middleRows(r0, rows);
            MatrixXd part(m, 2 * m + 2);
            part.leftCols(m).noalias() = X.middleRows(r0, rows).transpose() * LX;
            part.middleCols(m, m).noalias() = X.middleRows(r0, rows).transpose() * MX;
            W.middleRows(r0, rows).noalias() = LX - MX * lambda.asDiagonal();
            part.col(2 * m) = W.middleRows(r0, rows).colwise().squaredNorm().transpose();
            part.col(2 * m + 1) = MX.colwise().squaredNorm().transpose();
            return part;
        });
    };

    // Rayleigh–Ritz on span of the blocks (X: m, W: a, P: p columns) given their Gram matrices in L and M; returns
    // the coefficients C of the m lowest Ritz vectors (rows: X, W, P) and sets their values.
    auto rayleighRitz = [&](const MatrixXd& GA, const MatrixXd& GB) {
        Eigen::SelfAdjointEigenSolver<MatrixXd> b(GB);
        const VectorXd& d = b.eigenvalues();
        const double largest = d.maxCoeff();
        std::vector<Index> keep;
        for (Index i = 0; i < d.size(); ++i)
            if (d(i) > kRankTolerance * largest) keep.push_back(i);
        if (Index(keep.size()) < m) throw Error("LOBPCG: the search space lost rank; use the Lanczos path (--eigen-method lanczos)");
        MatrixXd Q(GB.rows(), Index(keep.size()));
        for (Index c = 0; c < Index(keep.size()); ++c)
            Q.col(c) = b.eigenvectors().col(keep[std::size_t(c)]) / std::sqrt(d(keep[std::size_t(c)]));
        MatrixXd H = Q.transpose() * GA * Q;
        H = 0.5 * (H + H.transpose()).eval();
        Eigen::SelfAdjointEigenSolver<MatrixXd> h(H);
        lambda = h.eigenvalues().head(m);
        return MatrixXd(Q * h.eigenvectors().leftCols(m));
    };

    // === Start: Rayleigh–Ritz on X alone
    {
        const MatrixXd sums = residualSweep();
        const MatrixXd C = rayleighRitz(sums.leftCols(m), sums.middleCols(m, m));
        forEachChunk(chunks, [&](Index r0, Index rows) {
            auto x = view(scratch.local().a, rows, m);
            x.noalias() = X.middleRows(r0, rows) * C;
            X.middleRows(r0, rows) = x;
        });
    }

    std::vector<double> z(static_cast<std::size_t>(n));  // one V-cycle's output
    Index previous = 0;                                  // columns of P in use
    std::vector<Index> active;
    VectorXd residual(m);
    for (int iteration = 1;; ++iteration) {
        progress.checkInterrupt();
        // === Residuals R = L X − M X Λ (into W), their norms relative to |λ| ‖M x‖
        const MatrixXd sums = residualSweep();
        active.clear();
        for (Index c = 0; c < m; ++c) residual(c) = std::sqrt(sums(c, 2 * m)) / (std::abs(lambda(c)) * std::sqrt(sums(c, 2 * m + 1)));
        Index converged = 0;
        while (converged < k && residual(converged) <= options.tolerance) ++converged;
        result.iterations = iteration - 1;
        progress.update("eigenpairs", std::min(0.95, std::log(residual.head(k).maxCoeff()) / std::log(options.tolerance)));
        if (converged == k) break;
        if (iteration > options.maxIterations)
            throw Error("LOBPCG did not converge on the " + std::to_string(k) + " lowest pairs within " +
                        std::to_string(options.maxIterations) + " iterations (largest residual " + numberText(residual.head(k).maxCoeff()) +
                        "): raise LobpcgOptions::maxIterations or use the "
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
        const Index b = a + p;  // columns of B = [W P]
        // A chunk's rows of M B, into `out`
        const auto massTimesB = [&](Index r0, Index rows, Eigen::Ref<MatrixXd> out) {
            out.leftCols(a).noalias() = mass.segment(r0, rows).asDiagonal() * W.block(r0, 0, rows, a);
            if (p) out.rightCols(p).noalias() = mass.segment(r0, rows).asDiagonal() * P.block(r0, 0, rows, p);
        };

        // === W and P made M-orthogonal to X: as the residuals shrink, the Gram matrices of raw blocks lose the
        //     digits that carry them and the iteration stagnates (measured: near 1e-4 here)
        const MatrixXd XtMB = sumOverChunks(chunks, m, b, [&](Index r0, Index rows) {
            auto MB = view(scratch.local().a, rows, b);
            massTimesB(r0, rows, MB);
            return MatrixXd(X.middleRows(r0, rows).transpose() * MB);
        });
        const VectorXd normsSquared = sumOverChunks(chunks, b, 1, [&](Index r0, Index rows) {
            const auto x = X.middleRows(r0, rows);
            W.block(r0, 0, rows, a).noalias() -= x * XtMB.leftCols(a);
            if (p) P.block(r0, 0, rows, p).noalias() -= x * XtMB.rightCols(p);
            const auto m_ = mass.segment(r0, rows).array();
            MatrixXd part(b, 1);
            part.topRows(a) = (W.block(r0, 0, rows, a).array().square().colwise() * m_).colwise().sum().transpose();
            if (p) part.bottomRows(p) = (P.block(r0, 0, rows, p).array().square().colwise() * m_).colwise().sum().transpose();
            return part;
        });
        // ... and of unit M-norm, by the diagonal scaling D, applied to their Gram matrices and the Ritz coefficients
        // rather than to the blocks (no sweep)
        VectorXd D = VectorXd::Ones(m + b);
        for (Index c = 0; c < b; ++c)
            if (normsSquared(c) > 0) D(m + c) = 1.0 / std::sqrt(normsSquared(c));

        // === Gram matrices of S = [X, W, P] in L and M: Sᵀ L B and Sᵀ M B (B = [W P]) in one sweep; the X–X blocks
        //     came with the residuals
        const Index s = m + b;
        const MatrixXd SLB_SMB = sumOverChunks(chunks, s, 2 * b, [&](Index r0, Index rows) {
            auto LBMB = view(scratch.local().a, rows, 2 * b);  // [L B, M B]
            applyLRows(L, W, r0, LBMB.leftCols(a));
            if (p) applyLRows(L, P, r0, LBMB.middleCols(a, p));
            massTimesB(r0, rows, LBMB.rightCols(b));
            MatrixXd part(s, 2 * b);
            part.topRows(m).noalias() = X.middleRows(r0, rows).transpose() * LBMB;
            part.middleRows(m, a).noalias() = W.block(r0, 0, rows, a).transpose() * LBMB;
            if (p) part.bottomRows(p).noalias() = P.block(r0, 0, rows, p).transpose() * LBMB;
            return part;
        });
        MatrixXd GA(s, s), GB(s, s);
        GA.block(0, 0, m, m) = sums.leftCols(m);
        GB.block(0, 0, m, m) = sums.middleCols(m, m);
        GA.block(m, 0, b, m) = SLB_SMB.block(0, 0, m, b).transpose();
        GB.block(m, 0, b, m) = SLB_SMB.block(0, b, m, b).transpose();
        GA.block(m, m, b, b) = SLB_SMB.block(m, 0, b, b);
        GB.block(m, m, b, b) = SLB_SMB.block(m, b, b, b);
        GA = GA.triangularView<Eigen::Lower>();
        GB = GB.triangularView<Eigen::Lower>();
        GA = GA.selfadjointView<Eigen::Lower>();
        GB = GB.selfadjointView<Eigen::Lower>();
        GA = D.asDiagonal() * GA * D.asDiagonal();
        GB = D.asDiagonal() * GB * D.asDiagonal();

        // === Rayleigh–Ritz; P ← W C_W + P C_P, X ← X C_X + P, row by row (C in terms of the unscaled W and P)
        const MatrixXd C = D.asDiagonal() * rayleighRitz(GA, GB);
        forEachChunk(chunks, [&](Index r0, Index rows) {
            Scratch& work = scratch.local();
            auto direction = view(work.a, rows, m);
            direction.noalias() = W.block(r0, 0, rows, a) * C.middleRows(m, a);
            if (p) direction.noalias() += P.block(r0, 0, rows, p) * C.bottomRows(p);
            auto x = view(work.b, rows, m);
            x.noalias() = X.middleRows(r0, rows) * C.topRows(m);
            x += direction;
            X.middleRows(r0, rows) = x;
            P.middleRows(r0, rows) = direction;
        });
        previous = m;
    }

    W.resize(0, 0);  // before the vectors are copied out: the peak stays at three blocks
    P.resize(0, 0);
    result.values = lambda.head(k);
    result.vectors = X.leftCols(k);
}

}  // namespace gpisvdb
