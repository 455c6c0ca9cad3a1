#include "gpisvdb/ops/laplacian.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "gpisvdb/band/stencil_neighbours.h"
#include "gpisvdb/core/errors.h"
#include "scatter_schedule.h"

namespace gpisvdb {

namespace {

/// L in compressed rows (RowMajor float) or, L being symmetric entry for entry, the same arrays read as compressed
/// columns (ColMajor double). Each entry sums its contributions in the order the voxels emit them (voxel, then
/// term, then sign) — the order of the triplet list this replaced (Eigen's setFromTriplets), so the entries are the
/// same to the last bit — without the list: its 48 slots per voxel and Eigen's copies of it peaked near 1 000 bytes
/// per voxel; this holds the contributions once, 8–12 bytes each, beside the result (docs/memory.md).
template <class Matrix>
Matrix assembleLaplacianAs(const Band& band) {
    using Scalar = typename Matrix::Scalar;
    using Entry = std::pair<std::int32_t, Scalar>;
    const std::size_t n = band.size();
    const double h = band.voxelSize;
    // === Each voxel's stencil neighbours (linear indices, −1 outside the band), in parallel
    std::vector<std::int32_t> nb = stencilNeighbours(band);
    auto neighbour = [&](std::size_t i, int slot) { return nb[kStencilSlots * i + std::size_t(slot)]; };

    // === Off-diagonal contributions per row, duplicates included: an edge i–j adds one to row i and one to row j
    std::vector<std::size_t> start(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i)
        for (int slot = 0; slot < 2 * band.stencil[i].count; ++slot)
            if (const std::int32_t j = neighbour(i, slot); j >= 0) {
                ++start[i + 1];
                ++start[std::size_t(j) + 1];
            }
    for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];

    // === The contributions in emission order (serial: that order makes every sum independent of threads)
    std::vector<Entry> contribution(start[n]);
    std::vector<Scalar> diagonal(n, Scalar(0));
    {
        std::vector<std::size_t> cursor(start.begin(), start.end() - 1);
        for (std::size_t i = 0; i < n; ++i) {
            for (int slot = 0; slot < 2 * band.stencil[i].count; ++slot) {
                const Scalar w = Scalar(0.5 * h * double(band.stencil[i].weight[std::size_t(slot / 2)]));
                diagonal[i] += w;  // an edge leaving the band adds to the diagonal only (u = 0 outside)
                const std::int32_t j = neighbour(i, slot);
                if (j < 0) continue;
                diagonal[std::size_t(j)] += w;
                contribution[cursor[i]++] = {j, -w};
                contribution[cursor[std::size_t(j)]++] = {std::int32_t(i), -w};
            }
        }
    }
    std::vector<std::int32_t>().swap(nb);

    // === Each row: its diagonal and contributions, stably sorted by column, equal columns summed in that order
    auto mergeRow = [&](std::size_t i, std::vector<Entry>& row) {
        row.assign(contribution.begin() + long(start[i]), contribution.begin() + long(start[i + 1]));
        row.emplace_back(std::int32_t(i), diagonal[i]);
        std::stable_sort(row.begin(), row.end(), [](const Entry& a, const Entry& b) { return a.first < b.first; });
        std::size_t m = 0;
        for (const Entry& e : row) {
            if (m > 0 && row[m - 1].first == e.first) row[m - 1].second += e.second;
            else row[m++] = e;
        }
        row.resize(m);
    };
    std::vector<std::int64_t> outer(n + 1, 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<Entry> row;
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            mergeRow(i, row);
            outer[i + 1] = std::int64_t(row.size());
        }
    });
    for (std::size_t i = 0; i < n; ++i) outer[i + 1] += outer[i];
    if (outer[n] > std::numeric_limits<int>::max()) throw Error("the Laplacian has more than 2^31 entries: use a coarser voxel size");
    Matrix L(static_cast<int>(n), static_cast<int>(n));
    L.resizeNonZeros(static_cast<Eigen::Index>(outer[n]));
    for (std::size_t i = 0; i <= n; ++i) L.outerIndexPtr()[i] = int(outer[i]);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        std::vector<Entry> row;
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            mergeRow(i, row);
            for (std::size_t e = 0; e < row.size(); ++e) {
                L.innerIndexPtr()[outer[i] + std::int64_t(e)] = row[e].first;
                L.valuePtr()[outer[i] + std::int64_t(e)] = row[e].second;
            }
        }
    });
    return L;
}
}  // namespace

SparseMatrixF assembleLaplacian(const Band& band) { return assembleLaplacianAs<SparseMatrixF>(band); }
SparseMatrixD assembleLaplacianDouble(const Band& band) { return assembleLaplacianAs<SparseMatrixD>(band); }

LaplacianSize laplacianSize(const Band& band) {
    // An edge i–j (j = x_i ± h e) is emitted by i, and by j too when j's stencil holds ±e; its two entries (i, j)
    // and (j, i) are stored once however often it is emitted. So each emission counts 2 contributions, and an edge
    // counts once: at i, unless j emits it too and j < i. (A term repeated in one stencil is emitted twice by it.)
    struct Count {
        std::size_t edges = 0, contributions = 0;
    };
    using Offset = std::array<std::int8_t, 3>;
    const auto holds = [](const VoxelStencil& st, const Offset& e, int terms) {
        for (int k = 0; k < terms; ++k) {
            const Offset& o = st.offset[std::size_t(k)];
            if ((o[0] == e[0] && o[1] == e[1] && o[2] == e[2]) || (o[0] == -e[0] && o[1] == -e[1] && o[2] == -e[2])) return true;
        }
        return false;
    };
    const Count total = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, band.size(), 4096), Count{},
        [&](const tbb::blocked_range<std::size_t>& r, Count c) {
            auto acc = band.index->getConstAccessor();
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                const VoxelStencil& st = band.stencil[i];
                for (int k = 0; k < st.count; ++k) {
                    const Offset& o = st.offset[std::size_t(k)];
                    const openvdb::Coord e(o[0], o[1], o[2]);
                    const bool repeated = holds(st, o, k);  // an earlier term of i already emitted these edges
                    for (const openvdb::Coord& x : {band.coord[i] + e, band.coord[i] - e}) {
                        const std::int32_t j = acc.getValue(x);
                        if (j < 0) continue;
                        c.contributions += 2;
                        if (repeated) continue;
                        if (std::size_t(j) < i && holds(band.stencil[std::size_t(j)], o, band.stencil[std::size_t(j)].count))
                            continue;  // counted at j
                        ++c.edges;
                    }
                }
            }
            return c;
        },
        [](Count a, const Count& b) {
            a.edges += b.edges;
            a.contributions += b.contributions;
            return a;
        });
    return {band.size(), band.size() + 2 * total.edges, total.contributions};
}

double assembledLaplacianBytes(const LaplacianSize& size, std::size_t scalarBytes) {
    return double(scalarBytes + sizeof(std::int32_t)) * double(size.entries) + 4.0 * double(size.voxels + 1);
}

double laplacianAssemblyBytes(const LaplacianSize& size, std::size_t scalarBytes) {
    const double n = double(size.voxels), s = double(scalarBytes);
    // A contribution is a (column, value) pair, padded to the value's alignment
    const double entry =
        double(scalarBytes == sizeof(float) ? sizeof(std::pair<std::int32_t, float>) : sizeof(std::pair<std::int32_t, double>));
    const double contributions = entry * double(size.contributions);
    const double rowStarts = 8.0 * (n + 1);  // std::size_t start, or std::int64_t outer
    const double emission = 4.0 * kStencilSlots * n + rowStarts + 8.0 * n /* cursor */ + s * n + contributions;
    const double merge = 2 * rowStarts + s * n + contributions + assembledLaplacianBytes(size, scalarBytes);
    return std::max(emission, merge);
}

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
    schedule_->neighbour = stencilNeighbours(band);
    schedule_->sum.assign(band.size(), 0.0);
}

LaplacianOperator::~LaplacianOperator() = default;

const std::int32_t* LaplacianOperator::neighbours() const { return schedule_->neighbour.data(); }

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
                    const std::int32_t j = nb[kStencilSlots * std::size_t(i) + 2 * std::size_t(k) + std::size_t(s)];
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
                    const std::int32_t j = nb[kStencilSlots * std::size_t(i) + 2 * std::size_t(k) + std::size_t(s)];
                    if (j >= 0) out[j] += w;
                }
            }
        }
    });
}

double laplacianOperatorBytes(std::size_t n) { return (12.0 * 4.0 + 8.0) * double(n); }

}  // namespace gpisvdb
