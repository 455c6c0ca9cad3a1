#pragma once
// Cells of a cubic lattice anchored at the world origin, as hash keys: the cells' shared far field
// (barnes_hut_cells.cpp) and the merged dipoles (merge_samples.cpp).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "gpisvdb/core/types.h"

namespace gpisvdb::detail {

/// The index of the cell holding u (in cell widths): floor(u), clamped to ±9e15 (exact in double); 0 where u is not
/// finite.
inline std::int64_t cellIndex(double u) {
    const double f = std::floor(u);
    return std::isfinite(f) ? std::int64_t(std::clamp(f, -9e15, 9e15)) : 0;
}

struct CellKey {
    std::int64_t c[3];
    bool operator==(const CellKey& o) const { return c[0] == o.c[0] && c[1] == o.c[1] && c[2] == o.c[2]; }
    /// The cell of width `width` (world units) holding p.
    static CellKey of(const Vec3d& p, double width) {
        return {{cellIndex(p[0] / width), cellIndex(p[1] / width), cellIndex(p[2] / width)}};
    }
};

/// FNV-1a over the three indices; as std::hash (operator()) and as TBB's hash-compare (hash, equal).
struct CellKeyHash {
    static std::size_t hash(const CellKey& k) {
        std::uint64_t h = 1469598103934665603ULL;
        for (std::int64_t v : k.c) h = (h ^ std::uint64_t(v)) * 1099511628211ULL;
        return std::size_t(h ^ (h >> 29));
    }
    static bool equal(const CellKey& a, const CellKey& b) { return a == b; }
    std::size_t operator()(const CellKey& k) const { return hash(k); }
};

}  // namespace gpisvdb::detail
