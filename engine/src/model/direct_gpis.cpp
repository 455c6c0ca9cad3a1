#include "gpisvdb/model/direct_gpis.h"

#include "contributions.h"

namespace gpisvdb {

DirectGpis::DirectGpis(Samples samples, double s) : samples_(std::move(samples)), kernel_(s) {}

ValueGradient DirectGpis::evaluate(const Vec3d& x) const {
    ValueGradient out;
    for (std::size_t i = 0; i < samples_.size(); ++i) {
        const Vec3d y = x - samples_.position[i];
        const RadialDerivatives F = kernel_.at(y.squaredNorm());
        detail::addMean(F, y, samples_.normal[i], out.mean);
        detail::addPositionNoise(F, y, samples_.normal[i], samples_.positionVariance[i], out.cov);
        detail::addNormalNoise(F, y, samples_.normalCovariance[i].matrix(), out.cov);
    }
    detail::finish(out);
    return out;
}

}  // namespace gpisvdb
