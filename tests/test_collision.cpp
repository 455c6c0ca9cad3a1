// Mesh collision: P(a mesh meets the inside of the GPIS) by Monte Carlo over draws (docs/uncertainty.md#mesh-collision).
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/triangle_soup.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/output/occupancy.h"
#include "gpisvdb/tasks/collision.h"
#include "gpisvdb/tasks/plausible_surfaces.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

struct Sphere {
    SoupSamples ss = soupSamples(icosphere(2), {1.0});
    double s = 0.4 * ss.samples.lengthScale;
    DirectGpis model{ss.samples, s};
};

/// A triangle of circumradius r around c, in the plane z = c.z.
std::vector<Vec3d> triangleAt(const Vec3d& c, double r) {
    return {c + r * Vec3d(1, 0, 0), c + r * Vec3d(-0.5, 0.866, 0), c + r * Vec3d(-0.5, -0.866, 0)};
}

CollisionOptions options(double step, int draws = 2000) {
    CollisionOptions o;
    o.step = step;
    o.draws = draws;
    o.seed = 5;
    return o;
}

}  // namespace

TEST_CASE("collision: a mesh the size of a point collides with the point's probability of being inside", "[collision]") {
    const Sphere sphere;
    for (const double z : {0.7, 0.9, 0.97, 1.05, 1.2}) {
        const Vec3d x(0.1, 0.05, z);
        const double inside = insideProbability(sphere.model.evaluate(x), 0.5);
        const CollisionResult c =
            collisionProbability(sphere.model, sphere.ss.samples, sphere.s, triangleAt(x, 1e-5), {{0, 1, 2}}, options(1.0));
        INFO("z " << z << ": P(inside) " << inside << ", collision " << c.probability << " +- " << c.standardError);
        CHECK(c.points == 3);
        CHECK(std::abs(c.probability - inside) <= 4 * std::sqrt(std::max(inside * (1 - inside), 1e-3) / 2000));
        CHECK(c.largestInside == Approx(inside).margin(1e-4));
    }
}

TEST_CASE("collision: a triangle deep inside always collides, one far outside never, and a wide one more than its points", "[collision]") {
    const Sphere sphere;
    const std::vector<std::array<int, 3>> one = {{0, 1, 2}};
    const double step = sphere.s / 2;
    CHECK(collisionProbability(sphere.model, sphere.ss.samples, sphere.s, triangleAt(Vec3d(0, 0, 0), 0.3), one, options(step, 200))
              .probability == 1.0);
    CHECK(collisionProbability(sphere.model, sphere.ss.samples, sphere.s, triangleAt(Vec3d(0, 0, 3), 0.3), one, options(step, 200))
              .probability == 0.0);
    // A wide triangle grazing the sphere's top: it collides when any of its points is inside, more often than its
    // most exposed point alone
    const CollisionResult wide =
        collisionProbability(sphere.model, sphere.ss.samples, sphere.s, triangleAt(Vec3d(0, 0, 1.05), 0.6), one, options(step));
    INFO("collision " << wide.probability << " +- " << wide.standardError << ", largest one-point " << wide.largestInside << ", "
                      << wide.points << " points");
    CHECK(wide.probability > wide.largestInside + 3 * wide.standardError);
    CHECK(wide.probability < 1.0);
    // The chunks of draws it takes are the draws of one SurfaceDraws: the same estimate from all of them at once
    SurfaceDrawOptions all;
    all.count = 2000;
    all.seed = 5;
    const SurfaceDraws draws(sphere.ss.samples, sphere.s, all);
    const std::vector<Vec3d> points = meshSamplePoints(triangleAt(Vec3d(0, 0, 1.05), 0.6), one, step);
    std::vector<char> hit(2000, 0);
    for (const Vec3d& x : points) {
        const double gamma = sphere.model.evaluate(x).mean[0];
        const std::vector<double> e = draws.perturbation(x);
        for (std::size_t k = 0; k < hit.size(); ++k) hit[k] |= char(gamma + e[k] > 0.5);
    }
    double collided = 0;
    for (char h : hit) collided += h;
    CHECK(collided / 2000 == wide.probability);
}

TEST_CASE("collision: the sample points cover every triangle within the step", "[collision]") {
    const std::vector<Vec3d> v = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(0.2, 0.7, 0.3), Vec3d(1.5, 1.5, 0)};
    const std::vector<std::array<int, 3>> f = {{0, 1, 2}, {1, 3, 2}};
    const double step = 0.05;
    const std::vector<Vec3d> points = meshSamplePoints(v, f, step);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> U(0, 1);
    double worst = 0;
    for (int k = 0; k < 2000; ++k) {
        const auto& t = f[std::size_t(k % 2)];
        double a = U(rng), b = U(rng);
        if (a + b > 1) a = 1 - a, b = 1 - b;
        const Vec3d x =
            v[std::size_t(t[0])] + a * (v[std::size_t(t[1])] - v[std::size_t(t[0])]) + b * (v[std::size_t(t[2])] - v[std::size_t(t[0])]);
        double nearest = HUGE_VAL;
        for (const Vec3d& p : points) nearest = std::min(nearest, (p - x).norm());
        worst = std::max(worst, nearest);
    }
    CHECK(worst <= step);
    CHECK_THROWS_AS(meshSamplePoints(v, f, 0.0), ParameterError);
    CHECK_THROWS_AS(meshSamplePoints(v, f, 1e-9), ParameterError);  // more than 1e8 points
    CHECK_THROWS_AS(meshSamplePoints(v, {{0, 1, 7}}, step), InputError);
}

TEST_CASE("collision: bad options and meshes are refused", "[collision]") {
    const Sphere sphere;
    const auto tri = triangleAt(Vec3d(0, 0, 0), 0.1);
    CHECK_THROWS_AS(collisionProbability(sphere.model, sphere.ss.samples, sphere.s, tri, {{0, 1, 2}}, options(0.1, 0)), ParameterError);
    CHECK_THROWS_AS(collisionProbability(sphere.model, sphere.ss.samples, sphere.s, {}, {}, options(0.1)), InputError);
    CHECK_THROWS_AS(collisionProbability(sphere.model, sphere.ss.samples, sphere.s, {Vec3d(NAN, 0, 0)}, {}, options(0.1)), InputError);
}
