#include "gpisvdb/stencil/selling.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gpisvdb {

namespace {
constexpr double kEps = std::numeric_limits<double>::epsilon();

/// ⟨a, T b⟩ in extended precision: the weights enter the reconstruction multiplied by |e|², which grows with
/// the anisotropy, so their rounding must stay far below ε‖T‖.
template <int D>
double exactDot(const Eigen::Matrix<int, D, 1>& a, const Eigen::Matrix<double, D, D>& T, const Eigen::Matrix<int, D, 1>& b) {
    long double sum = 0;
    for (int r = 0; r < D; ++r)
        for (int c = 0; c < D; ++c) sum += static_cast<long double>(a[r]) * T(r, c) * b[c];
    return double(sum);
}
}  // namespace

int Selling3::width() const {
    int w = 0;
    for (int k = 0; k < count; ++k) w = std::max(w, offset[k].cwiseAbs().sum());
    return w;
}

Mat3d Selling3::reconstruct() const {
    Mat3d T = Mat3d::Zero();
    for (int k = 0; k < count; ++k) {
        const Vec3d e = offset[k].cast<double>();
        T += weight[k] * e * e.transpose();
    }
    return T;
}

int Selling2::width() const {
    int w = 0;
    for (int k = 0; k < count; ++k) w = std::max(w, offset[k].cwiseAbs().sum());
    return w;
}

Eigen::Matrix2d Selling2::reconstruct() const {
    Eigen::Matrix2d T = Eigen::Matrix2d::Zero();
    for (int k = 0; k < count; ++k) {
        const Eigen::Vector2d e = offset[k].cast<double>();
        T += weight[k] * e * e.transpose();
    }
    return T;
}

Selling3 selling(const Mat3d& T, const SellingOptions& options) {
    // === Obtuse superbase: flip while some ⟨b_i, T b_j⟩ > 0 (each flip lowers Σ_i ⟨b_i, T b_i⟩)
    std::array<Eigen::Vector3i, 4> b = {Eigen::Vector3i(1, 0, 0), Eigen::Vector3i(0, 1, 0), Eigen::Vector3i(0, 0, 1),
                                        Eigen::Vector3i(-1, -1, -1)};
    auto dot = [&](int i, int j) { return b[i].cast<double>().dot(T * b[j].cast<double>()); };
    static constexpr int kPairs[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2}, {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
    Selling3 out;
    bool obtuse = false;
    while (!obtuse && out.flips < options.maxFlips) {
        obtuse = true;
        for (const auto& p : kPairs) {
            const int i = p[0], j = p[1], k = p[2], l = p[3];
            if (dot(i, j) > 0) {
                b[k] += b[i];
                b[l] += b[i];
                b[i] = -b[i];
                ++out.flips;
                obtuse = false;
                break;
            }
        }
    }
    out.capped = !obtuse;
    // === λ_ij = −⟨b_i, T b_j⟩, e_ij = b_k × b_l
    const double drop = options.dropRelative * kEps * std::abs(T.trace());
    for (const auto& p : kPairs) {
        const double lambda = -exactDot<3>(b[p[0]], T, b[p[1]]);
        if (!(lambda > drop)) continue;
        out.weight[out.count] = lambda;
        out.offset[out.count] = b[p[2]].cross(b[p[3]]);
        ++out.count;
    }
    return out;
}

Selling2 selling(const Eigen::Matrix2d& T, const SellingOptions& options) {
    std::array<Eigen::Vector2i, 3> b = {Eigen::Vector2i(1, 0), Eigen::Vector2i(0, 1), Eigen::Vector2i(-1, -1)};
    auto dot = [&](int i, int j) { return b[i].cast<double>().dot(T * b[j].cast<double>()); };
    static constexpr int kPairs[3][3] = {{0, 1, 2}, {0, 2, 1}, {1, 2, 0}};
    Selling2 out;
    bool obtuse = false;
    while (!obtuse && out.flips < options.maxFlips) {
        obtuse = true;
        for (const auto& p : kPairs) {
            const int i = p[0], j = p[1], k = p[2];
            if (dot(i, j) > 0) {
                b[k] = b[i] - b[j];
                b[i] = -b[i];
                ++out.flips;
                obtuse = false;
                break;
            }
        }
    }
    out.capped = !obtuse;
    const double drop = options.dropRelative * kEps * std::abs(T.trace());
    for (const auto& p : kPairs) {
        const double lambda = -exactDot<2>(b[p[0]], T, b[p[1]]);
        if (!(lambda > drop)) continue;
        out.weight[out.count] = lambda;
        out.offset[out.count] = Eigen::Vector2i(-b[p[2]].y(), b[p[2]].x());
        ++out.count;
    }
    return out;
}

}  // namespace gpisvdb
