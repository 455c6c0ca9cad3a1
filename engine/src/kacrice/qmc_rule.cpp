#include "gpisvdb/kacrice/qmc_rule.h"

#include <algorithm>
#include <boost/math/special_functions/erf.hpp>
#include <cmath>
#include <cstdint>
#include <string>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr int kBits = 32;

/// Direction numbers v_k = m_k 2^(32−k) of one Sobol dimension from its primitive polynomial (degree s,
/// coefficients a) and initial m_1..m_s (Bratley–Fox recurrence).
std::vector<std::uint32_t> directions(int s, std::uint32_t a, std::vector<std::uint32_t> m) {
    for (int k = s; k < kBits; ++k) {
        std::uint32_t next = m[k - s] ^ (m[k - s] << s);
        for (int j = 1; j < s; ++j)
            if ((a >> (s - 1 - j)) & 1u) next ^= m[k - j] << j;
        m.push_back(next);
    }
    std::vector<std::uint32_t> v(kBits);
    for (int k = 0; k < kBits; ++k) v[k] = m[k] << (kBits - 1 - k);
    return v;
}

}  // namespace

QmcRule::QmcRule(int samples) {
    if (samples < 1 || samples > (1 << 24))
        throw ParameterError(
            "the QMC point count S (BandOptions::qmcSamples) must be in [1, 16777216] (got " + std::to_string(samples) + ")",
            {"BandOptions::qmcSamples"});
    // Dimension 1: van der Corput; 2: x + 1; 3: x² + x + 1 (Joe–Kuo: s = 2, a = 1, m = 1, 3).
    const std::vector<std::uint32_t> dirs[3] = {{}, directions(1, 0, {1}), directions(2, 1, {1, 3})};
    std::vector<std::uint32_t> v0(kBits);
    for (int k = 0; k < kBits; ++k) v0[k] = 1u << (kBits - 1 - k);
    int pow2 = 1;
    while (pow2 < samples) pow2 *= 2;
    const double shift = 0.5 / pow2;  // cell centres: never 0, never 1
    points_.reserve(std::size_t(samples));
    for (std::uint32_t i = 0; i < std::uint32_t(samples); ++i) {
        std::uint32_t x[3] = {0, 0, 0};
        for (int k = 0; k < kBits; ++k)
            if ((i >> k) & 1u) {
                x[0] ^= v0[k];
                x[1] ^= dirs[1][k];
                x[2] ^= dirs[2][k];
            }
        Vec3d z;
        for (int d = 0; d < 3; ++d) {
            const double u = double(x[d]) / 4294967296.0 + shift;
            z[d] = std::sqrt(2.0) * boost::math::erf_inv(2.0 * u - 1.0);
        }
        points_.push_back(z);
    }
    const std::size_t padded = (points_.size() + 7) / 8 * 8;
    for (int d = 0; d < 3; ++d) {
        coordinate_[d].assign(padded, 0.0);
        for (std::size_t i = 0; i < points_.size(); ++i) coordinate_[d][i] = points_[i][d];
    }
    weight_.assign(padded, 0.0);
    std::fill(weight_.begin(), weight_.begin() + long(points_.size()), 1.0);
}

}  // namespace gpisvdb
