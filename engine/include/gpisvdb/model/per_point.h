#pragma once
// The reference path for batched models: a batch evaluated one point at a time through another model's
// evaluate(x) (GpisModel's plain parallel loop). Tests and benchmarks compare BarnesHutGpis's packets against it.
#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

class PerPointModel final : public GpisModel {
public:
    /// `model` must outlive this object.
    explicit PerPointModel(const GpisModel& model) : model_(model) {}
    using GpisModel::evaluate;
    ValueGradient evaluate(const Vec3d& x) const override { return model_.evaluate(x); }
    double naturalIso() const override { return model_.naturalIso(); }
    MeanScale meanScale() const override { return model_.meanScale(); }

private:
    const GpisModel& model_;
};

}  // namespace gpisvdb
