#pragma once
// A symmetric linear operator on band arrays (one float per band voxel, by linear index): what the PCG needs.
// Each applies in two precisions: float in and out (the PCG's iterations), and double in and out for the residual
// of iterative refinement (solve/pcg.h). Both apply the same matrix — the float stencil weights or entries the
// operator holds — and both sum in double; the double form only skips the rounding of input and output to float,
// so that b − A x can be resolved far below float's 6e-8. Implementations: the matrix-free Laplacian (laplacian.h), the naive first-order
// Laplacian (first_order.h), and any assembled matrix (AssembledOperator).
#include <cstddef>
#include <Eigen/SparseCore>
#include <vector>

namespace gpisvdb {

using SparseMatrixF = Eigen::SparseMatrix<float, Eigen::RowMajor, int>;
/// Double precision, compressed columns: what sparse Cholesky factorisations (CHOLMOD) take.
using SparseMatrixD = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

class SymmetricOperator {
public:
    virtual ~SymmetricOperator() = default;
    /// N, the number of unknowns.
    virtual std::size_t size() const = 0;
    /// out = A u (both of length N, not aliased). Deterministic for any thread count.
    virtual void apply(const float* u, float* out) const = 0;
    /// out = A u in double: the same matrix and order of sums as the float apply, nothing rounded to float.
    /// Deterministic for any thread count.
    virtual void apply(const double* u, double* out) const = 0;
    /// out = diag(A) (length N).
    virtual void diagonal(float* out) const = 0;
    /// The matrix itself when the operator holds one (for factorisations), else nullptr.
    virtual const SparseMatrixF* matrix() const { return nullptr; }
    /// Whether assemble() gives the operator's matrix (preconditioners that need entries set up from it).
    virtual bool assemblable() const { return matrix() != nullptr; }
    /// The operator's matrix, assembled (a copy when it holds one). Throws Error when !assemblable().
    virtual SparseMatrixF assemble() const;

    void apply(const std::vector<float>& u, std::vector<float>& out) const {
        out.resize(size());
        apply(u.data(), out.data());
    }
    void apply(const std::vector<double>& u, std::vector<double>& out) const {
        out.resize(size());
        apply(u.data(), out.data());
    }
};

/// out = A u for any compressed-row matrix, parallel over rows, each row summed in double in a fixed order.
void multiply(const SparseMatrixF& A, const float* u, float* out);
void multiply(const SparseMatrixF& A, const std::vector<float>& u, std::vector<float>& out);
/// The same in double (the float entries, a double input, no rounding of the output).
void multiply(const SparseMatrixF& A, const double* u, double* out);

/// An assembled symmetric matrix as an operator (the matrix is referenced, not copied).
class AssembledOperator final : public SymmetricOperator {
public:
    explicit AssembledOperator(const SparseMatrixF& A) : A_(A) {}
    std::size_t size() const override { return std::size_t(A_.rows()); }
    void apply(const float* u, float* out) const override { multiply(A_, u, out); }
    void apply(const double* u, double* out) const override { multiply(A_, u, out); }
    void diagonal(float* out) const override;
    const SparseMatrixF* matrix() const override { return &A_; }
    using SymmetricOperator::apply;

private:
    const SparseMatrixF& A_;
};

}  // namespace gpisvdb
