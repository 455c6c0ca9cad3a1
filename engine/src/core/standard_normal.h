#pragma once
// The standard normal density φ, distribution Φ and quantile Φ⁻¹, for the engine's own sources.
#include <boost/math/special_functions/erf.hpp>
#include <cmath>

namespace gpisvdb {

inline double normalPdf(double z) { return std::exp(-0.5 * z * z) * 0.3989422804014327; }
inline double normalCdf(double z) { return 0.5 * std::erfc(-z * M_SQRT1_2); }
/// Φ⁻¹(p) for p in (0, 1), by the complementary inverse on each side so that tails keep their digits.
inline double normalQuantile(double p) {
    return p < 0.5 ? -M_SQRT2 * boost::math::erfc_inv(2 * p) : M_SQRT2 * boost::math::erfc_inv(2 * (1 - p));
}

}  // namespace gpisvdb
