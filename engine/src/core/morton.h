#pragma once
// Morton (Z-order) keys: nearby points get nearby keys. An implementation header of the engine (the model's
// batch paths, the cloud's area estimate).
#include <algorithm>
#include <cstdint>
#include <tbb/parallel_for.h>
#include <utility>
#include <vector>

#include "gpisvdb/core/types.h"

namespace gpisvdb::detail {

/// Interleaves the bits of three 21-bit integers.
inline std::uint64_t morton(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
    auto spread = [](std::uint64_t v) {
        v &= 0x1fffff;
        v = (v | v << 32) & 0x1f00000000ffffULL;
        v = (v | v << 16) & 0x1f0000ff0000ffULL;
        v = (v | v << 8) & 0x100f00f00f00f00fULL;
        v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
        v = (v | v << 2) & 0x1249249249249249ULL;
        return v;
    };
    return spread(a) | spread(b) << 1 | spread(c) << 2;
}

/// (key, index) of every point, sorted along the Morton curve of the points' bounding cube: visiting them in this
/// order keeps neighbours together (fewer cache misses in a tree's queries). Ties keep index order.
inline std::vector<std::pair<std::uint64_t, std::uint32_t>> mortonSorted(const std::vector<Vec3d>& xs) {
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(xs.size());
    if (xs.empty()) return keyed;
    Vec3d lo = xs[0], hi = xs[0];
    for (const Vec3d& p : xs) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const double extent = std::max((hi - lo).maxCoeff(), 1e-300);
    tbb::parallel_for(std::size_t(0), xs.size(), [&](std::size_t i) {
        const Vec3d q = ((xs[i] - lo) / extent * double(0x1fffff)).cwiseMax(0.0);
        keyed[i] = {morton(std::uint64_t(q.x()), std::uint64_t(q.y()), std::uint64_t(q.z())), std::uint32_t(i)};
    });
    std::sort(keyed.begin(), keyed.end());
    return keyed;
}

}  // namespace gpisvdb::detail
