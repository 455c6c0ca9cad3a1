#include "gpisvdb/model/load_model.h"

#include <cmath>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/model/direct_gpis.h"

namespace gpisvdb {

LoadedModel loadModel(const InputData& data, const ModelOptions& options) {
    if (!(options.smoothingRel > 0) || !std::isfinite(options.smoothingRel))
        throw ParameterError("the kernel smoothing (ModelOptions::smoothingRel) must be finite and > 0 (got " +
                                 numberText(options.smoothingRel) + ")",
                             {"ModelOptions::smoothingRel"});
    LoadedModel m;
    m.input = makeSamples(data, {options.sigmaRel});
    m.smoothing = options.smoothingRel * m.input.samples.lengthScale;
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

}  // namespace gpisvdb
