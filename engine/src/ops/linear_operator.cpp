#include "gpisvdb/ops/linear_operator.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {
/// Rows in parallel, each summed in double in the order of its entries; Out is float or double.
template <class In, class Out>
void multiplyAs(const SparseMatrixF& A, const In* u, Out* out) {
    if (!A.isCompressed()) throw Error("multiply: the matrix must be compressed (call makeCompressed())");
    const int* outer = A.outerIndexPtr();
    const int* inner = A.innerIndexPtr();
    const float* value = A.valuePtr();
    tbb::parallel_for(tbb::blocked_range<int>(0, int(A.rows()), 1024), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) {
            double s = 0;
            for (int p = outer[i]; p < outer[i + 1]; ++p) s += double(value[p]) * double(u[inner[p]]);
            out[i] = Out(s);
        }
    });
}
}  // namespace

void multiply(const SparseMatrixF& A, const float* u, float* out) { multiplyAs(A, u, out); }
void multiply(const SparseMatrixF& A, const double* u, double* out) { multiplyAs(A, u, out); }

void multiply(const SparseMatrixF& A, const std::vector<float>& u, std::vector<float>& out) {
    out.resize(std::size_t(A.rows()));
    multiply(A, u.data(), out.data());
}

SparseMatrixF SymmetricOperator::assemble() const {
    if (const SparseMatrixF* M = matrix()) return *M;
    throw Error("this operator cannot be assembled (it holds no matrix and knows no assembly)");
}

void AssembledOperator::diagonal(float* out) const {
    for (int i = 0; i < A_.rows(); ++i) out[i] = A_.coeff(i, i);
}

}  // namespace gpisvdb
