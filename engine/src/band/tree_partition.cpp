#include "gpisvdb/band/tree_partition.h"

#include <algorithm>
#include <array>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

/// The position of c in the tree's nested blocks: 4096³ node (its origin, compared lexicographically as the root's
/// table orders it), then the child offsets in the 128³ node, the 8³ leaf and the voxel, each x-major.
std::array<int, 6> treeKey(const openvdb::Coord& c) {
    // Arithmetic shifts floor toward −∞, as the nodes' origins do for negative coordinates.
    const auto offset = [&](int shift, int bits) {
        const int mask = (1 << bits) - 1;
        return (((c.x() >> shift) & mask) << (2 * bits)) | (((c.y() >> shift) & mask) << bits) | ((c.z() >> shift) & mask);
    };
    return {c.x() >> 12, c.y() >> 12, c.z() >> 12, offset(7, 5), offset(3, 4), offset(0, 3)};
}

}  // namespace

bool treeOrderLess(const openvdb::Coord& a, const openvdb::Coord& b) { return treeKey(a) < treeKey(b); }

int TreePartition::owner(const openvdb::Coord& c) const {
    if (first.size() <= 1) return 0;
    // The last p ≥ 1 with first[p] ≤ c, else 0.
    const auto it = std::upper_bound(first.begin() + 1, first.end(), c,
                                     [](const openvdb::Coord& x, const openvdb::Coord& y) { return treeOrderLess(x, y); });
    return int(it - first.begin()) - 1;
}

TreePartition partitionLeaves(std::vector<std::pair<openvdb::Coord, double>> leaves, int parts) {
    if (parts < 1) throw ParameterError("a partition needs at least one part");
    std::sort(leaves.begin(), leaves.end(), [](const auto& a, const auto& b) { return treeOrderLess(a.first, b.first); });
    // Part k starts at the first leaf j whose preceding weight reaches k/parts of the total: every cut lies within
    // one leaf's weight of the ideal one.
    std::vector<double> before(leaves.size() + 1, 0.0);
    for (std::size_t j = 0; j < leaves.size(); ++j) before[j + 1] = before[j] + std::max(0.0, leaves[j].second);
    TreePartition p;
    p.first.assign(std::size_t(parts), openvdb::Coord(0));
    for (int k = 1; k < parts; ++k) {
        const double target = before.back() * double(k) / double(parts);
        const std::size_t j = std::size_t(std::lower_bound(before.begin(), before.end(), target) - before.begin());
        // A leaf's origin is its first voxel in tree order; past the last leaf, a part starts beyond every leaf.
        p.first[std::size_t(k)] = j < leaves.size() ? leaves[j].first : openvdb::Coord::max();
    }
    return p;
}

}  // namespace gpisvdb
