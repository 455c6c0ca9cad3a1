#pragma once
// The voxel size (paper Eq. 25; docs/math.md#resolution): h* = λ_res / max_i w(p_i), w the Selling stencil width of T at the
// samples; since Eq. 25 alone can under-resolve μ at small σ, the default is min(h*, c·k·w_μ) with w_μ = median
// √c₀₀/‖∇γ‖ over the samples (μ's width across the surface), c the resolution scale and k = kMuWidthFactor,
// the coarsest factor measured that keeps mass, energy, spectrum and geodesic paths within their documented
// errors (bench/bench_resolution.cpp; docs/benchmarks.md#default-voxel-size). Pictures of μ need c ≈ 0.6.
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

/// k in the default h = min(h*, c·k·w_μ) (docs/math.md#resolution).
constexpr double kMuWidthFactor = 1.25;

struct ResolutionOptions {
    double iso = 0.5;              ///< iso-value u
    int qmcSamples = 512;          ///< S for T at the samples
    double resolutionScale = 1.0;  ///< c (> 0): λ_res = c·ℓ, and the default h scales with c (c < 1: finer)
    double maxAnisotropy = 20;     ///< as BandOptions::maxAnisotropy
    double etaRelative = 0.01;     ///< as BandOptions::etaRelative, for bandArea and bandWidth
    /// The model is evaluated at every sample up to this many, and at every k-th beyond (k = ⌈n / maxSamples⌉): w_μ is
    /// a median and the cross-section a sum scaled to all the samples' area, both within 1 % of every sample's (tested);
    /// max w(p_i) is the subsample's (0: every sample). A 1e6-point scan spent 34 s here at every sample.
    std::size_t maxSamples = 200000;
};

struct Resolution {
    double hStar = 0;      ///< Eq. 25 with λ_res = c·ℓ, world units
    double muWidth = 0;    ///< w_μ, world units (not scaled by c)
    double h = 0;          ///< the default voxel size min(h*, c·kMuWidthFactor·w_μ), world units
    int maxStencilL1 = 0;  ///< max_i w(p_i)
    /// The band's expected cross-section, Σ_i a_i·t_i (world units³; a_i the samples' areas ‖w_i‖): t_i the width
    /// across the surface where μ > η at sample i, 2 w_i √(2 ln(μ̂_i / η)), with w_i = √c₀₀/‖∇γ‖ at the sample, μ̂_i
    /// the peak of μ along its normal (μ at the sample raised by its offset (γ − u)/‖∇γ‖ from the mean surface) and
    /// η = etaRelative × the median μ at the samples. The band holds about (bandVolume + area·h)/h³ voxels.
    double bandVolume = 0;
    double area = 0;  ///< Σ_i a_i, world units²
};

Resolution chooseResolution(const GpisModel& model, const Samples& samples, const ResolutionOptions& options = {},
                            const Progress& progress = {});

/// T with its anisotropy √(λmax/λmin) capped at `maxAnisotropy` by adding a multiple of I; `changed` tells.
Mat3d regularise(const Mat3d& T, double maxAnisotropy, bool& changed);

}  // namespace gpisvdb
