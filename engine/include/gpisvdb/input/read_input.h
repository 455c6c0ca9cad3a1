#pragma once
// Reading inputs from files. Soups: OBJ, OFF, PLY (with faces), STL. Clouds: XYZ (x y z nx ny nz [sigma]),
// PLY (no faces; nx ny nz, optional sigma), VTP (Normals point data, optional sigma array; polygons make it a soup),
// GDP (Gaussian dipoles with their covariances, gdp.h: a cloud with its own noise).
#include <optional>
#include <string>
#include <vector>

#include "gpisvdb/input/point_cloud.h"
#include "gpisvdb/input/triangle_soup.h"

namespace gpisvdb {

/// The most samples (triangles of a mesh, points of a cloud) an input may hold: 1e8. The model alone would need
/// tens of GB beyond it; readers refuse a file whose header declares more vertices, faces or points before
/// reading its body, and readInput and makeSamples refuse more triangles or points.
constexpr std::size_t kMaxInputSamples = 100000000;

struct InputData {
    std::string path;
    std::optional<TriangleSoup> soup;      ///< set for meshes
    std::optional<PointCloud> cloud;       ///< set for point clouds
    std::size_t polygonsTriangulated = 0;  ///< polygons with > 3 corners fan-triangulated
};

/// Reads a file by its extension (case-insensitive): a soup or a cloud, as the file holds.
/// \param path  the file: .obj .off .ply .stl .vtp (soups; .ply and .vtp without faces are clouds), .xyz, .gdp
/// \return the soup or the cloud, positions in the file's (world) units
/// \throws InputError with the file name and, where it applies, the line, on a missing file, unknown extension, empty
///         content, malformed content, non-finite numbers, out-of-range face indices, a cloud without normals, or more
///         than kMaxInputSamples samples
/// \par Complexity
///   O(size of the file) time and the input's own memory (a header that declares more than kMaxInputSamples is
///   refused before the body is read).
/// \par Thread safety
///   Reads only the file: concurrent calls are safe. One thread.
InputData readInput(const std::string& path);

struct NoiseOptions {
    double sigmaRel = kDefaultSigmaRel;  ///< σ relative to ℓ (> 0)
};

struct InputSamples {
    Samples samples;
    double sigma = 0;                   ///< absolute σ (world units)
    std::size_t degenerateSkipped = 0;  ///< zero-area triangles left out
    bool isSoup = false;
    bool absoluteNoise = false;     ///< a cloud with its own σ per point (world units), not σ = sigmaRel·ℓ
    bool lengthScaleGiven = false;  ///< ℓ came with the input (a .gdp written by gpisvdb), not from its geometry
    bool normalsFlipped = false;    ///< the input's normals pointed inward and were flipped (loadModel,
                                    ///< ModelOptions::orientOutward; docs/math.md#orientation)
};

/// Samples of either kind of input with its noise model (docs/math.md#samples): a soup's triangles (App. B's noise
/// from the vertices' σ), or a cloud's points with their areas (given, or estimated from the spacing) and their own σ
/// or σ = sigmaRel·ℓ.
/// \param input    a soup or a cloud (readInput), world units
/// \param options  σ relative to ℓ, where the input gives none of its own
/// \return the samples, ℓ (world units), the absolute σ and what was skipped
/// \throws ParameterError for sigmaRel ≤ 0 or not finite; InputError for an empty input, only zero-area triangles,
///         or more than kMaxInputSamples samples
/// \par Complexity
///   O(n log n) for n samples (a cloud's areas: a k-d tree and a k-nearest search per point); 104 B per sample
///   (samplesBytes) and, for a cloud, cloudSamplingBytes while the areas are estimated.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel inside (TBB); the samples are the same for any
///   thread count.
InputSamples makeSamples(const InputData& input, const NoiseOptions& options = {});

/// What makeSamples(input) allocates at its peak, bytes by part, counted from the input's size before it allocates
/// (docs/memory.md#info): a sample per triangle or point (samplesBytes) and, for a cloud, cloudSamplingBytes.
std::vector<std::pair<std::string, double>> makeSamplesBytes(const InputData& input);

}  // namespace gpisvdb
