#pragma once
// The probability that a mesh (a robot, a character, a tool) meets the inside of the uncertain shape
// (docs/uncertainty.md#mesh-collision), by Monte Carlo over draws of the GPIS (tasks/plausible_surfaces.h).
//
// The mesh is sampled at its vertices, along its edges and across its triangles at spacing `step`; draw k collides
// when φ_k > u at one of those points. The estimate is the fraction of the n draws that collide, with its standard
// error √(p (1 − p) / n); what happens between the sample points (a sliver of the shape thinner than `step`) is
// not seen.
#include <array>
#include <cstdint>
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/core/types.h"
#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

struct CollisionOptions {
    int draws = 1000;           ///< Monte Carlo draws n (1 … 10 000)
    std::uint64_t seed = 1;     ///< the draws' seed (as SurfaceDrawOptions::seed)
    double step = 0;            ///< spacing of the points sampled on the mesh, world units (> 0)
    double iso = 0.5;           ///< u: inside where φ > u
    double openingRatio = 6.0;  ///< the draws' Barnes–Hut β (SurfaceDrawOptions::openingRatio)
};

struct CollisionResult {
    double probability = 0;    ///< the fraction of draws in which the mesh meets the inside
    double standardError = 0;  ///< √(p (1 − p) / n)
    std::size_t points = 0;    ///< points sampled on the mesh
    double largestInside = 0;  ///< the largest P(φ > u) over those points, one point at a time (a lower bound on p)
};

/// Points on a triangle mesh: its vertices, and the points of a lattice of spacing ≤ step on each triangle (its
/// edges included). Throws ParameterError on a step ≤ 0 or more than 1e8 points.
std::vector<Vec3d> meshSamplePoints(const std::vector<Vec3d>& vertices, const std::vector<std::array<int, 3>>& triangles, double step);
/// An upper bound on meshSamplePoints' size (it counts the three corners of each triangle's lattice, which are the
/// vertices), without making the points; the same errors.
std::size_t meshSamplePointCount(const std::vector<Vec3d>& vertices, const std::vector<std::array<int, 3>>& triangles, double step);

/// P(the mesh meets {φ > u}) by Monte Carlo over draws of the input's noise (docs/uncertainty.md).
/// \param model      the winding model of `samples`: γ at the mesh's points
/// \param samples    its samples: J ε of each draw from their tree
/// \param s          the model's smoothing, world units
/// \param vertices   the mesh's vertices, world units
/// \param triangles  its triangles, as indices into `vertices`
/// \param options    draws, seed, the points' spacing on the mesh, the iso-value u, the draws' Barnes–Hut β
/// \param progress   reports the draws done; its interrupt stops them (Cancelled)
/// \return the probability, its standard error, the points sampled and the largest single-point P(φ > u)
/// \throws ParameterError on bad options or too many points on the mesh; InputError on an empty mesh, a vertex that
///         is not finite or a triangle naming a missing vertex; Cancelled when interrupted
/// \par Complexity
///   P points on the mesh (meshSamplePointCount); each draw evaluates J ε at them, O(P log n) over n samples: O(draws
///   · P log n) in all. Memory O(P) beside the samples' tree.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Each draw depends on its seed and index alone, so the result
///   is the same for any thread count.
CollisionResult collisionProbability(const GpisModel& model, const Samples& samples, double s, const std::vector<Vec3d>& vertices,
                                     const std::vector<std::array<int, 3>>& triangles, const CollisionOptions& options,
                                     const Progress& progress = {});

}  // namespace gpisvdb
