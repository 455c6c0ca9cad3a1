#include "gpisvdb/ops/laplacian.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace gpisvdb {

namespace {
// Each voxel emits at most 6 terms × 2 directions × 4 entries.
constexpr int kMaxTripletsPerVoxel = 48;
}  // namespace

SparseMatrixF assembleLaplacian(const Band& band) {
    const std::size_t n = band.size();
    const double h = band.voxelSize;
    std::vector<Eigen::Triplet<float, int>> slots(n * kMaxTripletsPerVoxel);
    std::vector<int> used(n, 0);
    // === Edges of every voxel's stencil, into fixed slots (the order, and so the sums, never depend on threads)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const tbb::blocked_range<std::size_t>& r) {
        auto acc = band.index->getConstAccessor();
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            Eigen::Triplet<float, int>* out = &slots[i * kMaxTripletsPerVoxel];
            int m = 0;
            const VoxelStencil& st = band.stencil[i];
            for (int k = 0; k < st.count; ++k) {
                const float w = float(0.5 * h * double(st.weight[std::size_t(k)]));
                const openvdb::Coord e(st.offset[std::size_t(k)][0], st.offset[std::size_t(k)][1], st.offset[std::size_t(k)][2]);
                for (const openvdb::Coord& y : {band.coord[i] + e, band.coord[i] - e}) {
                    const int j = acc.getValue(y);
                    out[m++] = {int(i), int(i), w};
                    if (j < 0) continue;  // outside the band: u = 0 there
                    out[m++] = {j, j, w};
                    out[m++] = {int(i), j, -w};
                    out[m++] = {j, int(i), -w};
                }
            }
            used[i] = m;
        }
    });
    std::vector<Eigen::Triplet<float, int>> triplets;
    std::size_t total = 0;
    for (int u : used) total += std::size_t(u);
    triplets.reserve(total);
    for (std::size_t i = 0; i < n; ++i)
        triplets.insert(triplets.end(), slots.begin() + long(i * kMaxTripletsPerVoxel),
                        slots.begin() + long(i * kMaxTripletsPerVoxel) + used[i]);
    slots.clear();
    slots.shrink_to_fit();
    SparseMatrixF L(static_cast<int>(n), static_cast<int>(n));
    L.setFromTriplets(triplets.begin(), triplets.end());
    L.makeCompressed();
    return L;
}

std::vector<float> massDiagonal(const Band& band) {
    const double h3 = band.voxelSize * band.voxelSize * band.voxelSize;
    std::vector<float> m(band.size());
    for (std::size_t i = 0; i < m.size(); ++i) m[i] = float(h3 * double(band.mu[i]));
    return m;
}

void multiply(const SparseMatrixF& A, const std::vector<float>& u, std::vector<float>& out) {
    out.resize(std::size_t(A.rows()));
    const int* outer = A.outerIndexPtr();
    const int* inner = A.innerIndexPtr();
    const float* value = A.valuePtr();
    tbb::parallel_for(tbb::blocked_range<int>(0, int(A.rows()), 1024), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) {
            double s = 0;
            for (int p = outer[i]; p < outer[i + 1]; ++p) s += double(value[p]) * double(u[std::size_t(inner[p])]);
            out[std::size_t(i)] = float(s);
        }
    });
}

}  // namespace gpisvdb
