#pragma once
// A deterministic parallel schedule for operators that scatter into neighbours (the matrix-free Laplacian adds
// each stencil edge to both of its ends). The band's leaves are grouped into cubic blocks of S voxels a side,
// S ≥ 2·reach, and the blocks into 8 colours by the parity of their block coordinates. Two blocks of one
// colour are at least S apart, so what they write (their voxels and the voxels within `reach` of them) never
// overlaps: blocks of a colour run in parallel, colours one after the other, each block's voxels in a fixed
// order. Every output therefore receives its terms in the same order for any thread count.
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "gpisvdb/band/band.h"

namespace gpisvdb::detail {

struct ScatterSchedule {
    int blockSize = 8;                                                ///< S, index space voxels
    std::vector<std::pair<std::uint32_t, std::uint32_t>> leafRanges;  ///< linear-index ranges, one per leaf
    std::vector<std::uint32_t> blockStart;                            ///< block b's leaves: [blockStart[b], blockStart[b+1])
    std::array<std::uint32_t, 9> colourStart{};                       ///< colour c's blocks: [colourStart[c], colourStart[c+1])
};

/// reach: the largest |e_c| of any stencil offset (index space).
ScatterSchedule makeScatterSchedule(const Band& band, int reach);

/// Largest |component| of any stencil offset of the band.
int stencilReach(const Band& band);

/// Calls body(firstIndex, endIndex) on every leaf range, colour by colour, blocks of a colour in parallel.
template <class Body>
void runScheduled(const ScatterSchedule& s, const Body& body);

}  // namespace gpisvdb::detail

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace gpisvdb::detail {

template <class Body>
void runScheduled(const ScatterSchedule& s, const Body& body) {
    for (int c = 0; c < 8; ++c) {
        tbb::parallel_for(tbb::blocked_range<std::uint32_t>(s.colourStart[c], s.colourStart[c + 1], 1),
                          [&](const tbb::blocked_range<std::uint32_t>& r) {
                              for (std::uint32_t b = r.begin(); b != r.end(); ++b)
                                  for (std::uint32_t l = s.blockStart[b]; l != s.blockStart[b + 1]; ++l)
                                      body(s.leafRanges[l].first, s.leafRanges[l].second);
                          });
    }
}

}  // namespace gpisvdb::detail
