#include "gpisvdb/model/load_model.h"

#include <algorithm>
#include <cmath>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/model/direct_gpis.h"

namespace gpisvdb {

double medianPositionStd(const Samples& samples) {
    std::vector<double> v(samples.positionVariance);
    if (v.empty()) return 0.0;
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return std::sqrt(std::max(0.0, v[v.size() / 2]));
}

LoadedModel loadModel(const InputData& data, const ModelOptions& options) {
    if (!(options.smoothingRel > 0) || !std::isfinite(options.smoothingRel))
        throw ParameterError("the kernel smoothing (ModelOptions::smoothingRel) must be finite and > 0 (got " +
                                 numberText(options.smoothingRel) + ")",
                             {"ModelOptions::smoothingRel"});
    LoadedModel m;
    if (!(options.noiseSmoothing >= 0) || !std::isfinite(options.noiseSmoothing))
        throw ParameterError("the noise smoothing factor (ModelOptions::noiseSmoothing) must be finite and >= 0 (got " +
                                 numberText(options.noiseSmoothing) + ")",
                             {"ModelOptions::noiseSmoothing"});
    m.input = makeSamples(data, {options.sigmaRel});
    m.smoothing = options.smoothingRel * m.input.samples.lengthScale;
    // === s follows a cloud's own noise where its points are denser than it (docs/math.md#smoothing)
    const double fromNoise = options.noiseSmoothing * medianPositionStd(m.input.samples);
    if (options.kind == ModelKind::Winding && m.input.absoluteNoise && fromNoise > m.smoothing)
        m.smoothing = fromNoise, m.smoothingSource = SmoothingSource::Noise;
    if (options.kind == ModelKind::Regression) {
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
    } else if (options.exact) {
        m.model = std::make_unique<DirectGpis>(m.input.samples, m.smoothing);
    } else {
        m.model = std::make_unique<BarnesHutGpis>(m.input.samples, m.smoothing, options.barnesHut);
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
    if (options.exact) m.model = std::make_unique<DirectGpis>(m.input.samples, s);
    else m.model = std::make_unique<BarnesHutGpis>(m.input.samples, s, options.barnesHut);
    return m;
}

}  // namespace gpisvdb
