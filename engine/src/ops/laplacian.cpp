#include "gpisvdb/ops/laplacian.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "../band/stencil_neighbours.h"
#include "scatter_schedule.h"

namespace gpisvdb {

namespace {
// Each voxel emits at most 6 terms × 2 directions × 4 entries.
constexpr int kMaxTripletsPerVoxel = 48;

openvdb::Coord offsetOf(const VoxelStencil& st, int k) {
    const auto& e = st.offset[std::size_t(k)];
    return openvdb::Coord(e[0], e[1], e[2]);
}

template <class Matrix>
Matrix assembleLaplacianAs(const Band& band) {
    using Scalar = typename Matrix::Scalar;
    using Triplet = Eigen::Triplet<Scalar, int>;
    const std::size_t n = band.size();
    const double h = band.voxelSize;
    std::vector<Triplet> slots(n * kMaxTripletsPerVoxel);
    std::vector<int> used(n, 0);
    // === Edges of every voxel's stencil, into fixed slots (the order, and so the sums, never depend on threads)
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const tbb::blocked_range<std::size_t>& r) {
        auto acc = band.index->getConstAccessor();
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            Triplet* out = &slots[i * kMaxTripletsPerVoxel];
            int m = 0;
            const VoxelStencil& st = band.stencil[i];
            for (int k = 0; k < st.count; ++k) {
                const Scalar w = Scalar(0.5 * h * double(st.weight[std::size_t(k)]));
                const openvdb::Coord e = offsetOf(st, k);
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
    std::vector<Triplet> triplets;
    std::size_t total = 0;
    for (int u : used) total += std::size_t(u);
    triplets.reserve(total);
    for (std::size_t i = 0; i < n; ++i)
        triplets.insert(triplets.end(), slots.begin() + long(i * kMaxTripletsPerVoxel),
                        slots.begin() + long(i * kMaxTripletsPerVoxel) + used[i]);
    slots.clear();
    slots.shrink_to_fit();
    Matrix L(static_cast<int>(n), static_cast<int>(n));
    L.setFromTriplets(triplets.begin(), triplets.end());
    L.makeCompressed();
    return L;
}
}  // namespace

SparseMatrixF assembleLaplacian(const Band& band) { return assembleLaplacianAs<SparseMatrixF>(band); }
SparseMatrixD assembleLaplacianDouble(const Band& band) { return assembleLaplacianAs<SparseMatrixD>(band); }

std::vector<float> massDiagonal(const Band& band) {
    const double h3 = band.voxelSize * band.voxelSize * band.voxelSize;
    std::vector<float> m(band.size());
    for (std::size_t i = 0; i < m.size(); ++i) m[i] = float(h3 * double(band.mu[i]));
    return m;
}

// === Matrix-free L

struct LaplacianOperator::Schedule {
    detail::ScatterSchedule scatter;
    std::vector<std::int32_t> neighbour;  // voxel i, term k, sign s (+, −): [12 i + 2 k + s], −1 outside the band
    mutable std::vector<double> sum;      // per-voxel sums in double: one rounding per output, like a CSR row
};

LaplacianOperator::LaplacianOperator(const Band& band) : band_(band), schedule_(std::make_unique<Schedule>()) {
    schedule_->scatter = detail::makeScatterSchedule(band, detail::stencilReach(band));
    schedule_->neighbour = detail::stencilNeighbours(band);
    schedule_->sum.assign(band.size(), 0.0);
}

LaplacianOperator::~LaplacianOperator() = default;

std::size_t LaplacianOperator::memoryBytes() const {
    const auto& s = schedule_->scatter;
    return sizeof(Schedule) + s.leafRanges.capacity() * sizeof(s.leafRanges[0]) + s.blockStart.capacity() * sizeof(std::uint32_t) +
           schedule_->neighbour.capacity() * sizeof(std::int32_t) + schedule_->sum.capacity() * sizeof(double);
}

namespace {
/// sum += L u, scattered edge by edge along the schedule (sum must hold zeros on entry). T is float or double:
/// both read u[i] into a double, so the float and double applies run the same sums.
template <class T>
void scatterLaplacian(const Band& band, const detail::ScatterSchedule& scatter, const std::int32_t* nb, const T* u, double* sum) {
    const double halfH = 0.5 * band.voxelSize;
    // Edge (i, j = i ± e_k) of voxel i's stencil, weight w = h λ_k(i)/2: adds w (u_i − u_j) to out_i and
    // w (u_j − u_i) to out_j (j in the band) — the two halves of h (λ^e(i) + λ^e(j))/2 come from i's and j's
    // own stencils. Outside the band u_j = 0, so out_i gains w u_i alone.
    detail::runScheduled(scatter, [&](std::uint32_t begin, std::uint32_t end) {
        for (std::uint32_t i = begin; i != end; ++i) {
            const VoxelStencil& st = band.stencil[i];
            const double ui = u[i];
            double own = 0;
            for (int k = 0; k < st.count; ++k) {
                const double w = halfH * double(st.weight[std::size_t(k)]);
                for (int s = 0; s < 2; ++s) {
                    const std::int32_t j = nb[detail::kStencilSlots * std::size_t(i) + 2 * std::size_t(k) + std::size_t(s)];
                    if (j < 0) {
                        own += w * ui;
                    } else {
                        const double d = w * (double(u[j]) - ui);
                        own -= d;
                        sum[j] += d;
                    }
                }
            }
            sum[i] += own;
        }
    });
}
}  // namespace

void LaplacianOperator::apply(const float* u, float* out) const {
    double* sum = schedule_->sum.data();
    std::fill(sum, sum + band_.size(), 0.0);
    scatterLaplacian(band_, schedule_->scatter, schedule_->neighbour.data(), u, sum);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, band_.size(), 4096), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) out[i] = float(sum[i]);
    });
}

void LaplacianOperator::apply(const double* u, double* out) const {
    // The output is the accumulator itself: no rounding, and the float path's sums in the same order.
    std::fill(out, out + band_.size(), 0.0);
    scatterLaplacian(band_, schedule_->scatter, schedule_->neighbour.data(), u, out);
}

SparseMatrixF LaplacianOperator::assemble() const { return assembleLaplacian(band_); }

void LaplacianOperator::diagonal(float* out) const {
    const Band& band = band_;
    const float halfH = float(0.5 * band.voxelSize);
    std::fill(out, out + band.size(), 0.0f);
    const std::int32_t* nb = schedule_->neighbour.data();
    detail::runScheduled(schedule_->scatter, [&](std::uint32_t begin, std::uint32_t end) {
        for (std::uint32_t i = begin; i != end; ++i) {
            const VoxelStencil& st = band.stencil[i];
            for (int k = 0; k < st.count; ++k) {
                const float w = halfH * st.weight[std::size_t(k)];
                for (int s = 0; s < 2; ++s) {
                    out[i] += w;
                    const std::int32_t j = nb[detail::kStencilSlots * std::size_t(i) + 2 * std::size_t(k) + std::size_t(s)];
                    if (j >= 0) out[j] += w;
                }
            }
        }
    });
}

}  // namespace gpisvdb
