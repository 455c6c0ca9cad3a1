#pragma once
// Oriented point clouds with per-point uncertainty (docs/math.md#samples).
#include <vector>

#include "gpisvdb/core/types.h"
#include "gpisvdb/input/samples.h"

namespace gpisvdb {

struct PointCloud {
    std::vector<Vec3d> positions;           ///< world units
    std::vector<Vec3d> normals;             ///< any length > 0; normalised when sampled
    std::vector<double> sigmas;             ///< optional per-point position std (world units); empty = use sigmaRel
    std::vector<double> areas;              ///< optional per-point area (world units²); empty = estimate
    std::vector<Sym3> normalCovariances;    ///< optional per-point Σ'_i, the covariance of the vector area a_i n_i
                                            ///< (world units⁴; a .gdp's); empty = the formula of cloudSamples
    std::vector<double> positionVariances;  ///< optional per-point σ_i² (world units²), in place of sigmas (a .gdp's,
                                            ///< kept exact)
    bool vectorAreas = false;               ///< the normals are the vector areas w_i themselves (a .gdp's), taken as they are
    double lengthScale = 0;                 ///< > 0: ℓ as given (world units; a .gdp written by gpisvdb), else √(area / points)
};

struct CloudNoiseOptions {
    double sigmaRel = kDefaultSigmaRel;  ///< default position std relative to ℓ when a point has no sigma, > 0
    int areaNeighbours = 8;              ///< k: the area estimate counts points in a cylinder of radius 2 × (k-th neighbour distance)
    int areaDoublings = 5;               ///< the cylinder's radius doubles at most this often while its points lie along a line, 0…20
    double areaIsotropy = 0.3;           ///< ... that is, while their tangent second moments' ratio (min/max) is below this, 0…1
    int areaGrowthPoints = 32;           ///< ... and while it holds at most this × k points (≥ 1): past that a cylinder that is
                                         ///< still not covered (a corner, a strip, an outlier) keeps its first area
};

struct CloudSamples {
    Samples samples;
    double sigma = 0;  ///< default absolute position std used where no per-point sigma is given
};

/// Samples of an oriented cloud: w_i = a_i n_i, Σ_i = σ_i² I and Σ'_i = a_i² τ_i² (I − n_i n_iᵀ) with the
/// normal-angle std τ_i = σ_i / √a_i (position noise over the local spacing), or the cloud's own Σ'_i, σ_i², w_i and
/// ℓ where it gives them. ℓ = √(A / N), A / N the mean of the
/// areas less the largest 1 % (docs/math.md#length-scale). Throws InputError on fewer than 2 points or a zero normal.
CloudSamples cloudSamples(const PointCloud& cloud, const CloudNoiseOptions& options = {});

/// Bytes cloudSamples holds beside the samples it makes from `points` points while it makes them: each point's area
/// and a copy of it for ℓ (16 B), the order the areas are estimated in (16 B) and the k-d tree over the points (an
/// 8 B index per point and its nodes).
double cloudSamplingBytes(std::size_t points);

}  // namespace gpisvdb
