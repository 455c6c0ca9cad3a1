#pragma once
// Built-in shapes: the default input of the demo, and analytic cases for tests and benchmarks.
#include "gpisvdb/input/point_cloud.h"
#include "gpisvdb/input/triangle_soup.h"

namespace gpisvdb {

/// Unit-radius sphere centred at the origin: an icosahedron subdivided `level` times (20·4^level
/// triangles), vertices projected on the sphere, outward orientation.
TriangleSoup icosphere(int level, double radius = 1.0);

/// Torus around the z axis: `major` ring radius, `minor` tube radius, u×v quads split in two triangles.
TriangleSoup torus(int u, int v, double major = 1.0, double minor = 0.4);

/// Oriented cloud on a torus around the z axis sampled as a line scanner samples: rings around the axis (the scan
/// lines) `across` world units apart on the surface, points `along` world units apart on each ring, each ring at
/// a random phase and each point moved along its ring by up to ±jitter/2 × along (seeded). Area per point
/// ≈ along × across; the torus's area is 4π² major·minor. Normals outward, no σ column.
PointCloud scanLineTorus(double along, double across, double major = 3.0, double minor = 1.0, double jitter = 0.5, unsigned seed = 1);

/// Removes every triangle whose barycentre has z > zCut (makes a hole: the demo's "missing data").
TriangleSoup cutAbove(const TriangleSoup& soup, double zCut);
/// Removes every triangle whose barycentre lies in the axis-aligned box [lo, hi] (world units).
TriangleSoup cutBox(const TriangleSoup& soup, const Vec3d& lo, const Vec3d& hi);

}  // namespace gpisvdb
