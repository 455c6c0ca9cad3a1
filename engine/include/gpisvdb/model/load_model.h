#pragma once
// A GPIS model from an input, with the parameters every front end shares (the command line, the Python module):
// σ and the kernel smoothing s relative to the input's length scale ℓ, and the choice of model (Barnes–Hut or direct
// sums of the winding-number GPIS, or the regression GPIS of App. F). docs/model.md.
#include <cstddef>
#include <memory>
#include <optional>

#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/gpis_model.h"
#include "gpisvdb/model/regression_gpis.h"

namespace gpisvdb {

enum class ModelKind {
    Winding,     ///< the linearised winding number (paper Eq. 5), surface at φ = 1/2
    Regression,  ///< GP regression on labels (App. F), surface at φ = 0
};

struct ModelOptions {
    double sigmaRel = 0.5;      ///< vertex/point noise std σ relative to ℓ (> 0)
    double smoothingRel = 0.4;  ///< kernel smoothing s relative to ℓ (regression: to the training spacing) (> 0)
    ModelKind kind = ModelKind::Winding;
    bool exact = false;                ///< winding: direct O(n) sums instead of Barnes–Hut
    BarnesHutOptions barnesHut;        ///< winding, not exact: the tree's accuracy
    TrainingOptions training;          ///< regression: labels generated from the input (when `labels` is empty)
    std::optional<LabelledPoints> labels;  ///< regression: the training labels; empty: generated from the input
    double labelNoise = RegressionGpisOptions{}.labelNoise;  ///< regression: std of the labels (≥ 0)
};

struct LoadedModel {
    InputSamples input;
    double smoothing = 0;          ///< absolute s, world units
    std::size_t trainingSize = 0;  ///< labelled points of the regression model (0: winding model)
    std::unique_ptr<GpisModel> model;
};

/// The input's samples with σ = sigmaRel·ℓ, then the model. Throws ParameterError naming the ModelOptions (or the
/// noise options') field on a bad parameter, InputError on unusable input.
LoadedModel loadModel(const InputData& data, const ModelOptions& options = {});

}  // namespace gpisvdb
