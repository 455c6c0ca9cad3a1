#include "gpisvdb/model/kernel.h"

#include <cmath>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {
constexpr double kSwitchAR = 2.0;  // series below a·r = 2: terms (a²t)^m/m! stay ≤ 4^m/m!, no cancellation
constexpr int kSeriesTerms = RegularizedKernel::kSeriesTerms;
constexpr double kFarAR = 8.0;  // beyond a·r = 8, erf = 1 and exp(−a²r²)·(ar)^8 < 1e-20: pure Newton terms

}  // namespace

const RegularizedKernel::Series& RegularizedKernel::series() {
    static const Series table = [] {
        Series s;
        for (int m = 0; m < kSeriesTerms; ++m) {
            for (int k = 0; k < 5; ++k) s.inverse[m][k] = 1.0 / double(2 * m + 2 * k + 1);
            s.next[m] = 1.0 / double(m + 1);
        }
        return s;
    }();
    return table;
}

RegularizedKernel::RegularizedKernel(double s) : s_(s) {
    if (!(s > 0) || !std::isfinite(s)) throw ParameterError("smoothing length s must be finite and > 0 (got " + std::to_string(s) + ")");
    a_ = 1.0 / (std::sqrt(2.0) * s);
    a2_ = a_ * a_;
    c_ = 2.0 * a_ / std::sqrt(M_PI);
    tSwitch_ = (kSwitchAR / a_) * (kSwitchAR / a_);
    tFar_ = (kFarAR / a_) * (kFarAR / a_);
}

RadialDerivatives RegularizedKernel::at(double t) const {
    RadialDerivatives F;
    if (t < tSwitch_) {
        // === Series: G^(k)(t) = c Σ_m (−a²)^(m+k) t^m / (m! (2m+2k+1))
        const Series& series = RegularizedKernel::series();
        double sum[5] = {0, 0, 0, 0, 0};
        double term = 1.0;  // (−a² t)^m / m!
        const double x = -a2_ * t;
        for (int m = 0; m < kSeriesTerms; ++m) {
            for (int k = 0; k < 5; ++k) sum[k] += term * series.inverse[m][k];
            term *= x / double(m + 1);
        }
        double scale = c_;  // c (−a²)^k 2^k
        double* out[5] = {&F.F0, &F.F1, &F.F2, &F.F3, &F.F4};
        for (int k = 0; k < 5; ++k) {
            *out[k] = scale * sum[k];
            scale *= -2.0 * a2_;
        }
        return F;
    }
    // === Closed forms: F_k = c_k erf(ar) r^-(2k+1) + g P_k(r), g = (2a/√π) exp(−a²r²),
    // c_{k+1} = −(2k+1) c_k, P_{k+1} = c_k r^-(2k+2) − 2a² P_k + P_k′/r.
    const double r = std::sqrt(t);
    const bool far = t > tFar_;
    const double E = far ? 1.0 : std::erf(a_ * r);
    const double g = far ? 0.0 : c_ * std::exp(-a2_ * t);
    const double u = 1.0 / t;  // r^-2
    const double a2 = a2_, a4 = a2 * a2, a6 = a4 * a2;
    const double ir = 1.0 / r;
    F.F0 = E * ir;
    F.F1 = -E * ir * u + g * u;
    F.F2 = 3.0 * E * ir * u * u - g * (3.0 * u * u + 2.0 * a2 * u);
    F.F3 = -15.0 * E * ir * u * u * u + g * (15.0 * u * u * u + 10.0 * a2 * u * u + 4.0 * a4 * u);
    F.F4 = 105.0 * E * ir * u * u * u * u - g * (105.0 * u * u * u * u + 70.0 * a2 * u * u * u + 28.0 * a4 * u * u + 8.0 * a6 * u);
    return F;
}

Mat3d RegularizedKernel::hessian(const RadialDerivatives& F, const Vec3d& y) {
    Mat3d H = F.F2 * (y * y.transpose());
    H.diagonal().array() += F.F1;
    return H;
}

Mat3d RegularizedKernel::thirdContracted(const RadialDerivatives& F, const Vec3d& y, const Vec3d& w) {
    const double yw = y.dot(w);
    Mat3d D = F.F2 * (y * w.transpose() + w * y.transpose()) + (F.F3 * yw) * (y * y.transpose());
    D.diagonal().array() += F.F2 * yw;
    return D;
}

}  // namespace gpisvdb
