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

namespace {

/// Selling's algorithm in dimension D over the D + 1 vectors of a superbase: flip while some pair is not obtuse,
/// then one term per pair, λ_ij = −⟨b_i, T b_j⟩ with the pair's offset. `flip(b, i, j)` and `offset(b, i, j)`
/// carry what depends on the dimension.
template <int D, class Result, class Flip, class Offset>
Result decompose(const Eigen::Matrix<double, D, D>& T, const SellingOptions& options, Flip flip, Offset offset) {
    using IVec = Eigen::Matrix<int, D, 1>;
    std::array<IVec, D + 1> b;
    for (int i = 0; i < D; ++i) b[std::size_t(i)] = IVec::Unit(i);
    b[D] = -IVec::Ones();
    auto dot = [&](int i, int j) { return b[std::size_t(i)].template cast<double>().dot(T * b[std::size_t(j)].template cast<double>()); };
    Result out;
    bool obtuse = false;
    while (!obtuse && out.flips < options.maxFlips) {
        obtuse = true;
        for (int i = 0; i <= D && obtuse; ++i)
            for (int j = i + 1; j <= D && obtuse; ++j)
                if (dot(i, j) > 0) {
                    flip(b, i, j);
                    ++out.flips;
                    obtuse = false;
                }
    }
    out.capped = !obtuse;
    const double drop = options.dropRelative * kEps * std::abs(T.trace());
    for (int i = 0; i <= D; ++i)
        for (int j = i + 1; j <= D; ++j) {
            const double lambda = -exactDot<D>(b[std::size_t(i)], T, b[std::size_t(j)]);
            if (!(lambda > drop)) continue;
            out.weight[std::size_t(out.count)] = lambda;
            out.offset[std::size_t(out.count)] = offset(b, i, j);
            ++out.count;
        }
    return out;
}

}  // namespace

Selling3 selling(const Mat3d& T, const SellingOptions& options) {
    using B = std::array<Eigen::Vector3i, 4>;
    // (b_i, b_j, b_k, b_l) → (−b_i, b_j, b_k + b_i, b_l + b_i); e_ij = b_k × b_l
    auto flip = [](B& b, int i, int j) {
        for (int k = 0; k < 4; ++k)
            if (k != i && k != j) b[std::size_t(k)] += b[std::size_t(i)];
        b[std::size_t(i)] = -b[std::size_t(i)];
    };
    auto offset = [](const B& b, int i, int j) {
        int k = 0;
        while (k == i || k == j) ++k;
        int l = k + 1;
        while (l == i || l == j) ++l;
        return Eigen::Vector3i(b[std::size_t(k)].cross(b[std::size_t(l)]));
    };
    return decompose<3, Selling3>(T, options, flip, offset);
}

Selling2 selling(const Eigen::Matrix2d& T, const SellingOptions& options) {
    using B = std::array<Eigen::Vector2i, 3>;
    // (b_i, b_j, b_k) → (−b_i, b_j, b_i − b_j); e_ij = b_k rotated by 90°
    auto flip = [](B& b, int i, int j) {
        b[std::size_t(3 - i - j)] = b[std::size_t(i)] - b[std::size_t(j)];
        b[std::size_t(i)] = -b[std::size_t(i)];
    };
    auto offset = [](const B& b, int i, int j) {
        const Eigen::Vector2i& k = b[std::size_t(3 - i - j)];
        return Eigen::Vector2i(-k.y(), k.x());
    };
    return decompose<2, Selling2>(T, options, flip, offset);
}

}  // namespace gpisvdb
