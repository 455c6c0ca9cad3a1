#pragma once
// The regression-based GPIS (paper App. F, Sec. 3.2; Williams & Fitzgibbon 2006): φ is a Gaussian process with a
// constant prior mean m₀ and the covariance k(x, x') = a ρ_s(x − x') / ρ_s(0) — the same regularized Newton kernel
// as the winding-number model (paper Eq. 6), positive definite in 3-D (its Fourier transform is
// 4π e^{−s²|ξ|²/2} / |ξ|²) — conditioned on labelled samples: +1 inside, 0 on the surface, −1 outside.
// The value/gradient pair at x is jointly Gaussian with the block kernel k^∇ = [[k, ∇ₓ'kᵀ], [∇ₓk, ∇ₓ∇ₓ'k]]:
//   mean  = (m₀, 0) + Bᵀ K⁻¹ (y − m₀),        B = [k(xᵢ, x), ∇ₓ k(x, xᵢ)]ᵢ  (n × 4)
//   cov   = k^∇(x, x) − Bᵀ K⁻¹ B,            K = [k(xᵢ, xⱼ)] + diag(noiseᵢ²),
// with k^∇(x, x) = diag(a, −a F₁(0)/F₀(0) I) (F₁ = ρ′/r < 0, see kernel.h). The prior mean is the outside label, so far from
// the samples φ → −1, away from the surface level 0, and the band stays near the data; inside a closed sample shell
// the kernel's harmonic far field keeps φ near +1.
// Surface level: φ = 0 (naturalIso). Cost: O(n³) to build, O(n²) per query point (4 triangular solves, batched).
#include <cstddef>
#include <string>
#include <vector>

#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/gpis_model.h"
#include "gpisvdb/model/kernel.h"

namespace gpisvdb {

/// Labelled training points: +1 inside, 0 on the surface, −1 outside (any real label is accepted).
struct LabelledPoints {
    std::vector<Vec3d> position;  ///< world units
    std::vector<double> label;
    std::vector<double> noise;  ///< std of each label (≥ 0); empty: RegressionGpisOptions::labelNoise for all
    std::size_t size() const { return position.size(); }
};

struct TrainingOptions {
    std::size_t surfacePoints = 300;  ///< surface samples kept (farthest-point subsampling of the input), each giving 3 labels
    double offsetRelative = 0.5;      ///< inside/outside offset along the normal, relative to the training spacing √(A/n)
};

/// From oriented samples: n surface points chosen by farthest-point sampling (deterministic, starting at sample 0),
/// each labelled 0, with p − δ n̂ labelled +1 and p + δ n̂ labelled −1 (n̂ the outward unit normal, δ = offset ×
/// √(A / n), A = Σ|wᵢ|). `spacing`, when given, receives √(A / n).
LabelledPoints trainingFromSamples(const Samples& samples, const TrainingOptions& options = {}, double* spacing = nullptr);

/// A CSV of x,y,z,label[,noise] rows (the format of readPointData). Throws InputError.
LabelledPoints readLabelledPoints(const std::string& path);

struct RegressionGpisOptions {
    double smoothing = 0;         ///< s of the kernel ρ_s, world units (> 0)
    double amplitude = 1.0 / 16;  ///< prior variance a = k(x, x), label units² (> 0): std 1/4 of the label step, so that far
                                  ///< from the samples φ ≥ 0 is a 4σ event and μ there falls ~1e-5 below its surface value
    double labelNoise = 0.05;     ///< std of the labels when the points carry none, label units (≥ 0; > 0 keeps K well conditioned)
    double priorMean = -1;        ///< m₀: the value far from every sample (the outside label)
};

class RegressionGpis final : public GpisModel {
public:
    /// Factors K once (O(n³)). Throws ParameterError for bad options, InputError for no or non-finite points,
    /// Error when K is not positive definite (duplicate points with zero noise).
    RegressionGpis(LabelledPoints training, const RegressionGpisOptions& options);
    ~RegressionGpis() override;
    using GpisModel::evaluate;
    ValueGradient evaluate(const Vec3d& x) const override;
    /// Batched: blocks of points share one triangular solve; blocks are fixed by index, so results do not depend on
    /// the thread count.
    std::vector<ValueGradient> evaluate(const std::vector<Vec3d>& xs, const Progress& progress = {}) const override;
    double naturalIso() const override { return 0.0; }
    std::size_t trainingSize() const;
    /// Bytes held (the Cholesky factor dominates: 8 n²).
    std::size_t memoryBytes() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace gpisvdb
