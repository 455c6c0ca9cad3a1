#include "gpisvdb/band/stencil_neighbours.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace gpisvdb {

void stencilNeighbours(const Band& band, std::size_t first, std::size_t last, std::vector<std::int32_t>& nb) {
    nb.assign(kStencilSlots * (last - first), -1);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(first, last, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        auto acc = band.index->getConstAccessor();
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const VoxelStencil& st = band.stencil[i];
            const std::size_t at = kStencilSlots * (i - first);
            for (int k = 0; k < st.count; ++k) {
                const auto& o = st.offset[std::size_t(k)];
                const openvdb::Coord e(o[0], o[1], o[2]);
                nb[at + 2 * std::size_t(k)] = acc.getValue(band.coord[i] + e);
                nb[at + 2 * std::size_t(k) + 1] = acc.getValue(band.coord[i] - e);
            }
        }
    });
}

std::vector<std::int32_t> stencilNeighbours(const Band& band) {
    std::vector<std::int32_t> nb;
    stencilNeighbours(band, 0, band.size(), nb);
    return nb;
}

}  // namespace gpisvdb
