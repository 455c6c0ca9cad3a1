#pragma once
// The reference GPIS: exact O(n) sums over all samples (docs/math.md#gpis).
#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/gpis_model.h"
#include "gpisvdb/model/kernel.h"

namespace gpisvdb {

class DirectGpis final : public GpisModel {
public:
    /// s: smoothing length of the kernel, world units (> 0). Keeps a copy of the samples.
    DirectGpis(Samples samples, double s);
    using GpisModel::evaluate;
    ValueGradient evaluate(const Vec3d& x) const override;
    MeanScale meanScale() const override { return MeanScale::Probit; }  ///< as BarnesHutGpis

private:
    Samples samples_;
    RegularizedKernel kernel_;
};

}  // namespace gpisvdb
