// The spectrum of the GPIS Laplacian (tasks/spectrum.h).
#include <catch2/catch.hpp>
#include <cmath>

#include "band_fixtures.h"
#include "gpisvdb/tasks/spectrum.h"

using namespace gpisvdb;

TEST_CASE("spectrum: unit sphere at low sigma follows l(l+1) above the ground mode, multiplicities 1, 3, 5, ...", "[spectrum]") {
    // u ≈ g(across) Y_lm(along): λ ≈ λ_0 + l(l+1)/r², λ_0 the ground energy of the profile across the band
    // (u = 0 outside it), r the mean surface's radius. So the second to fourth λ are nearly equal and
    // (λ − λ_0) runs 2 : 6 : 12 : 20 : 30 over groups of 3, 5, 7, 9, 11 (docs/spectrum.md).
    const Band band = test::bandOf(icosphere(3), 0.5, 0.04);
    EigenOptions o;
    o.count = 36;
    const EigenResult r = spectrum(band, o);
    const Eigen::VectorXd& l = r.values;
    const double area = massVector(band).sum();
    const double r2 = area / (4 * M_PI);  // the radius² of a sphere of the band's expected area
    INFO("lambda_0 = " << l(0) << ", lambda_1 - lambda_0 = " << l(1) - l(0) << ", 2/r^2 = " << 2 / r2);
    CHECK(l(1) - l(0) == Approx(2 / r2).epsilon(0.03));
    int first = 1;
    for (int degree = 1; degree <= 5; ++degree) {
        const int size = 2 * degree + 1;
        const int last = first + size - 1;
        INFO("l = " << degree << ": lambda " << first << " ... " << last);
        const double ratio = (l(first) - l(0)) / (l(1) - l(0));
        CHECK(ratio == Approx(degree * (degree + 1) / 2.0).epsilon(0.03));
        // A group: its spread is small against the gap to its neighbours (the grid splits it a little).
        const double spread = l(last) - l(first);
        CHECK(spread < 0.1 * (l(first) - l(first - 1)));
        if (last + 1 < o.count) CHECK(spread < 0.1 * (l(last + 1) - l(last)));
        first = last + 1;
    }
}

TEST_CASE("spectrum: the ground mode is positive, smooth across the band and one-signed", "[spectrum]") {
    const Band& band = test::sphereBand();
    EigenOptions o;
    o.count = 1;
    const EigenResult r = spectrum(band, o);
    CHECK(r.values(0) > 0);
    // Courant: the first Dirichlet eigenvector does not change sign (up to solver round-off).
    CHECK(r.vectors.col(0).minCoeff() > -1e-8 * r.vectors.col(0).maxCoeff());
}

TEST_CASE("spectrum: an empty band is refused", "[spectrum]") {
    Band empty;
    CHECK_THROWS_AS(spectrum(empty), InputError);
}
