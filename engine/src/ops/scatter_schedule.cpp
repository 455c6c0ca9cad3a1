#include "scatter_schedule.h"

#include <algorithm>
#include <cstdlib>
#include <tuple>

namespace gpisvdb::detail {

int stencilReach(const Band& band) {
    int reach = 0;
    for (const VoxelStencil& st : band.stencil)
        for (int k = 0; k < st.count; ++k)
            for (int d = 0; d < 3; ++d) reach = std::max(reach, std::abs(int(st.offset[std::size_t(k)][std::size_t(d)])));
    return reach;
}

ScatterSchedule makeScatterSchedule(const Band& band, int reach) {
    ScatterSchedule s;
    while (s.blockSize < 2 * reach) s.blockSize *= 2;
    int shift = 0;
    while ((1 << shift) < s.blockSize) ++shift;

    // === Leaves: their linear-index range (indices are assigned leaf by leaf) and their block
    struct Leaf {
        int colour;
        openvdb::Coord block;
        std::uint32_t begin, end;
    };
    std::vector<Leaf> leaves;
    for (auto leaf = band.index->tree().cbeginLeaf(); leaf; ++leaf) {
        const auto first = leaf->cbeginValueOn();
        if (!first) continue;
        const std::uint32_t begin = std::uint32_t(*first);
        const std::uint32_t end = begin + std::uint32_t(leaf->onVoxelCount());
        const openvdb::Coord o = leaf->origin();
        // Arithmetic shifts: floor division, also for negative coordinates.
        const openvdb::Coord block(o.x() >> shift, o.y() >> shift, o.z() >> shift);
        const int colour = (block.x() & 1) | ((block.y() & 1) << 1) | ((block.z() & 1) << 2);
        leaves.push_back({colour, block, begin, end});
    }
    std::sort(leaves.begin(), leaves.end(),
              [](const Leaf& a, const Leaf& b) { return std::tie(a.colour, a.block, a.begin) < std::tie(b.colour, b.block, b.begin); });
    // === Blocks in colour order
    for (std::size_t l = 0; l < leaves.size(); ++l) {
        const bool newBlock = l == 0 || leaves[l].colour != leaves[l - 1].colour || leaves[l].block != leaves[l - 1].block;
        if (newBlock) {
            for (int c = (l == 0 ? 0 : leaves[l - 1].colour + 1); c <= leaves[l].colour; ++c)
                s.colourStart[std::size_t(c)] = std::uint32_t(s.blockStart.size());
            s.blockStart.push_back(std::uint32_t(l));
        }
        s.leafRanges.emplace_back(leaves[l].begin, leaves[l].end);
    }
    const int lastColour = leaves.empty() ? -1 : leaves.back().colour;
    for (int c = lastColour + 1; c <= 8; ++c) s.colourStart[std::size_t(c)] = std::uint32_t(s.blockStart.size());
    s.blockStart.push_back(std::uint32_t(leaves.size()));
    return s;
}

}  // namespace gpisvdb::detail
