#include "gpisvdb/solve/fast_marching.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include "../band/stencil_neighbours.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kSlots = detail::kStencilSlots;

/// The stencil neighbours (term k, sign s at [12 i + 2 k + s], −1 outside the band) and their reverse table.
struct Neighbours {
    std::vector<std::int32_t> forward;
    std::vector<std::uint32_t> reverseStart;  // voxels whose stencil reaches y: reverse[reverseStart[y] …]
    std::vector<std::int32_t> reverse;
};

Neighbours neighbours(const Band& band) {
    const std::size_t n = band.size();
    Neighbours nb;
    nb.forward = detail::stencilNeighbours(band);
    // === Reverse table by counting sort (deterministic: sources in index order)
    nb.reverseStart.assign(n + 1, 0);
    for (std::int32_t j : nb.forward)
        if (j >= 0) ++nb.reverseStart[std::size_t(j) + 1];
    for (std::size_t y = 0; y < n; ++y) nb.reverseStart[y + 1] += nb.reverseStart[y];
    nb.reverse.resize(nb.reverseStart[n]);
    std::vector<std::uint32_t> fill(nb.reverseStart.begin(), nb.reverseStart.end() - 1);
    // A voxel's 12 stencil neighbours are distinct (Selling's offsets are distinct up to sign), so each voxel is
    // listed at most once per neighbour.
    for (std::size_t i = 0; i < n; ++i)
        for (int s = 0; s < kSlots; ++s) {
            const std::int32_t j = nb.forward[kSlots * i + std::size_t(s)];
            if (j >= 0) nb.reverse[fill[std::size_t(j)]++] = std::int32_t(i);
        }
    return nb;
}

/// Solves Σ_k λ_k max(0, U − m_k)² = h² for U, m_k the smaller accepted neighbour value of term k (+∞ if none).
double localSolve(const double* lambda, const double* m, int count, double h2) {
    int order[6];
    for (int k = 0; k < count; ++k) {  // insertion sort by m: at most 6 terms
        int q = k;
        for (; q > 0 && m[order[q - 1]] > m[k]; --q) order[q] = order[q - 1];
        order[q] = k;
    }
    double a = 0, b = 0, c = -h2, u = kInf;
    for (int q = 0; q < count; ++q) {
        const int k = order[q];
        if (!std::isfinite(m[k]) || !(lambda[k] > 0)) break;
        if (u <= m[k]) break;  // the terms beyond are inactive: max(0, U − m_k) = 0
        a += lambda[k];
        b += lambda[k] * m[k];
        c += lambda[k] * m[k] * m[k];
        // a U² − 2 b U + c = 0, the larger root
        const double disc = b * b - a * c;
        u = (b + std::sqrt(std::max(0.0, disc))) / a;
    }
    return u;
}

}  // namespace

FastMarchingResult fastMarching(const Band& band, const std::vector<std::size_t>& sources,
                                const std::vector<std::size_t>& targets, const FastMarchingOptions& options,
                                const Progress& progress) {
    const std::size_t n = band.size();
    if (sources.empty()) throw ParameterError("fast marching needs at least one source");
    for (std::size_t s : sources)
        if (s >= n) throw ParameterError("a fast-marching source is not a band voxel");
    for (std::size_t t : targets)
        if (t >= n) throw ParameterError("a fast-marching target is not a band voxel");
    const Neighbours nb = neighbours(band);
    const double h2 = band.voxelSize * band.voxelSize;

    FastMarchingResult r;
    r.distance.assign(n, kInf);
    std::vector<std::uint8_t> accepted(n, 0);
    std::vector<std::uint8_t> isTarget(n, 0);
    std::size_t targetsLeft = 0;
    for (std::size_t t : targets)
        if (!isTarget[t]) isTarget[t] = 1, ++targetsLeft;

    // === Seeds (fixed at 0), then Dijkstra order on (U, index): ties resolved by index, so the march is unique
    using Entry = std::pair<double, std::uint32_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
    for (std::size_t s : sources) {
        if (r.distance[s] == 0) continue;
        r.distance[s] = 0;
        heap.emplace(0.0, std::uint32_t(s));
    }
    double lambda[6], m[6];
    while (!heap.empty()) {
        const auto [u, y] = heap.top();
        heap.pop();
        if (accepted[y] || u > r.distance[y]) continue;  // stale entry
        accepted[y] = 1;
        ++r.accepted;
        if (r.accepted % 65536 == 0) {
            progress.checkInterrupt();
            progress.update("geodesic", double(r.accepted) / double(n));
        }
        if (isTarget[y] && --targetsLeft == 0 && options.stopAtTargets && !targets.empty()) {
            r.stoppedEarly = r.accepted < n;
            break;
        }
        // === Update every voxel whose stencil reaches y, from its accepted neighbours
        for (std::uint32_t q = nb.reverseStart[y]; q < nb.reverseStart[y + 1]; ++q) {
            const std::uint32_t x = std::uint32_t(nb.reverse[q]);
            if (accepted[x]) continue;
            const VoxelStencil& st = band.stencil[x];
            for (int k = 0; k < st.count; ++k) {
                lambda[k] = st.weight[std::size_t(k)];
                m[k] = kInf;
                for (int s = 0; s < 2; ++s) {
                    const std::int32_t j = nb.forward[kSlots * std::size_t(x) + 2 * std::size_t(k) + std::size_t(s)];
                    if (j >= 0 && accepted[std::size_t(j)]) m[k] = std::min(m[k], r.distance[std::size_t(j)]);
                }
            }
            const double v = localSolve(lambda, m, st.count, h2);
            if (v < r.distance[x]) {
                r.distance[x] = v;
                heap.emplace(v, x);
            }
        }
    }
    // === Whatever was not accepted is not final: +∞ and counted
    for (std::size_t i = 0; i < n; ++i)
        if (!accepted[i]) r.distance[i] = kInf, ++r.unreached;
    progress.update("geodesic", 1.0);
    return r;
}

}  // namespace gpisvdb
