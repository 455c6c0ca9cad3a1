#pragma once
// The voxel size (paper Eq. 25; docs/math.md#resolution): h* = λ_res / max_i w(p_i), w the Selling stencil width of T at the
// samples; since Eq. 25 alone can under-resolve μ, the default is min(h*, w_μ/2) with w_μ = median √c₀₀/‖∇γ‖
// over the samples (μ's width across the surface).
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

struct ResolutionOptions {
    double iso = 0.5;              ///< iso-value u
    int qmcSamples = 512;          ///< S for T at the samples
    double resolutionScale = 1.0;  ///< λ_res = resolutionScale·ℓ (> 0)
    double maxAnisotropy = 20;     ///< as BandOptions::maxAnisotropy
};

struct Resolution {
    double hStar = 0;        ///< Eq. 25, world units
    double muWidth = 0;      ///< w_μ, world units
    double h = 0;            ///< min(h*, w_μ/2), world units
    int maxStencilL1 = 0;    ///< max_i w(p_i)
};

Resolution chooseResolution(const GpisModel& model, const Samples& samples, const ResolutionOptions& options = {},
                            const Progress& progress = {});

/// T with its anisotropy √(λmax/λmin) capped at `maxAnisotropy` by adding a multiple of I; `changed` tells.
Mat3d regularise(const Mat3d& T, double maxAnisotropy, bool& changed);

}  // namespace gpisvdb
