#pragma once
// Where a ray first meets the uncertain surface (docs/uncertainty.md#ray-queries).
//
// Along x(t) = o + t d (‖d‖ = 1, 0 ≤ t ≤ L), φ(t) and its derivative v(t) = d·∇φ are jointly Gaussian at every t
// (the model's mean and covariance of (φ, ∇φ)). The ray is inside where φ > u; it "hits" the surface where it first
// enters the inside (an origin inside is a hit at t = 0). Rice's formula gives the rate of entries (up-crossings of
// u) at t:
//   ρ⁺(t) = p_φ(u) E[v⁺ | φ = u],
// and an entry at t needs the ray outside just before, so the rate of first hits among rays still outside is
// λ(t) = ρ⁺(t) / P(φ(t) < u) (exact for the first entry where the sign of φ − u forgets its past, the sign's Markov
// approximation). The probability of no hit up to t is then
//   S(t) = P(φ(0) < u) · exp(−∫₀ᵗ λ),
// integrated by the trapezoid rule at steps of `step`. Tested against Monte Carlo over draws of the GPIS
// (tasks/plausible_surfaces.h).
#include <cstddef>
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/core/types.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

struct Ray {
    Vec3d origin = Vec3d::Zero();      ///< world units
    Vec3d direction = Vec3d::UnitZ();  ///< any length > 0; normalised
    double length = 0;                 ///< L, world units (> 0)
};

struct RayQueryOptions {
    double iso = 0.5;  ///< u: the surface φ = u, inside where φ > u (the model's naturalIso())
    double step = 0;   ///< Δ, world units (> 0): the spacing of the points evaluated along each ray
};

struct RayHit {
    double insideAtOrigin = 0;  ///< P(φ(0) > u)
    double hit = 0;             ///< P(a hit within [0, L]) = 1 − S(L), the origin's inside included
    double expected = 0;        ///< E[T | hit], world units (NaN when hit = 0)
    double stddev = 0;          ///< std of T given a hit, world units (NaN when hit = 0)
};

/// The first-hit distribution along each ray (docs/uncertainty.md#ray-queries). The no-hit probability is kept at
/// most P(φ(t) < u) at every point (a step that jumps over an entry lands inside).
/// \param model     the GPIS (either model), world units
/// \param rays      origins, directions and lengths, world units
/// \param options   the iso-value u and the step Δ between the points evaluated along each ray
/// \param progress  reports the rays done; its interrupt stops the query (Cancelled)
/// \return one RayHit per ray, in order
/// \throws ParameterError on a ray of zero direction, a non-finite value, a length ≤ 0 or a step ≤ 0, and when one
///         ray would need more than 1e6 points or all of them more than 1e8 (before any evaluation); Cancelled when
///         interrupted
/// \par Complexity
///   P = Σ (⌈L/Δ⌉ + 1) points, each one evaluation of (φ, ∇φ) and their covariance: O(log n) with Barnes–Hut over n
///   samples. Rays are evaluated in batches of whole rays of about 2^18 points: memory O(2^18 + the longest ray).
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel over the points (the model's batch evaluation); the
///   result is the same for any thread count.
std::vector<RayHit> queryRays(const GpisModel& model, const std::vector<Ray>& rays, const RayQueryOptions& options,
                              const Progress& progress = {});

/// One ray's no-hit probability S(t_j) at t_j = j Δ (the last point at L): the curve behind its RayHit.
struct RayProfile {
    std::vector<double> t;         ///< world units
    std::vector<double> survival;  ///< S(t_j) = P(no hit in [0, t_j])
};
RayProfile rayProfile(const GpisModel& model, const Ray& ray, const RayQueryOptions& options);

/// The points t_j along a ray at which queryRays evaluates the model: 0, Δ, 2Δ, …, L.
std::vector<double> rayParameters(const Ray& ray, double step);
/// Their number, ⌈L / Δ⌉ + 1, counted without making them. Throws ParameterError (as queryRays) on a bad ray or
/// step, and on more than 1e6 points on one ray (a ray's points are evaluated at once).
std::size_t rayPointCount(const Ray& ray, double step);

}  // namespace gpisvdb
