#include "stencil_neighbours.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace gpisvdb::detail {

std::vector<std::int32_t> stencilNeighbours(const Band& band) {
    std::vector<std::int32_t> nb(kStencilSlots * band.size(), -1);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, band.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        auto acc = band.index->getConstAccessor();
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const VoxelStencil& st = band.stencil[i];
            for (int k = 0; k < st.count; ++k) {
                const auto& o = st.offset[std::size_t(k)];
                const openvdb::Coord e(o[0], o[1], o[2]);
                nb[kStencilSlots * i + 2 * std::size_t(k)] = acc.getValue(band.coord[i] + e);
                nb[kStencilSlots * i + 2 * std::size_t(k) + 1] = acc.getValue(band.coord[i] - e);
            }
        }
    });
    return nb;
}

}  // namespace gpisvdb::detail
