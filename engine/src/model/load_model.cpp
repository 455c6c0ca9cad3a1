#include "gpisvdb/model/load_model.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <tuple>
#include <vector>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/model/merge_samples.h"

namespace gpisvdb {

double medianPositionStd(const Samples& samples) {
    std::vector<double> v(samples.positionVariance);
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return std::sqrt(std::max(0.0, v[v.size() / 2]));
}

double medianGammaAtSamples(const GpisModel& winding, const Samples& samples) {
    const std::size_t n = samples.size(), step = std::max<std::size_t>(1, (n + kOrientationSamples - 1) / kOrientationSamples);
    std::vector<Vec3d> xs;
    for (std::size_t i = 0; i < n; i += step) xs.push_back(samples.position[i]);
    if (xs.empty()) return 0.0;
    const std::vector<ValueGradient> values = winding.evaluate(xs);
    std::vector<double> gamma(values.size());
    for (std::size_t i = 0; i < values.size(); ++i) gamma[i] = values[i].mean[0];
    std::nth_element(gamma.begin(), gamma.begin() + long(gamma.size() / 2), gamma.end());
    return gamma[gamma.size() / 2];
}

namespace {

/// The winding model of the samples, or of their merged dipoles where they are denser than s (docs/math.md#merging);
/// `dipoles` receives the count the model holds.
std::unique_ptr<GpisModel> windingModel(const Samples& samples, double s, const ModelOptions& options, std::size_t* dipoles = nullptr) {
    const auto build = [&](const Samples& modelSamples) -> std::unique_ptr<GpisModel> {
        if (dipoles) *dipoles = modelSamples.size();
        if (options.exact) return std::make_unique<DirectGpis>(modelSamples, s);
        return std::make_unique<BarnesHutGpis>(modelSamples, s, options.barnesHut);
    };
    if (mergesSamples(samples, s, options)) return build(mergeSamples(samples, options.mergeRel * s));
    return build(samples);
}

/// Flips the normals of inward samples (medianGammaAtSamples < 0), given a winding model of them; true if it did.
/// The normals' covariance Σ' is unchanged (the noise of −w is that of w).
bool orientOutward(InputSamples& input, const GpisModel& winding) {
    if (!(medianGammaAtSamples(winding, input.samples) < 0)) return false;
    for (Vec3d& w : input.samples.normal) w = -w;
    input.normalsFlipped = true;
    return true;
}

}  // namespace

bool mergesSamples(const Samples& samples, double s, const ModelOptions& options) {
    if (!(options.mergeRel >= 0) || !std::isfinite(options.mergeRel))
        throw ParameterError("the merging cell (ModelOptions::mergeRel) must be finite and >= 0 (got " + numberText(options.mergeRel) + ")",
                             {"ModelOptions::mergeRel"});
    return options.mergeRel > 0 && s > samples.lengthScale;
}

std::pair<double, SmoothingSource> windingSmoothing(const InputSamples& input, const ModelOptions& options) {
    const double fromLength = options.smoothingRel * input.samples.lengthScale;
    // === s follows a cloud's own noise where its points are denser than it (docs/math.md#smoothing)
    const double fromNoise = input.absoluteNoise ? options.noiseSmoothing * medianPositionStd(input.samples) : 0;
    if (fromNoise > fromLength) return {fromNoise, SmoothingSource::Noise};
    return {fromLength, SmoothingSource::LengthScale};
}

LoadedModel loadModel(const InputData& data, const ModelOptions& options) {
    if (!(options.smoothingRel > 0) || !std::isfinite(options.smoothingRel))
        throw ParameterError(
            "the kernel smoothing (ModelOptions::smoothingRel) must be finite and > 0 (got " + numberText(options.smoothingRel) + ")",
            {"ModelOptions::smoothingRel"});
    LoadedModel m;
    if (!(options.noiseSmoothing >= 0) || !std::isfinite(options.noiseSmoothing))
        throw ParameterError("the noise smoothing factor (ModelOptions::noiseSmoothing) must be finite and >= 0 (got " +
                                 numberText(options.noiseSmoothing) + ")",
                             {"ModelOptions::noiseSmoothing"});
    m.input = makeSamples(data, {options.sigmaRel});
    m.smoothing = options.smoothingRel * m.input.samples.lengthScale;
    if (options.kind == ModelKind::Winding) std::tie(m.smoothing, m.smoothingSource) = windingSmoothing(m.input, options);
    if (options.kind == ModelKind::Regression) {
        // === Orientation: the generated labels' inside and outside follow the normals
        if (options.orientOutward && !options.labels) orientOutward(m.input, *windingModel(m.input.samples, m.smoothing, options));
        // Labels generated from the samples, or given; the kernel smoothing relative to the training spacing, as
        // the winding model's is to ℓ.
        double spacing = 0;
        LabelledPoints training = trainingFromSamples(m.input.samples, options.training, &spacing);
        if (options.labels) training = *options.labels;
        RegressionGpisOptions ro;
        ro.smoothing = options.smoothingRel * spacing;
        ro.labelNoise = options.labelNoise;
        m.smoothing = ro.smoothing;
        m.trainingSize = training.size();
        m.model = std::make_unique<RegressionGpis>(std::move(training), ro);
    } else {
        m.model = windingModel(m.input.samples, m.smoothing, options, &m.modelSamples);
        // === Orientation: inward normals flipped, the model built again on them (docs/math.md#orientation); the
        //     first tree is freed before the second is built, so the peak is one tree's
        if (options.orientOutward && orientOutward(m.input, *m.model)) {
            m.model.reset();
            m.model = windingModel(m.input.samples, m.smoothing, options, &m.modelSamples);
        }
    }
    return m;
}

const char* smoothingSourceName(SmoothingSource source) {
    switch (source) {
        case SmoothingSource::Noise: return "noise";
        case SmoothingSource::VoxelSize: return "voxel size";
        default: return "length scale";
    }
}

LoadedModel withSmoothing(const LoadedModel& model, const ModelOptions& options, double s, SmoothingSource source) {
    if (!(s > 0) || !std::isfinite(s)) throw ParameterError("the kernel smoothing must be finite and > 0 (got " + numberText(s) + ")");
    LoadedModel m;
    m.input = model.input;
    m.smoothing = s;
    m.smoothingSource = source;
    m.model = windingModel(m.input.samples, s, options, &m.modelSamples);
    return m;
}

}  // namespace gpisvdb
