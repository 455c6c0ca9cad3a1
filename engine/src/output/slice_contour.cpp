#include "gpisvdb/output/slice_contour.h"

#include <cmath>

namespace gpisvdb {

std::vector<std::vector<Vec3d>> sliceContour(const openvdb::FloatGrid& grid, const SliceSpec& slice, double level) {
    const int a = slice.axis, u = (a + 1) % 3, v = (a + 2) % 3;
    const int layer = int(std::lround(grid.transform().worldToIndex(openvdb::Vec3d(slice.value))[a]));
    auto acc = grid.getConstAccessor();
    const openvdb::math::Transform& xf = grid.transform();
    std::vector<std::vector<Vec3d>> segments;
    // Corners in counter-clockwise order (0,0), (1,0), (1,1), (0,1) of the (u, v) square; edge e joins e and e + 1.
    constexpr int kCorner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    auto world = [&](const openvdb::Vec3d& x) {
        const openvdb::Vec3d w = xf.indexToWorld(x);
        return Vec3d(w[0], w[1], w[2]);
    };
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        if (!it.isVoxelValue() || it.getCoord()[a] != layer) continue;  // tiles hold no line: they are constant
        const openvdb::Coord c0 = it.getCoord();
        openvdb::Coord c[4];
        double f[4];
        bool complete = true;
        for (int k = 0; k < 4 && complete; ++k) {
            c[k] = c0;
            c[k][u] += kCorner[k][0], c[k][v] += kCorner[k][1];
            float value = 0;
            complete = acc.probeValue(c[k], value) && std::isfinite(value);
            f[k] = double(value) - level;
        }
        if (!complete) continue;
        // === Crossings on the edges whose ends lie on either side (a corner at the level counts as above)
        openvdb::Vec3d cross[4];
        bool crossed[4];
        int count = 0;
        for (int e = 0; e < 4; ++e) {
            const int e1 = (e + 1) % 4;
            crossed[e] = (f[e] < 0) != (f[e1] < 0);
            if (!crossed[e]) continue;
            const double t = f[e] / (f[e] - f[e1]);
            cross[e] = c[e].asVec3d() + t * (c[e1].asVec3d() - c[e].asVec3d());
            ++count;
        }
        if (count == 2) {
            std::vector<Vec3d> s;
            for (int e = 0; e < 4; ++e)
                if (crossed[e]) s.push_back(world(cross[e]));
            segments.push_back(std::move(s));
        } else if (count == 4) {
            // === Saddle: the square's mean says whether the above corners (0 and 2, or 1 and 3) join across it
            const bool centreAbove = (f[0] + f[1] + f[2] + f[3]) >= 0;
            const bool zeroAbove = f[0] >= 0;
            // Cut off the corners of the side that the centre is not on: each cut joins that corner's two edges.
            const int first = (centreAbove == zeroAbove) ? 1 : 0;
            for (int corner = first; corner < 4; corner += 2) {
                const int before = (corner + 3) % 4, after = corner;
                segments.push_back({world(cross[before]), world(cross[after])});
            }
        }
    }
    return segments;
}

}  // namespace gpisvdb
