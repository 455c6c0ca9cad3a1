#pragma once
// How far one GPIS evaluation is from a reference (Barnes–Hut against the direct sum), on all 14 numbers.
//
// Norm: for each number q, error_q = max over points |got_q − ref_q| / scale_q, with the scales taken from
// the reference over the same points: γ: 1 (the winding number's jump across the surface); ∂γ: max ‖∇γ‖;
// c_ab: max √(c_aa c_bb) (the largest the entry can be, by Cauchy–Schwarz).
#include <array>
#include <string>
#include <vector>

#include "gpisvdb/model/gpis_model.h"

namespace gpisvdb {

struct ModelError {
    std::array<double, 14> maxRel{};  ///< γ, gx, gy, gz, c00, c01, c02, c03, c11, c12, c13, c22, c23, c33
    std::array<double, 14> rmsRel{};  ///< same, root mean square over the points
    double worst() const;
    std::string describe() const;
    static const std::array<const char*, 14>& names();
};

ModelError compareModels(const std::vector<ValueGradient>& reference, const std::vector<ValueGradient>& got);

}  // namespace gpisvdb
