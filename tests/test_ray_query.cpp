// Ray queries: the first hit's distribution along a ray (docs/uncertainty.md#ray-queries), against Monte Carlo over
// draws of the same GPIS.
#include <catch2/catch.hpp>
#include <cmath>

#include "cli_run.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/input/triangle_soup.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/tasks/plausible_surfaces.h"
#include "gpisvdb/tasks/ray_query.h"
#include "helpers.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

using namespace gpisvdb;

namespace {

/// The first hit of each of n draws along the ray's points t_j: 0 when the draw is inside at the origin, the
/// linear interpolation of its first up-crossing of u otherwise, NaN without one.
std::vector<double> drawnHits(const GpisModel& model, const SurfaceDraws& draws, const Ray& ray, double step, double u) {
    const std::vector<double> t = rayParameters(ray, step);
    const Vec3d d = ray.direction.normalized();
    const int n = draws.count();
    std::vector<double> hit(std::size_t(n), NAN);
    std::vector<double> previous(std::size_t(n), 0.0);
    for (std::size_t j = 0; j < t.size(); ++j) {
        const Vec3d x = ray.origin + t[j] * d;
        const double gamma = model.evaluate(x).mean[0];
        const std::vector<double> e = draws.perturbation(x);
        for (int k = 0; k < n; ++k) {
            const double phi = gamma + e[std::size_t(k)] - u;
            if (std::isnan(hit[k]) && phi > 0) hit[k] = j == 0 ? 0.0 : t[j - 1] + (t[j] - t[j - 1]) * previous[k] / (previous[k] - phi);
            previous[k] = phi;
        }
        bool all = true;
        for (double h : hit) all = all && !std::isnan(h);
        if (all) break;
    }
    return hit;
}

struct Sampled {
    double hit = 0, hitError = 0, expected = NAN, expectedError = NAN, stddev = NAN;
};

Sampled summary(const std::vector<double>& hits) {
    Sampled s;
    double count = 0, sum = 0, sum2 = 0;
    for (double h : hits)
        if (!std::isnan(h)) count += 1, sum += h, sum2 += h * h;
    const double n = double(hits.size());
    s.hit = count / n;
    s.hitError = std::sqrt(std::max(s.hit * (1 - s.hit), 1.0 / n) / n);
    if (count > 1) {
        s.expected = sum / count;
        s.stddev = std::sqrt(std::max(sum2 / count - s.expected * s.expected, 0.0));
        s.expectedError = s.stddev / std::sqrt(count);
    }
    return s;
}

struct Case {
    const char* name;
    Ray ray;
};

void compareWithDraws(const GpisModel& model, const Samples& samples, double s, const std::vector<Case>& cases, double hitTolerance,
                      double distanceTolerance) {
    RayQueryOptions o;
    o.step = s / 4;
    SurfaceDrawOptions drawOptions;
    drawOptions.count = 1000;
    drawOptions.seed = 3;
    const SurfaceDraws draws(samples, s, drawOptions);
    std::vector<Ray> rays;
    for (const Case& c : cases) rays.push_back(c.ray);
    const std::vector<RayHit> hits = queryRays(model, rays, o);
    for (std::size_t i = 0; i < cases.size(); ++i) {
        const Sampled mc = summary(drawnHits(model, draws, cases[i].ray, o.step, o.iso));
        const RayHit& h = hits[i];
        INFO(cases[i].name << ": P(hit) " << h.hit << " against " << mc.hit << " +- " << mc.hitError << "; E[T | hit] " << h.expected
                           << " against " << mc.expected << " +- " << mc.expectedError << "; std " << h.stddev << " against " << mc.stddev);
        CHECK(std::abs(h.hit - mc.hit) <= 3 * mc.hitError + hitTolerance);
        if (mc.hit > 0.2) {
            CHECK(std::abs(h.expected - mc.expected) <= 3 * mc.expectedError + distanceTolerance);
            CHECK(std::abs(h.stddev - mc.stddev) <= 0.25 * mc.stddev + distanceTolerance);
        }
    }
}

}  // namespace

TEST_CASE("ray query: the first hit's probability and distance match Monte Carlo over draws on a sphere", "[rays]") {
    const SoupSamples ss = soupSamples(icosphere(2), {1.0});
    const double s = 0.4 * ss.samples.lengthScale;
    const DirectGpis model(ss.samples, s);
    compareWithDraws(model, ss.samples, s,
                     {{"radial, from outside", {Vec3d(0, 0, 2.5), Vec3d(0, 0, -1), 2.5}},
                      {"from the centre outward (inside at the origin)", {Vec3d(0, 0, 0), Vec3d(0, 0, 1), 2.0}},
                      {"grazing at height 0.9", {Vec3d(-2.5, 0, 0.9), Vec3d(1, 0, 0), 5.0}},
                      {"grazing at height 1.0", {Vec3d(-2.5, 0.1, 1.0), Vec3d(1, 0, 0), 5.0}},
                      {"passing at height 1.6", {Vec3d(-2.5, 0, 1.6), Vec3d(1, 0, 0), 5.0}}},
                     0.03, 0.02);
}

TEST_CASE("ray query: the first hit's probability and distance match Monte Carlo over draws on the bunny", "[rays]") {
    const InputData data = readInput(test::dataPath("bunny.obj"));
    const SoupSamples ss = soupSamples(*data.soup, {1.0});
    const double s = 0.4 * ss.samples.lengthScale;
    const BarnesHutGpis model(ss.samples, s);
    compareWithDraws(model, ss.samples, s,
                     {{"down onto the back", {Vec3d(0.5, 12, 0), Vec3d(0, -1, 0), 8}},
                      {"across the ears", {Vec3d(-6, 8, 0), Vec3d(1, 0, 0), 12}},
                      {"into the side", {Vec3d(0, 3, 8), Vec3d(0, 0, -1), 8}}},
                     0.03, 0.05);
}

TEST_CASE("ray query: certain rays, the profile and bad rays", "[rays]") {
    const SoupSamples ss = soupSamples(icosphere(2), {0.5});
    const double s = 0.4 * ss.samples.lengthScale;
    const DirectGpis model(ss.samples, s);
    RayQueryOptions o;
    o.step = s / 4;
    const Ray radial{Vec3d(0, 0, 3), Vec3d(0, 0, -2), 3};  // the direction's length does not matter
    const RayProfile p = rayProfile(model, radial, o);
    REQUIRE(p.t.size() == p.survival.size());
    CHECK(p.t.back() == 3.0);
    for (std::size_t j = 1; j < p.survival.size(); ++j) CHECK(p.survival[j] <= p.survival[j - 1]);
    const RayHit h = queryRays(model, {radial}, o).front();
    CHECK(h.hit == Approx(1).margin(1e-9));
    CHECK(h.expected == Approx(2).margin(0.1));  // the soup's sphere, inscribed in the unit sphere
    CHECK(h.hit == Approx(1 - p.survival.back()));
    const RayHit away = queryRays(model, {{Vec3d(0, 0, 3), Vec3d(0, 0, 1), 3}}, o).front();
    CHECK(away.hit < 1e-9);
    CHECK_THROWS_AS(queryRays(model, {{Vec3d(0, 0, 3), Vec3d(0, 0, 0), 1}}, o), ParameterError);
    CHECK_THROWS_AS(queryRays(model, {{Vec3d(0, 0, NAN), Vec3d(0, 0, 1), 1}}, o), ParameterError);
    CHECK_THROWS_AS(queryRays(model, {{Vec3d(0, 0, 3), Vec3d(0, 0, 1), 0}}, o), ParameterError);
    RayQueryOptions tiny = o;
    tiny.step = 1e-9;
    CHECK_THROWS_AS(queryRays(model, {radial}, tiny), ParameterError);
}

TEST_CASE("ray query: the query command answers rays, points and a mesh as the engine does, and refuses bad input", "[rays][cli]") {
    namespace fs = std::filesystem;
    using namespace test::cli;
    const std::string bunny = test::dataPath("bunny.obj"), csv = temp("query.csv"), json = temp("query.json");
    const std::string rays = temp("query_rays.csv", "# ox oy oz dx dy dz length\n0.5,12,0,0,-1,0,8\n-6 8 0 1 0 0 12\n0,0,30,0,0,1,5\n");
    REQUIRE(run("query " + bunny + " --sigma 1 --rays " + rays + " -o " + csv + " --report " + json + " --quiet").code == 0);
    const std::string text = fileText(csv);
    CHECK(text.rfind("ox,oy,oz,dx,dy,dz,length,p_inside_origin,p_hit,hit_distance,hit_distance_std\n", 0) == 0);
    // The engine's answer on the same model and step
    const InputData data = readInput(bunny);
    const SoupSamples ss = soupSamples(*data.soup, {1.0});
    const double s = 0.4 * ss.samples.lengthScale;
    const BarnesHutGpis model(ss.samples, s);
    RayQueryOptions o;
    o.step = s / 4;
    const auto hits = queryRays(model, {{Vec3d(0.5, 12, 0), Vec3d(0, -1, 0), 8}, {Vec3d(-6, 8, 0), Vec3d(1, 0, 0), 12}}, o);
    std::istringstream rows(text);
    std::string line;
    std::getline(rows, line);
    for (int i = 0; i < 3; ++i) {
        REQUIRE(std::getline(rows, line));
        std::vector<double> v;
        std::istringstream cells(line);
        for (std::string cell; std::getline(cells, cell, ',');) v.push_back(std::strtod(cell.c_str(), nullptr));
        REQUIRE(v.size() == 11);
        if (i < 2) {
            CHECK(v[8] == Approx(hits[std::size_t(i)].hit).margin(1e-6));
            CHECK(v[9] == Approx(hits[std::size_t(i)].expected).margin(1e-4));
        } else {
            CHECK(v[8] < 1e-9);       // a ray far above the bunny, pointing away
            CHECK(std::isnan(v[9]));  // no hit: no distance
        }
    }
    CHECK(nlohmann::json::parse(std::ifstream(json))["query"]["rays"] == 3);
    // Points: the same P(inside) as evaluate's last column
    const std::string points = temp("query_points.xyz", "0 5 0\n0.5 6 1\n0 20 0\n");
    REQUIRE(run("query " + bunny + " --points " + points + " -o " + csv + " --quiet").code == 0);
    CHECK(fileText(csv).rfind("x,y,z,p_inside,gamma,stddev\n", 0) == 0);
    // A mesh: a small triangle inside the body always collides
    const std::string tri = temp("query_tri.obj", "v -0.2 4 0\nv 0.2 4 0\nv 0 4.3 0\nf 1 2 3\n");
    REQUIRE(run("query " + bunny + " --mesh " + tri + " --draws 50 -o " + csv + " --quiet").code == 0);
    CHECK_THAT(fileText(csv), Catch::Contains("points,p_collision,standard_error,largest_point_p_inside\n"));
    CHECK_THAT(fileText(csv), Catch::Contains(",1,0,"));
    // Refused: one line, exit 1, no output
    const std::string bad = temp("query_bad.csv");
    for (const std::string& args :
         {"--rays " + temp("q_short.csv", "0 0 0 1 0 0\n"), "--rays " + temp("q_zero.csv", "0 0 0 0 0 0 1\n"),
          "--rays " + temp("q_nan.csv", "0 0 nan 1 0 0 1\n"), "--points " + temp("q_empty.xyz", "# none\n"), "--rays " + rays + " --step 0",
          "--mesh " + tri + " --draws 0", "--mesh " + points, "--mesh " + tri + " --model regression", std::string("")}) {
        INFO(args);
        fs::remove(bad);
        const Run e = run("query " + bunny + " " + args + " -o " + bad);
        CHECK(e.code == 1);
        CHECK(lines(e.err) == 1);
        CHECK_FALSE(leftovers(bad));
    }
}
