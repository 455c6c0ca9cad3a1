#pragma once
// Built-in shapes: the default input of the demo, and analytic cases for tests and benchmarks.
#include "gpisvdb/input/triangle_soup.h"

namespace gpisvdb {

/// Unit-radius sphere centred at the origin: an icosahedron subdivided `level` times (20·4^level
/// triangles), vertices projected on the sphere, outward orientation.
TriangleSoup icosphere(int level, double radius = 1.0);

/// Torus around the z axis: `major` ring radius, `minor` tube radius, u×v quads split in two triangles.
TriangleSoup torus(int u, int v, double major = 1.0, double minor = 0.4);

/// Removes every triangle whose barycentre has z > zCut (makes a hole: the demo's "missing data").
TriangleSoup cutAbove(const TriangleSoup& soup, double zCut);
/// Removes every triangle whose barycentre lies in the axis-aligned box [lo, hi] (world units).
TriangleSoup cutBox(const TriangleSoup& soup, const Vec3d& lo, const Vec3d& hi);

}  // namespace gpisvdb
