#include "gpisvdb/model/accuracy.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {
// Row-major upper triangle of the 4×4 covariance, in the order of the CSV columns.
constexpr int kPairs[10][2] = {{0, 0}, {0, 1}, {0, 2}, {0, 3}, {1, 1}, {1, 2}, {1, 3}, {2, 2}, {2, 3}, {3, 3}};
}  // namespace

const std::array<const char*, 14>& ModelError::names() {
    static const std::array<const char*, 14> n = {"gamma", "gx",  "gy",  "gz",  "c00", "c01", "c02",
                                                  "c03",   "c11", "c12", "c13", "c22", "c23", "c33"};
    return n;
}

double ModelError::worst() const { return *std::max_element(maxRel.begin(), maxRel.end()); }

std::string ModelError::describe() const {
    std::ostringstream ss;
    for (int q = 0; q < 14; ++q) ss << names()[q] << " " << maxRel[q] << (q < 13 ? ", " : "");
    return ss.str();
}

ModelError compareModels(const std::vector<ValueGradient>& ref, const std::vector<ValueGradient>& got) {
    if (ref.size() != got.size() || ref.empty()) throw Error("compareModels: sizes differ or are zero");
    double gradScale = 0;
    Vec4d diagScale = Vec4d::Zero();
    for (const auto& r : ref) {
        gradScale = std::max(gradScale, r.mean.tail<3>().norm());
        diagScale = diagScale.cwiseMax(r.cov.diagonal());
    }
    std::array<double, 14> scale;
    scale[0] = 1.0;
    for (int q = 1; q < 4; ++q) scale[q] = gradScale;
    for (int k = 0; k < 10; ++k) scale[4 + k] = std::sqrt(diagScale[kPairs[k][0]] * diagScale[kPairs[k][1]]);
    ModelError e;
    for (std::size_t i = 0; i < ref.size(); ++i) {
        for (int q = 0; q < 14; ++q) {
            const double d = q < 4 ? got[i].mean[q] - ref[i].mean[q]
                                   : got[i].cov(kPairs[q - 4][0], kPairs[q - 4][1]) - ref[i].cov(kPairs[q - 4][0], kPairs[q - 4][1]);
            const double rel = scale[q] > 0 ? std::abs(d) / scale[q] : std::abs(d);
            e.maxRel[q] = std::max(e.maxRel[q], rel);
            e.rmsRel[q] += rel * rel;
        }
    }
    for (double& v : e.rmsRel) v = std::sqrt(v / double(ref.size()));
    return e;
}

}  // namespace gpisvdb
