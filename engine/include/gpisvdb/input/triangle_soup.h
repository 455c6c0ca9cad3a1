#pragma once
// Triangle soups and the vertex-noise model of paper App. B (docs/math.md#samples).
#include <array>
#include <cstddef>
#include <vector>

#include "gpisvdb/core/types.h"
#include "gpisvdb/input/samples.h"

namespace gpisvdb {

struct TriangleSoup {
    std::vector<Vec3d> vertices;                ///< world units
    std::vector<std::array<int, 3>> triangles;  ///< vertex indices, counter-clockwise seen from outside
};

struct SoupNoiseOptions {
    double sigmaRel = kDefaultSigmaRel;  ///< vertex noise std σ relative to ℓ (σ = sigmaRel·ℓ), > 0
};

struct SoupSamples {
    Samples samples;
    std::size_t degenerateSkipped = 0;  ///< zero-area triangles left out
    double sigma = 0;                   ///< absolute vertex noise std, world units
};

/// Mean edge length of the soup's triangles (ℓ), world units.
double meanEdgeLength(const TriangleSoup& soup);

/// One sample per non-degenerate triangle: p = barycentre, w = ½ (x_v − x_u) × (x_w − x_u),
/// Σ = (σ²/3) I, Σ' = (σ²/4) Σ_e (|e|² I − e eᵀ). Throws InputError if no triangle remains.
SoupSamples soupSamples(const TriangleSoup& soup, const SoupNoiseOptions& options = {});

}  // namespace gpisvdb
