#include "gpisvdb/input/procedural.h"

#include <cmath>
#include <map>
#include <random>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

TriangleSoup icosphere(int level, double radius) {
    if (level < 0 || level > 9) throw ParameterError("icosphere level must be in [0, 9]");
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    TriangleSoup s;
    s.vertices = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                  {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    s.triangles = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                   {3, 9, 4},  {3, 4, 2}, {3, 2, 6}, {3, 6, 8},  {3, 8, 9},   {4, 9, 5}, {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (auto& v : s.vertices) v.normalize();
    for (int l = 0; l < level; ++l) {
        std::map<std::pair<int, int>, int> mid;
        auto midpoint = [&](int a, int b) {
            const auto key = std::minmax(a, b);
            auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            s.vertices.push_back((s.vertices[a] + s.vertices[b]).normalized());
            return mid[key] = int(s.vertices.size()) - 1;
        };
        std::vector<std::array<int, 3>> next;
        for (const auto& f : s.triangles) {
            const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
            next.push_back({f[0], a, c});
            next.push_back({f[1], b, a});
            next.push_back({f[2], c, b});
            next.push_back({a, b, c});
        }
        s.triangles = std::move(next);
    }
    for (auto& v : s.vertices) v *= radius;
    return s;
}

TriangleSoup torus(int u, int v, double major, double minor) {
    if (u < 3 || v < 3) throw ParameterError("torus resolution must be at least 3×3");
    TriangleSoup s;
    for (int i = 0; i < u; ++i)
        for (int j = 0; j < v; ++j) {
            const double a = 2 * M_PI * i / u, b = 2 * M_PI * j / v;
            s.vertices.emplace_back((major + minor * std::cos(b)) * std::cos(a), (major + minor * std::cos(b)) * std::sin(a),
                                    minor * std::sin(b));
        }
    auto id = [&](int i, int j) { return (i % u) * v + (j % v); };
    for (int i = 0; i < u; ++i)
        for (int j = 0; j < v; ++j) {
            s.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            s.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    return s;
}

PointCloud scanLineTorus(double along, double across, double major, double minor, double jitter, unsigned seed) {
    if (!(along > 0) || !(across > 0) || !(minor > 0) || !(major > minor) || !(jitter >= 0 && jitter <= 1))
        throw ParameterError("scanLineTorus needs along, across > 0, major > minor > 0 and jitter in [0, 1]");
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    PointCloud c;
    const int rings = std::max(3, int(std::lround(2 * M_PI * minor / across)));
    for (int j = 0; j < rings; ++j) {
        const double b = 2 * M_PI * j / rings, radius = major + minor * std::cos(b);
        const int points = std::max(3, int(std::lround(2 * M_PI * radius / along)));
        const double phase = unit(rng);
        for (int i = 0; i < points; ++i) {
            const double a = 2 * M_PI * (i + phase + jitter * (unit(rng) - 0.5)) / points;
            const Vec3d n(std::cos(b) * std::cos(a), std::cos(b) * std::sin(a), std::sin(b));
            c.positions.emplace_back(radius * std::cos(a), radius * std::sin(a), minor * std::sin(b));
            c.normals.push_back(n);
        }
    }
    return c;
}

TriangleSoup cutAbove(const TriangleSoup& soup, double zCut) {
    TriangleSoup out;
    out.vertices = soup.vertices;
    for (const auto& f : soup.triangles) {
        const double z = (soup.vertices[f[0]].z() + soup.vertices[f[1]].z() + soup.vertices[f[2]].z()) / 3.0;
        if (z <= zCut) out.triangles.push_back(f);
    }
    return out;
}

TriangleSoup cutBox(const TriangleSoup& soup, const Vec3d& lo, const Vec3d& hi) {
    TriangleSoup out;
    out.vertices = soup.vertices;
    for (const auto& f : soup.triangles) {
        const Vec3d c = (soup.vertices[f[0]] + soup.vertices[f[1]] + soup.vertices[f[2]]) / 3.0;
        if (!((c.array() >= lo.array()).all() && (c.array() <= hi.array()).all())) out.triangles.push_back(f);
    }
    return out;
}

}  // namespace gpisvdb
