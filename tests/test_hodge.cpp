#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/first_order.h"
#include "gpisvdb/tasks/hodge.h"

using namespace gpisvdb;
using test::dot;
using test::randomField;

namespace {

double sNorm(const Band& band, const std::vector<float>& v) { return std::sqrt(sInnerProduct(band, v, v)); }

/// A smooth function on the band that vanishes towards its boundary (so that G ψ has no Dirichlet jump).
std::vector<float> smoothPotential(const Band& band) {
    std::vector<float> f(band.size());
    for (std::size_t i = 0; i < band.size(); ++i) {
        const openvdb::Coord& k = band.coord[i];
        const double x = band.voxelSize * k.x(), z = band.voxelSize * k.z();
        f[i] = float((x + 0.5 * z * z) * band.mu[i] / (band.mu[i] + 1.0));
    }
    return f;
}

}  // namespace

TEST_CASE("hodge: the parts sum to the field, the free part is mu-divergence-free and S-orthogonal") {
    const Band& band = test::sphereBand();
    const std::vector<float> V = randomField(3 * band.size(), 7);
    HodgeOptions o;
    o.solver.tolerance = 1e-6;
    const HodgeResult r = hodgeDecomposition(band, V, o);
    REQUIRE(r.solver.converged);
    for (std::size_t k = 0; k < V.size(); ++k) CHECK(r.gradient[k] + r.free[k] == Approx(V[k]).margin(1e-6));
    // M D_φ V_free is the solve's residual, up to float rounding of the parts.
    CHECK(r.divergenceResidual <= 10 * o.solver.tolerance);
    CHECK(std::abs(r.sInnerProduct) < 1e-4);
    CHECK(std::abs(r.sInnerProduct) == Approx(std::abs(sInnerProduct(band, r.gradient, r.free)) /
                                              (sNorm(band, r.gradient) * sNorm(band, r.free))).epsilon(1e-9));
    // Not orthogonal in the Euclidean inner product: the S weighting is what makes the projection orthogonal.
    const double euclid = dot(r.gradient, r.free) / std::sqrt(dot(r.gradient, r.gradient) * dot(r.free, r.free));
    CHECK(std::abs(euclid) > 100 * std::abs(r.sInnerProduct));
}

TEST_CASE("hodge: a discrete GPIS gradient has no free part") {
    const Band& band = test::sphereBand();
    const std::vector<float> psi = smoothPotential(band);
    HodgeOptions o;
    o.boundary = GENERATE(Boundary::Neumann, Boundary::Dirichlet);
    o.solver.tolerance = 1e-8;
    std::vector<float> V;
    gradPhi(band, psi, V, o.boundary);
    const HodgeResult r = hodgeDecomposition(band, V, o);
    CHECK(sNorm(band, r.free) < 1e-3 * sNorm(band, V));
    if (o.boundary == Boundary::Dirichlet) {  // K is definite: the potential itself is recovered
        double err = 0, ref = 0;
        for (std::size_t i = 0; i < band.size(); ++i) {
            err = std::max(err, double(std::abs(r.potential[i] - psi[i])));
            ref = std::max(ref, double(std::abs(psi[i])));
        }
        CHECK(err < 1e-3 * ref);
    }
}

TEST_CASE("hodge: the rotation's gradient part and the height gradient's free part shrink with h") {
    double rot[2], grad[2];
    const double hs[2] = {0.08, 0.04};
    for (int k = 0; k < 2; ++k) {
        const Band band = test::bandOf(icosphere(2), 1.0, hs[k]);
        const std::vector<float> R = hodgePreset(band, HodgePreset::Rotation), H = hodgePreset(band, HodgePreset::Gradient);
        rot[k] = sNorm(band, hodgeDecomposition(band, R).gradient) / sNorm(band, R);
        grad[k] = sNorm(band, hodgeDecomposition(band, H).free) / sNorm(band, H);
    }
    INFO("rotation |V_grad|/|V|: " << rot[0] << " -> " << rot[1] << "; height |V_free|/|V|: " << grad[0] << " -> " << grad[1]);
    CHECK(rot[1] < 0.7 * rot[0]);
    CHECK(grad[1] < 0.7 * grad[0]);
}

TEST_CASE("hodge: with Neumann boundaries the height gradient stays a gradient, with Dirichlet it does not") {
    // ψ = z does not vanish at the band's boundary: Dirichlet must bend it to 0 across the thin band.
    const Band& band = test::sphereBand();
    const std::vector<float> H = hodgePreset(band, HodgePreset::Gradient), R = hodgePreset(band, HodgePreset::Rotation);
    HodgeOptions neumann, dirichlet;
    dirichlet.boundary = Boundary::Dirichlet;
    const HodgeResult n = hodgeDecomposition(band, H, neumann), d = hodgeDecomposition(band, H, dirichlet);
    const double freeN = sNorm(band, n.free) / sNorm(band, H), freeD = sNorm(band, d.free) / sNorm(band, H);
    INFO("height gradient |V_free|_S / |V|_S: Neumann " << freeN << ", Dirichlet " << freeD);
    CHECK(freeN < 0.1);
    CHECK(freeD > 4 * freeN);
    // Mixed = rotation + gradient, and the decomposition is linear.
    const HodgeResult rot = hodgeDecomposition(band, R, neumann);
    const HodgeResult mixed = hodgeDecomposition(band, hodgePreset(band, HodgePreset::Mixed), neumann);
    const double scale = test::maxAbs(mixed.gradient);
    for (std::size_t k = 0; k < mixed.gradient.size(); k += 97)
        CHECK(mixed.gradient[k] == Approx(rot.gradient[k] + n.gradient[k]).margin(1e-4 * scale));
}

TEST_CASE("hodge: results do not depend on the thread count") {
    const Band& band = test::sphereBand();
    const std::vector<float> V = hodgePreset(band, HodgePreset::Mixed);
    HodgeResult one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = hodgeDecomposition(band, V);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = hodgeDecomposition(band, V);
    }
    CHECK(one.free == two.free);
    CHECK(one.solver.iterations == two.solver.iterations);
}

TEST_CASE("hodge: a field of the wrong length or with NaN is refused") {
    const Band& band = test::sphereBand();
    CHECK_THROWS_AS(hodgeDecomposition(band, std::vector<float>(band.size())), Error);
    std::vector<float> V(3 * band.size(), 1.0f);
    V[5] = std::nanf("");
    CHECK_THROWS_AS(hodgeDecomposition(band, V), InputError);
}

TEST_CASE("hodge: a zero field splits into zeros") {
    const Band& band = test::sphereBand();
    const HodgeResult r = hodgeDecomposition(band, std::vector<float>(3 * band.size(), 0.0f));
    CHECK(r.solver.converged);
    CHECK(test::maxAbs(r.free) == 0);
    CHECK(r.divergenceResidual == 0);
}
