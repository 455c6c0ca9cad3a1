#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/model/kernel.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {
// 5-point central difference of a vector-valued function of y along e_d.
template <class Fn>
auto diff(const Fn& f, const Vec3d& y, int d, double h) {
    Vec3d e = Vec3d::Zero();
    e[d] = h;
    return ((f(Vec3d(y - 2 * e)) - 8 * f(Vec3d(y - e)) + 8 * f(Vec3d(y + e)) - f(Vec3d(y + 2 * e))) / (12 * h)).eval();
}
}  // namespace

TEST_CASE("kernel: Cartesian derivatives of orders 1-3 match finite differences from 1e-4 s to 1e3 s", "[kernel]") {
    for (double s : {1e-3, 0.4, 250.0}) {
        const RegularizedKernel K(s);
        std::mt19937_64 rng(7);
        for (double rel = 1e-4; rel <= 1e3 * 1.0001; rel *= std::sqrt(10.0)) {
            const Vec3d y = rel * s * test::randomUnit(rng);
            const Vec3d w = test::randomUnit(rng);
            const double h = 1e-3 * std::max(rel * s, s);
            auto rho = [&](const Vec3d& p) { return Eigen::Matrix<double, 1, 1>(K.at(p.squaredNorm()).F0); };
            auto grad = [&](const Vec3d& p) { return Vec3d(K.at(p.squaredNorm()).F1 * p); };
            auto hessW = [&](const Vec3d& p) { return Vec3d(RegularizedKernel::hessian(K.at(p.squaredNorm()), p) * w); };
            const RadialDerivatives F = K.at(y.squaredNorm());
            Vec3d g;
            Mat3d H, D3;
            for (int d = 0; d < 3; ++d) {
                g[d] = diff(rho, y, d, h)(0);
                H.col(d) = diff(grad, y, d, h);
                D3.col(d) = diff(hessW, y, d, h);
            }
            INFO("s = " << s << ", r/s = " << rel);
            CHECK((g - F.F1 * y).norm() <= 1e-6 * g.norm());
            CHECK((H - RegularizedKernel::hessian(F, y)).norm() <= 1e-6 * H.norm());
            CHECK((D3 - RegularizedKernel::thirdContracted(F, y, w)).norm() <= 1e-6 * D3.norm());
        }
    }
}

TEST_CASE("kernel: radial recursion F_{k+1} = (1/r) dF_k/dr holds up to order 4", "[kernel]") {
    const double s = 0.7;
    const RegularizedKernel K(s);
    for (double rel = 1e-2; rel <= 1e3; rel *= 1.7) {
        const double r = rel * s, h = 1e-3 * std::max(r, s);
        auto F = [&](double rr, int k) {
            const RadialDerivatives d = K.at(rr * rr);
            const double v[5] = {d.F0, d.F1, d.F2, d.F3, d.F4};
            return v[k];
        };
        for (int k = 0; k < 4; ++k) {
            const double dFdr = (F(r - 2 * h, k) - 8 * F(r - h, k) + 8 * F(r + h, k) - F(r + 2 * h, k)) / (12 * h);
            INFO("k = " << k << ", r/s = " << rel);
            CHECK(std::abs(dFdr / r - F(r, k + 1)) <= 1e-6 * std::abs(F(r, k + 1)));
        }
    }
}

TEST_CASE("kernel: series and closed form agree where they meet", "[kernel]") {
    const double s = 1.3;
    const RegularizedKernel K(s);
    const double rSwitch = 2.0 * std::sqrt(2.0) * s;  // a·r = 2
    const RadialDerivatives below = K.at(std::pow(rSwitch * (1 - 1e-12), 2));
    const RadialDerivatives above = K.at(std::pow(rSwitch * (1 + 1e-12), 2));
    CHECK(below.F0 == Approx(above.F0).epsilon(1e-11));
    CHECK(below.F1 == Approx(above.F1).epsilon(1e-11));
    CHECK(below.F2 == Approx(above.F2).epsilon(1e-11));
    CHECK(below.F3 == Approx(above.F3).epsilon(1e-10));
    CHECK(below.F4 == Approx(above.F4).epsilon(1e-10));
}

TEST_CASE("kernel: centre value and far field are the analytic limits", "[kernel]") {
    const double s = 0.5;
    const RegularizedKernel K(s);
    // ρ(0) = √(2/π)/s; far away ρ → 1/r, ∇ρ → −y/r³.
    CHECK(K.at(0.0).F0 == Approx(std::sqrt(2.0 / M_PI) / s).epsilon(1e-14));
    const double r = 1e3 * s;
    const RadialDerivatives F = K.at(r * r);
    CHECK(F.F0 == Approx(1.0 / r).epsilon(1e-14));
    CHECK(F.F1 == Approx(-1.0 / (r * r * r)).epsilon(1e-14));
    CHECK(F.F2 == Approx(3.0 / std::pow(r, 5)).epsilon(1e-14));
}

TEST_CASE("kernel: a smoothing length <= 0 or not finite is refused", "[kernel]") {
    CHECK_THROWS_AS(RegularizedKernel(0.0), ParameterError);
    CHECK_THROWS_AS(RegularizedKernel(-1.0), ParameterError);
    CHECK_THROWS_AS(RegularizedKernel(std::nan("")), ParameterError);
}
