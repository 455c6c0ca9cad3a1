#pragma once
// A GPIS model from an input, with the parameters every front end shares (the command line, the Python module):
// σ and the kernel smoothing s relative to the input's length scale ℓ, and the choice of model (Barnes–Hut or direct
// sums of the winding-number GPIS, or the regression GPIS of App. F). docs/model.md.
#include <cstddef>
#include <memory>
#include <optional>
#include <utility>

#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/gpis_model.h"
#include "gpisvdb/model/regression_gpis.h"

namespace gpisvdb {

enum class ModelKind {
    Winding,     ///< the linearised winding number (paper Eq. 5), surface at φ = 1/2
    Regression,  ///< GP regression on labels (App. F), surface at φ = 0
};

/// The default ModelOptions::noiseSmoothing: with s ≥ 1.2 σ_p a sphere cloud's expected area stays within 1.2 % from 1e4
/// to 1e6 points at a fixed noise in world units, where s = 0.4 ℓ alone gave 14.1 and 24.5 at 1e4 and 1e5 against
/// 4π (docs/math.md#smoothing, docs/benchmarks.md#coarse-voxels).
constexpr double kNoiseSmoothing = 1.2;
/// The default ModelOptions::smoothingRel: s = 0.4 ℓ (docs/math.md#smoothing).
constexpr double kDefaultSmoothingRel = 0.4;

/// The default ModelOptions::mergeRel: cells of width s (docs/math.md#merging).
constexpr double kDefaultMergeRel = 1.0;

struct ModelOptions {
    double sigmaRel = kDefaultSigmaRel;          ///< vertex/point noise std σ relative to ℓ (> 0)
    double smoothingRel = kDefaultSmoothingRel;  ///< kernel smoothing s relative to ℓ (regression: to the training spacing) (> 0)
    /// Winding model of a cloud with its own σ per point (InputSamples::absoluteNoise): s is at least this × σ_p, the
    /// samples' median position std (world units), so that s follows the noise where the points are denser than it
    /// (≥ 0; 0: s = smoothingRel·ℓ alone). Where σ = sigmaRel·ℓ, s/σ is fixed by the two. docs/math.md#smoothing.
    double noiseSmoothing = kNoiseSmoothing;
    /// Winding model: where the samples are denser than the kernel (s > ℓ), they are merged into one Gaussian dipole per
    /// cubic cell of width mergeRel·s (world lattice) before the model is built (mergeSamples; ≥ 0; 0: never).
    /// docs/math.md#merging.
    double mergeRel = kDefaultMergeRel;
    ModelKind kind = ModelKind::Winding;
    bool exact = false;                                      ///< winding: direct O(n) sums instead of Barnes–Hut
    BarnesHutOptions barnesHut;                              ///< winding, not exact: the tree's accuracy
    TrainingOptions training;                                ///< regression: labels generated from the input (when `labels` is empty)
    std::optional<LabelledPoints> labels;                    ///< regression: the training labels; empty: generated from the input
    double labelNoise = RegressionGpisOptions{}.labelNoise;  ///< regression: std of the labels (≥ 0)
    /// Flip the input's normals when they point inward: the winding number's median at the samples is −1/2 there
    /// instead of +1/2, and the default surface γ = 1/2 would not exist (docs/math.md#orientation).
    bool orientOutward = true;
};

/// Which term set a winding model's s (docs/math.md#smoothing).
enum class SmoothingSource {
    LengthScale,  ///< smoothingRel·ℓ
    Noise,        ///< noiseSmoothing·σ_p
    VoxelSize,    ///< kVoxelSmoothing·h, for a band of voxel values (band/default_band.h)
};
const char* smoothingSourceName(SmoothingSource source);  ///< "length scale", "noise", "voxel size"

struct LoadedModel {
    InputSamples input;
    double smoothing = 0;  ///< absolute s, world units
    SmoothingSource smoothingSource = SmoothingSource::LengthScale;
    std::size_t trainingSize = 0;  ///< labelled points of the regression model (0: winding model)
    std::size_t modelSamples = 0;  ///< winding model: the samples or merged dipoles it sums (ModelOptions::mergeRel)
    std::unique_ptr<GpisModel> model;
};

/// Whether the winding model of smoothing s (world units) merges the samples (ModelOptions::mergeRel > 0 and s > ℓ).
/// Throws ParameterError when mergeRel is negative or not finite.
bool mergesSamples(const Samples& samples, double s, const ModelOptions& options);

/// σ_p: the median over the samples of their position std √v_i, world units.
double medianPositionStd(const Samples& samples);

/// A winding model's smoothing s (world units) and what set it: smoothingRel·ℓ, or noiseSmoothing·σ_p where that is
/// larger and the input gives its own σ per point (docs/math.md#smoothing). What loadModel uses; `gpisvdb info` says it.
std::pair<double, SmoothingSource> windingSmoothing(const InputSamples& input, const ModelOptions& options);

/// The median of a winding model's mean γ at up to kOrientationSamples of the samples (every k-th): +1/2 where the
/// samples' normals point outward, −1/2 where they point inward (docs/math.md#orientation).
double medianGammaAtSamples(const GpisModel& winding, const Samples& samples);
constexpr std::size_t kOrientationSamples = 1024;
/// What the front ends say when loadModel flipped the normals.
constexpr const char* kNormalsFlippedNote =
    "the input's normals point inward (the winding number is about -1/2 at its samples): flipped, so that the surface "
    "is gamma = 1/2 and the inside is the side they enclose (docs/math.md#orientation)";

/// The input's samples with σ = sigmaRel·ℓ, their normals flipped if they point inward (orientOutward), then the model
/// (winding: s = smoothingRel·ℓ, or noiseSmoothing·σ_p where that is larger and the cloud gives its own σ; the samples
/// merged into dipoles where s > ℓ, mergeRel).
/// \param data     a soup or a cloud (readInput), world units
/// \param options  σ, s, merging, the kind of model and its accuracy (relative values as ModelOptions says)
/// \return the samples as read (normals flipped if they were), s (world units) and what set it, and the model
/// \throws ParameterError naming the ModelOptions (or the noise options') field on a bad parameter; InputError on
///         unusable input (makeSamples)
/// \par Complexity
///   makeSamples' O(n log n), then the Barnes–Hut tree's O(m log m) over the m ≤ n samples or dipoles it sums (twice
///   where the normals are flipped); the regression model: its training's O(t³) for t labels. Memory: the samples
///   and one tree (barnes_hut_gpis.h's memoryBytes).
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel inside (TBB); the model is the same for any thread
///   count.
LoadedModel loadModel(const InputData& data, const ModelOptions& options = {});

/// The same samples in a winding model (as options.exact asks) of another smoothing, for a band of voxel values.
/// \param model    a loaded model: its samples are reused (copied), its own model is not
/// \param options  the model's options (exact, accuracy, merging)
/// \param s        the new smoothing, world units (> 0)
/// \param source   what set s, for the report
/// \return the samples with a new winding model of smoothing s (merged where s > ℓ)
/// \throws ParameterError for s ≤ 0 or not finite, or a bad mergeRel
/// \par Complexity
///   The tree's O(m log m) over the m samples or dipoles, and a copy of the samples.
/// \par Thread safety
///   Reads its inputs only: concurrent calls are safe. Parallel inside (TBB).
LoadedModel withSmoothing(const LoadedModel& model, const ModelOptions& options, double s, SmoothingSource source);

}  // namespace gpisvdb
