#pragma once
// A GPIS model: at any point x, Z(x) = (φ(x), ∇φ(x)) is Gaussian with a mean in R⁴ and a 4×4 covariance
// (paper Eq. 5, 7; docs/math.md#gpis). Every task takes a GpisModel and nothing else of the input.
#include <memory>
#include <vector>

#include "gpisvdb/core/progress.h"
#include "gpisvdb/core/types.h"

namespace gpisvdb {

struct ValueGradient {
    Vec4d mean = Vec4d::Zero();  ///< (γ, ∂xγ, ∂yγ, ∂zγ); gradient in world units⁻¹
    Mat4d cov = Mat4d::Zero();   ///< covariance of (φ, ∂xφ, ∂yφ, ∂zφ)
};

/// The scale in which a model's mean γ is about linear in the distance across its surface (kacrice/kac_rice_column.h).
enum class MeanScale {
    Linear,  ///< γ itself (a regression on signed values)
    Probit,  ///< Φ⁻¹(γ): the winding number's γ ≈ Φ(−d/s), a probability of being inside
};

class GpisModel {
public:
    virtual ~GpisModel() = default;
    /// Mean and covariance at x (world units).
    virtual ValueGradient evaluate(const Vec3d& x) const = 0;
    /// Batch evaluation, parallel over points with TBB; results do not depend on the thread count.
    virtual std::vector<ValueGradient> evaluate(const std::vector<Vec3d>& xs, const Progress& progress = {}) const;
    /// Points that fill space densely (a band's voxels): a model may share work between neighbours, so results may
    /// differ from evaluate(xs)'s within the model's documented error; each still depends on its point alone, never on
    /// the batch or the thread count. By default evaluate(xs).
    virtual std::vector<ValueGradient> evaluateDense(const std::vector<Vec3d>& xs, const Progress& progress = {}) const {
        return evaluate(xs, progress);
    }
    /// Bytes that evaluateDense will keep, beyond what it holds now, while it evaluates a band near the samples: an
    /// estimate, for the band's memory estimate (docs/memory.md#band). By default none.
    virtual double expectedDenseCacheBytes() const { return 0; }
    /// The level u of the surface φ = u in this model's convention: 1/2 for the winding number (1 inside, 0 outside).
    virtual double naturalIso() const { return 0.5; }
    /// The scale in which γ is about linear across the surface. By default Linear.
    virtual MeanScale meanScale() const { return MeanScale::Linear; }
};

}  // namespace gpisvdb
