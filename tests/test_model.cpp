#include <algorithm>
#include <catch2/catch.hpp>
#include <Eigen/Geometry>
#include <limits>
#include <random>
#include <tuple>

#include <tbb/global_control.h>
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/accuracy.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/model/load_model.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

/// Ray-parity inside test against the exact mesh (independent of the GPIS), majority over 3 rays.
bool insideMesh(const TriangleSoup& m, const Vec3d& x) {
    const Vec3d dirs[3] = {Vec3d(1, 0.123, 0.377).normalized(), Vec3d(-0.31, 1, 0.2).normalized(), Vec3d(0.17, -0.29, -1).normalized()};
    int votes = 0;
    for (const Vec3d& d : dirs) {
        int hits = 0;
        for (const auto& f : m.triangles) {
            const Vec3d &a = m.vertices[f[0]], &b = m.vertices[f[1]], &c = m.vertices[f[2]];
            const Vec3d e1 = b - a, e2 = c - a, pv = d.cross(e2);
            const double det = e1.dot(pv);
            if (std::abs(det) < 1e-14) continue;
            const Vec3d tv = x - a;
            const double u = tv.dot(pv) / det;
            if (u < 0 || u > 1) continue;
            const Vec3d qv = tv.cross(e1);
            const double v = d.dot(qv) / det;
            if (v < 0 || u + v > 1) continue;
            if (e2.dot(qv) / det > 0) ++hits;
        }
        votes += hits % 2;
    }
    return votes >= 2;
}

double distanceToMesh(const TriangleSoup& m, const Vec3d& x) {
    double best = 1e300;  // distance to triangle vertices and barycentres bounds the true distance from above
    for (const auto& f : m.triangles)
        for (int k = 0; k < 3; ++k) best = std::min(best, (m.vertices[f[k]] - x).norm());
    return best;
}

void checkWindingNumber(const TriangleSoup& mesh, const char* name) {
    const SoupSamples ss = soupSamples(mesh, {0.5});
    const double ell = ss.samples.lengthScale;
    const DirectGpis model(ss.samples, 0.4 * ell);
    Vec3d lo = mesh.vertices[0], hi = lo;
    for (const auto& v : mesh.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> U(0, 1);
    int in = 0, out = 0;
    for (int tries = 0; tries < 4000 && (in < 40 || out < 40); ++tries) {
        const Vec3d pad = 0.2 * (hi - lo);
        const Vec3d x = (lo - pad).array() + (hi - lo + 2 * pad).array() * Vec3d(U(rng), U(rng), U(rng)).array();
        // Away from the surface by many smoothing lengths (γ's transition has width ~ s = 0.4 ℓ) plus the
        // mesh's own edge length (the vertex distance over-estimates the true distance by up to an edge).
        if (distanceToMesh(mesh, x) < 3 * ell) continue;
        const bool inside = insideMesh(mesh, x);
        if ((inside && in >= 40) || (!inside && out >= 40)) continue;
        (inside ? in : out)++;
        INFO(name << " at (" << x.transpose() << "), inside = " << inside);
        CHECK(std::abs(model.evaluate(x).mean[0] - (inside ? 1.0 : 0.0)) <= 1e-2);
    }
    CHECK(in >= 20);
    CHECK(out >= 40);
}

std::vector<Vec3d> nearAndFar(const Samples& s, std::size_t count, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-1, 1);
    Vec3d lo = s.position[0], hi = lo;
    for (const auto& p : s.position) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const double diag = (hi - lo).norm(), ell = s.lengthScale;
    std::vector<Vec3d> xs;
    for (std::size_t i = 0; i < count; ++i) {
        if (i % 2 == 0) {  // near: within 3ℓ of a sample
            const Vec3d& p = s.position[rng() % s.size()];
            xs.push_back(p + 3 * ell * Vec3d(U(rng), U(rng), U(rng)));
        } else {  // anywhere in a box three times the size of the input's
            xs.push_back(0.5 * (lo + hi) + 1.5 * diag * Vec3d(U(rng), U(rng), U(rng)));
        }
    }
    return xs;
}

/// Appends a lattice block of 8³ points at spacing h from `corner`, as in a band's VDB leaf.
void appendBlock(std::vector<Vec3d>& xs, const Vec3d& corner, double h) {
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
            for (int k = 0; k < 8; ++k) xs.push_back(corner + h * Vec3d(i, j, k));
}

}  // namespace

TEST_CASE("model: regularized winding number is 1 inside and 0 outside (sphere, bunny, elephant)", "[model]") {
    checkWindingNumber(icosphere(4), "sphere");
    checkWindingNumber(*readInput(test::dataPath("bunny.obj")).soup, "bunny");
    checkWindingNumber(*readInput(test::dataPath("elephant.off")).soup, "elephant");
}

TEST_CASE("model: Barnes-Hut matches the direct sum on all 14 numbers at the default beta", "[model]") {
    for (const char* which : {"sphere", "bunny", "cloud"}) {
        Samples s;
        if (std::string(which) == "sphere") s = soupSamples(icosphere(4), {0.5}).samples;
        else if (std::string(which) == "bunny") s = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
        else s = makeSamples(readInput(test::dataPath("sphere_20k_normal.xyz")), {0.5}).samples;
        const double sm = 0.4 * s.lengthScale;
        const DirectGpis direct(s, sm);
        const BarnesHutGpis bh(s, sm);
        const auto xs = nearAndFar(s, 2000, 11);
        const auto ref = direct.evaluate(xs);
        const auto got = bh.evaluate(xs);
        const ModelError e = compareModels(ref, got);
        INFO(which << ": " << e.describe());
        CHECK(e.worst() <= 1e-3);
    }
}

TEST_CASE("model: Barnes-Hut converges to the direct sum as beta grows", "[model]") {
    const Samples s = soupSamples(icosphere(4), {0.5}).samples;
    const DirectGpis direct(s, 0.4 * s.lengthScale);
    const auto xs = nearAndFar(s, 600, 5);
    const auto ref = direct.evaluate(xs);
    double previous = 1e300;
    for (double beta : {1.5, 3.0, 6.0}) {
        BarnesHutOptions o;
        o.beta = beta;
        const double err = compareModels(ref, BarnesHutGpis(s, 0.4 * s.lengthScale, o).evaluate(xs)).worst();
        INFO("beta = " << beta << ": " << err);
        CHECK(err < previous);
        previous = err;
    }
}

TEST_CASE("model: the covariance's opening ratio trades its accuracy alone, and packets follow it point by point", "[model]") {
    // BarnesHutOptions::covarianceRatio (default 2): the covariance's error against the direct sum grows as the ratio
    // falls to 1 while the mean's stays (the mean's opening test does not read it), and the packets open what
    // evaluate(x) opens at every ratio (with the near field in double, to rounding), also where the far relaxation's
    // floor of 2 is above the ratio near the query (β = 1.5, ratio 1).
    const Samples s = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
    const double sm = 0.4 * s.lengthScale;
    const auto xs = nearAndFar(s, 400, 23);
    const auto ref = DirectGpis(s, sm).evaluate(xs);
    // The packets against evaluate(x), point by point, on the same tree.
    const auto batchError = [&](const BarnesHutGpis& bh, const std::vector<ValueGradient>& batch) {
        std::vector<ValueGradient> single(xs.size());
        for (std::size_t i = 0; i < xs.size(); ++i) single[i] = bh.evaluate(xs[i]);
        return compareModels(single, batch).worst();
    };
    double previousCov = 1e300, meanAtFirst = -1;
    for (double ratio : {1.0, 2.0, 3.0}) {
        BarnesHutOptions o;
        o.covarianceRatio = ratio;
        o.floatNearField = false;
        const BarnesHutGpis bh(s, sm, o);
        const auto batch = bh.evaluate(xs);
        const ModelError e = compareModels(ref, batch);
        const double cov = *std::max_element(e.maxRel.begin() + 4, e.maxRel.end());
        const double mean = *std::max_element(e.maxRel.begin(), e.maxRel.begin() + 4);
        INFO("covariance ratio " << ratio << ": " << e.describe());
        CHECK(cov < previousCov);
        previousCov = cov;
        if (meanAtFirst < 0) meanAtFirst = mean;
        CHECK(mean == meanAtFirst);
        CHECK(batchError(bh, batch) <= 1e-12);
    }
    {
        BarnesHutOptions o;
        o.beta = 1.5;
        o.covarianceRatio = 1;
        o.floatNearField = false;
        const BarnesHutGpis bh(s, sm, o);
        CHECK(batchError(bh, bh.evaluate(xs)) <= 1e-12);
    }
    for (double bad : {0.5, std::nan(""), std::numeric_limits<double>::infinity()}) {
        BarnesHutOptions o;
        o.covarianceRatio = bad;
        CHECK_THROWS_AS(BarnesHutGpis(s, sm, o), ParameterError);
    }
}

TEST_CASE("model: a packet of points opens the nodes each point opens alone (batch equals single-point evaluation)", "[model]") {
    // The batch path (Morton order, packets of 8, SIMD lanes) against the reference path (one traversal per point):
    // the same nodes and samples per point, so the same numbers to rounding with the near field in double, and to
    // float's rounding with it in float (the default; docs/model.md#packets: ≤ 1e-5 in the norm, 2e-5 pointwise;
    // measured ≤ 2e-6 and 3.5e-6). Points: near and far, a dense lattice block as in a band leaf, a batch that is not
    // a multiple of 8, and inputs scaled by 1e-6 and 1e6.
    struct Case {
        const char* name;
        Samples samples;
    };
    std::vector<Case> cases;
    cases.push_back({"sphere", soupSamples(icosphere(3), {0.5}).samples});
    cases.push_back({"bunny", makeSamples(readInput(test::dataPath("bunny.obj")), {0.25}).samples});
    cases.push_back({"cloud", makeSamples(readInput(test::dataPath("sphere_20k_normal.xyz")), {1.0}).samples});
    for (double scale : {1e-6, 1e6}) {
        TriangleSoup t = torus(24, 8);
        for (auto& v : t.vertices) v *= scale;
        cases.push_back({scale < 1 ? "torus x1e-6" : "torus x1e6", soupSamples(t, {0.5}).samples});
    }
    for (const Case& c : cases)
        for (const bool inFloat : {false, true}) {
            BarnesHutOptions o;
            o.floatNearField = inFloat;
            const BarnesHutGpis bh(c.samples, 0.4 * c.samples.lengthScale, o);
            std::vector<Vec3d> xs = nearAndFar(c.samples, 1203, 17);
            const double h = 0.3 * c.samples.lengthScale;
            appendBlock(xs, c.samples.position[c.samples.size() / 3], h);
            const std::vector<ValueGradient> batch = bh.evaluate(xs);
            std::vector<ValueGradient> single(xs.size());
            for (std::size_t i = 0; i < xs.size(); ++i) single[i] = bh.evaluate(xs[i]);
            const ModelError e = compareModels(single, batch);
            INFO(c.name << (inFloat ? ", near field in float: " : ", near field in double: ") << e.describe());
            CHECK(e.worst() <= (inFloat ? 1e-5 : 1e-12));
            // And the covariance pointwise, against the point's own √(c_aa c_bb): far points have tiny covariances, which
            // the norm above (scaled by the largest over the points) would not see. (Not the mean: outside a closed
            // surface γ's terms cancel to rounding noise, which no two summation orders share.)
            double worst = 0;
            for (std::size_t i = 0; i < xs.size(); ++i)
                for (int a = 0; a < 4; ++a)
                    for (int b = 0; b < 4; ++b) {
                        const double scale = std::sqrt(single[i].cov(a, a) * single[i].cov(b, b));
                        worst = std::max(worst, std::abs(batch[i].cov(a, b) - single[i].cov(a, b)) / scale);
                    }
            CHECK(worst <= (inFloat ? 2e-5 : 1e-10));
        }
}

TEST_CASE("model: a packet holds 1 to 8 points and refuses more", "[model]") {
    const Samples s = soupSamples(icosphere(2), {0.5}).samples;
    BarnesHutOptions inDouble;
    inDouble.floatNearField = false;
    const BarnesHutGpis bh(s, 0.4 * s.lengthScale), bhDouble(s, 0.4 * s.lengthScale, inDouble);
    const std::vector<Vec3d> xs = nearAndFar(s, 9, 4);
    // Compared in the documented norm (scales over the points): far outside the sphere γ is rounding noise (1e-18),
    // which FMA in the packets' clones rounds differently from the reference. The near field in double agrees to
    // rounding, in float (the default) to float's.
    for (const auto& [model, name, bound] : {std::tuple<const BarnesHutGpis*, const char*, double>{&bhDouble, "double", 1e-12},
                                             std::tuple<const BarnesHutGpis*, const char*, double>{&bh, "float", 1e-5}})
        for (int count = 1; count <= BarnesHutGpis::kPacket; ++count) {
            std::vector<ValueGradient> out(static_cast<std::size_t>(count)), ref;
            model->evaluatePacket(xs.data(), count, out.data());
            for (int l = 0; l < count; ++l) ref.push_back(bh.evaluate(xs[std::size_t(l)]));
            const ModelError e = compareModels(ref, out);
            INFO(count << " points, near field in " << name << ": " << e.describe());
            CHECK(e.worst() <= bound);
        }
    std::vector<ValueGradient> out(9);
    CHECK_THROWS_AS(bh.evaluatePacket(xs.data(), 9, out.data()), Error);
    CHECK_THROWS_AS(bh.evaluatePacket(xs.data(), 0, out.data()), Error);
    CHECK(bh.evaluate(std::vector<Vec3d>{}).empty());
}

TEST_CASE("model: a point's batch result does not depend on the other points of its batch, to the bit", "[model]") {
    // Near and far points: packets mix lanes in the series, closed-form and pure-Newton regimes of the kernel.
    const Samples s = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
    const BarnesHutGpis bh(s, 0.4 * s.lengthScale);
    const std::vector<Vec3d> xs = nearAndFar(s, 300, 17);
    const std::vector<ValueGradient> whole = bh.evaluate(xs);
    std::mt19937_64 rng(3);
    for (std::size_t batch : {1, 3, 8, 37}) {
        std::vector<std::size_t> order(xs.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
        std::shuffle(order.begin(), order.end(), rng);
        for (std::size_t b = 0; b < order.size(); b += batch) {
            std::vector<Vec3d> part;
            for (std::size_t k = b; k < std::min(order.size(), b + batch); ++k) part.push_back(xs[order[k]]);
            const std::vector<ValueGradient> got = bh.evaluate(part);
            for (std::size_t k = 0; k < part.size(); ++k) {
                const ValueGradient& ref = whole[order[b + k]];
                REQUIRE(got[k].mean == ref.mean);
                REQUIRE(got[k].cov == ref.cov);
            }
        }
    }
}

TEST_CASE("model: batch results do not depend on the thread count", "[model]") {
    const Samples s = soupSamples(icosphere(3), {0.5}).samples;
    const BarnesHutGpis bh(s, 0.4 * s.lengthScale);
    const auto xs = nearAndFar(s, 3000, 2);
    std::vector<ValueGradient> one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = bh.evaluate(xs);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = bh.evaluate(xs);
    }
    for (std::size_t i = 0; i < xs.size(); ++i) {
        REQUIRE(one[i].mean == two[i].mean);
        REQUIRE(one[i].cov == two[i].cov);
    }
}

TEST_CASE("model: translation and rotation move the field with the input", "[model]") {
    const TriangleSoup base = *readInput(test::dataPath("bunny.obj")).soup;
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Vec3d(1, 2, 3).normalized()).toRotationMatrix();
    const Vec3d t(10.0, -5.0, 3.0);
    TriangleSoup moved = base;
    for (auto& v : moved.vertices) v = R * v + t;
    const Samples a = soupSamples(base, {0.5}).samples, b = soupSamples(moved, {0.5}).samples;
    REQUIRE(a.lengthScale == Approx(b.lengthScale).epsilon(1e-12));
    const BarnesHutGpis ma(a, 0.4 * a.lengthScale), mb(b, 0.4 * b.lengthScale);
    const DirectGpis da(a, 0.4 * a.lengthScale), db(b, 0.4 * b.lengthScale);
    Mat4d B = Mat4d::Identity();
    B.bottomRightCorner<3, 3>() = R;
    const std::vector<Vec3d> xs = nearAndFar(a, 400, 9);
    std::vector<Vec3d> ys;
    for (const Vec3d& x : xs) ys.push_back(R * x + t);
    for (int exact = 0; exact < 2; ++exact) {
        std::vector<ValueGradient> va = exact ? da.evaluate(xs) : ma.evaluate(xs);
        const std::vector<ValueGradient> vb = exact ? db.evaluate(ys) : mb.evaluate(ys);
        for (auto& v : va) v.mean = B * v.mean, v.cov = B * v.cov * B.transpose();
        // A moved input builds a different tree: Barnes-Hut agrees to its own accuracy (2 × 1e-3), the direct
        // sum to rounding.
        const double err = compareModels(va, vb).worst();
        INFO("exact = " << exact << ": " << compareModels(va, vb).describe());
        CHECK(err <= (exact ? 1e-10 : 2e-3));
    }
}

TEST_CASE("model: scaling the input scales results as dimensional analysis says", "[model]") {
    const TriangleSoup base = icosphere(3);
    const Samples a = soupSamples(base, {0.5}).samples;
    const DirectGpis da(a, 0.4 * a.lengthScale);
    const BarnesHutGpis ba(a, 0.4 * a.lengthScale);
    for (double c : {1e-3, 1e3}) {
        TriangleSoup scaled = base;
        for (auto& v : scaled.vertices) v *= c;
        const Samples b = soupSamples(scaled, {0.5}).samples;
        const DirectGpis db(b, 0.4 * b.lengthScale);
        const BarnesHutGpis bb(b, 0.4 * b.lengthScale);
        // γ is dimensionless, ∇ carries 1/length: mean (1, 1/c, 1/c, 1/c), covariance D C D with D = diag(1, 1/c…)
        Mat4d D = Mat4d::Identity() / c;
        D(0, 0) = 1;
        const std::vector<Vec3d> xs = nearAndFar(a, 200, 4);
        std::vector<Vec3d> ys;
        for (const Vec3d& x : xs) ys.push_back(c * x);
        for (int exact = 0; exact < 2; ++exact) {
            std::vector<ValueGradient> va = exact ? da.evaluate(xs) : ba.evaluate(xs);
            const std::vector<ValueGradient> vb = exact ? db.evaluate(ys) : bb.evaluate(ys);
            for (auto& v : va) v.mean = D * v.mean, v.cov = D * v.cov * D;
            // The direct sum scales to rounding; a scaled input may split its octree differently where samples
            // sit on a splitting plane, so Barnes-Hut agrees to its own accuracy.
            INFO("c = " << c << ", exact = " << exact << ": " << compareModels(va, vb).describe());
            CHECK(compareModels(va, vb).worst() <= (exact ? 1e-10 : 2e-3));
        }
    }
}

TEST_CASE("model: cells share the far field within the bound of the direct sum and near evaluate(x), whatever the batch", "[model]") {
    // evaluateDense with BarnesHutOptions::cellWidth > 0 (docs/model.md#cells): a cell's points take the nodes far from the whole cell
    // from one Chebyshev interpolant. Against the direct sum, all 14 numbers stay within the documented 1e-3; against
    // evaluate(x) (the per-point reference) within 2e-4: the interpolation's error, and a cell opens some nodes more
    // finely than a point would (measured ≤ 5e-5 on sphere soups at 4.8ℓ cells). Points: lattice blocks as in a band
    // leaf, near and far points; inputs: the bunny, an 8.2e4-triangle soup (icosphere 6), a point cloud, and a torus
    // scaled by 1e-6 and 1e6.
    struct Case {
        const char* name;
        Samples samples;
    };
    std::vector<Case> cases;
    cases.push_back({"bunny", makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples});
    cases.push_back({"soup", soupSamples(icosphere(6), {0.5}).samples});
    cases.push_back({"cloud", makeSamples(readInput(test::dataPath("sphere_20k_normal.xyz")), {1.0}).samples});
    for (double scale : {1e-6, 1e6}) {
        TriangleSoup t = torus(24, 8);
        for (auto& v : t.vertices) v *= scale;
        cases.push_back({scale < 1 ? "torus x1e-6" : "torus x1e6", soupSamples(t, {0.5}).samples});
    }
    for (const Case& c : cases) {
        const double sm = 0.4 * c.samples.lengthScale;
        const BarnesHutOptions o;  // cells of 12 s, the default
        REQUIRE(o.cellWidth == 12);
        const BarnesHutGpis cells(c.samples, sm, o), points(c.samples, sm);
        std::vector<Vec3d> xs = nearAndFar(c.samples, 200, 31);
        const double h = 0.3 * c.samples.lengthScale;
        for (std::size_t b : {std::size_t(0), c.samples.size() / 2}) appendBlock(xs, c.samples.position[b], h);
        const std::vector<ValueGradient> got = cells.evaluateDense(xs);
        std::vector<ValueGradient> single(xs.size());
        for (std::size_t i = 0; i < xs.size(); ++i) single[i] = points.evaluate(xs[i]);
        const ModelError againstPoints = compareModels(single, got);
        INFO(c.name << ", against evaluate(x): " << againstPoints.describe());
        CHECK(againstPoints.worst() <= 2e-4);
        CHECK(againstPoints.worst() > 1e-9);                               // the cells are in use: interpolation is not rounding
        CHECK(compareModels(single, cells.evaluate(xs)).worst() <= 1e-5);  // evaluate(xs) stays the packets
        {
            std::vector<Vec3d> some;
            for (std::size_t i = 0; i < xs.size(); i += 3) some.push_back(xs[i]);
            const ModelError direct = compareModels(DirectGpis(c.samples, sm).evaluate(some), cells.evaluateDense(some));
            INFO(c.name << ", against the direct sum: " << direct.describe());
            CHECK(direct.worst() <= 1e-3);
        }
        // A point's result depends on its cell only: the same to the bit in batches of 1 and 37.
        for (std::size_t batch : {std::size_t(1), std::size_t(37)})
            for (std::size_t b = 0; b < xs.size(); b += 97 * batch) {
                const std::vector<Vec3d> part(xs.begin() + long(b), xs.begin() + long(std::min(xs.size(), b + batch)));
                const std::vector<ValueGradient> r = cells.evaluateDense(part);
                for (std::size_t k = 0; k < part.size(); ++k) {
                    REQUIRE(r[k].mean == got[b + k].mean);
                    REQUIRE(r[k].cov == got[b + k].cov);
                }
            }
        // Nor on whether its cell's table was kept from an earlier batch (here: none kept), nor on the thread count.
        BarnesHutOptions keepNone = o;
        keepNone.cellCacheBytes = 0;
        const BarnesHutGpis uncached(c.samples, sm, keepNone);
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        const std::vector<ValueGradient> serial = uncached.evaluateDense(xs);
        CHECK(uncached.cellCacheBytes() == 0);
        CHECK(cells.cellCacheBytes() > 0);
        for (std::size_t i = 0; i < xs.size(); ++i) {
            REQUIRE(serial[i].mean == got[i].mean);
            REQUIRE(serial[i].cov == got[i].cov);
        }
    }
}

TEST_CASE("model: cells' options out of range are refused", "[model]") {
    const Samples s = soupSamples(icosphere(1), {0.5}).samples;
    const auto refused = [&](auto set) {
        BarnesHutOptions o;
        set(o);
        CHECK_THROWS_AS(BarnesHutGpis(s, 0.1, o), ParameterError);
    };
    for (double bad : {-1.0, 1e-320, std::nan(""), std::numeric_limits<double>::infinity()})
        refused([&](BarnesHutOptions& o) { o.cellWidth = bad; });
    for (int bad : {1, 9}) refused([&](BarnesHutOptions& o) { o.cellNodes = bad; });
    for (double bad : {0.25, std::nan("")}) refused([&](BarnesHutOptions& o) { o.cellSeparation = bad; });
}

TEST_CASE("model: Barnes-Hut refuses beta <= 1 and empty samples", "[model]") {
    const Samples s = soupSamples(icosphere(1), {0.5}).samples;
    BarnesHutOptions o;
    o.beta = 1.0;
    CHECK_THROWS_AS(BarnesHutGpis(s, 0.1, o), ParameterError);
    CHECK_THROWS_AS(BarnesHutGpis(Samples{}, 0.1), InputError);
    CHECK_THROWS_AS(DirectGpis(s, -1.0), ParameterError);
}

TEST_CASE("model: the linearised covariance matches Monte-Carlo over perturbed vertices (sigma_rel = 0.02)", "[model]") {
    const TriangleSoup soup = test::unshare(icosphere(2));
    const double sigmaRel = 0.02;
    const SoupSamples base = soupSamples(soup, {sigmaRel});
    const double ell = base.samples.lengthScale, s = 0.4 * ell;
    const DirectGpis model(base.samples, s);
    const std::vector<Vec3d> xs = {Vec3d(0, 0, 1.0 + 0.3 * ell), Vec3d(0.6, 0.0, 0.8 - 0.2 * ell), Vec3d(0.577, 0.577, 0.577),
                                   Vec3d(0.2, 0.1, 0.3)};
    const int K = 2500;
    std::mt19937_64 rng(123);
    std::normal_distribution<double> N(0, base.sigma);
    std::vector<std::vector<Vec4d>> draws(xs.size());
    for (int k = 0; k < K; ++k) {
        TriangleSoup noisy = soup;
        for (auto& v : noisy.vertices) v += Vec3d(N(rng), N(rng), N(rng));
        const DirectGpis perturbed(soupSamples(noisy, {sigmaRel}).samples, s);  // same s: only the data moves
        for (std::size_t q = 0; q < xs.size(); ++q) draws[q].push_back(perturbed.evaluate(xs[q]).mean);
    }
    for (std::size_t q = 0; q < xs.size(); ++q) {
        const ValueGradient ref = model.evaluate(xs[q]);
        Vec4d mean = Vec4d::Zero();
        for (const auto& d : draws[q]) mean += d / K;
        Mat4d cov = Mat4d::Zero();
        for (const auto& d : draws[q]) cov += (d - mean) * (d - mean).transpose() / (K - 1);
        for (int a = 0; a < 4; ++a) {
            // Monte-Carlo standard errors, 5 of them, plus 2% for what the linearisation leaves out.
            const double seMean = std::sqrt(ref.cov(a, a) / K);
            INFO("point " << q << ", component " << a);
            CHECK(std::abs(mean[a] - ref.mean[a]) <= 5 * seMean + 0.02 * std::sqrt(ref.cov(a, a)));
            for (int b = 0; b < 4; ++b) {
                const double scale = std::sqrt(ref.cov(a, a) * ref.cov(b, b));
                const double se = std::sqrt((scale * scale + ref.cov(a, b) * ref.cov(a, b)) / K);
                INFO("cov(" << a << "," << b << "): model " << ref.cov(a, b) << ", Monte-Carlo " << cov(a, b));
                CHECK(std::abs(cov(a, b) - ref.cov(a, b)) <= 5 * se + 0.02 * scale);
            }
        }
    }
}

TEST_CASE("model: inward normals are flipped, so that the surface is gamma = 1/2 whatever the input's orientation", "[model]") {
    // A soup inside out (each triangle's winding reversed) and a cloud with inward normals, against the same inputs
    // oriented outward: the winding number at the samples is -1/2 before the flip, and after it the samples and the
    // field are the outward input's (up to the rounding of a centroid summed in another order).
    const TriangleSoup outwardSoup = icosphere(3);
    TriangleSoup inwardSoup = outwardSoup;
    for (auto& t : inwardSoup.triangles) std::swap(t[1], t[2]);
    PointCloud outwardCloud;
    std::mt19937_64 rng(3);
    std::normal_distribution<double> g;
    for (int i = 0; i < 2000; ++i) {
        const Vec3d d = Vec3d(g(rng), g(rng), g(rng)).normalized();
        outwardCloud.positions.push_back(d);
        outwardCloud.normals.push_back(d);
    }
    PointCloud inwardCloud = outwardCloud;
    for (Vec3d& n : inwardCloud.normals) n = -n;
    const std::vector<Vec3d> probes = {Vec3d(0, 0, 0), Vec3d(0.3, -0.2, 0.1), Vec3d(1.5, 0, 0), Vec3d(0, 0.98, 0.1)};
    for (const bool soup : {true, false}) {
        InputData outward, inward;
        if (soup) outward.soup = outwardSoup, inward.soup = inwardSoup;
        else outward.cloud = outwardCloud, inward.cloud = inwardCloud;
        INFO((soup ? "soup" : "cloud"));
        const LoadedModel a = loadModel(outward), b = loadModel(inward);
        ModelOptions keep;
        keep.orientOutward = false;
        const LoadedModel c = loadModel(inward, keep);
        CHECK_FALSE(a.input.normalsFlipped);
        CHECK(b.input.normalsFlipped);
        CHECK_FALSE(c.input.normalsFlipped);
        CHECK(medianGammaAtSamples(*a.model, a.input.samples) == Approx(0.5).margin(0.05));
        CHECK(medianGammaAtSamples(*c.model, c.input.samples) == Approx(-0.5).margin(0.05));
        REQUIRE(b.input.samples.size() == a.input.samples.size());
        for (std::size_t i = 0; i < a.input.samples.size(); ++i) {
            CHECK((b.input.samples.normal[i] - a.input.samples.normal[i]).norm() <= 1e-12 * a.input.samples.normal[i].norm());
            CHECK(b.input.samples.normalCovariance[i].trace() == Approx(a.input.samples.normalCovariance[i].trace()).epsilon(1e-12));
        }
        for (const Vec3d& x : probes) {
            const ValueGradient va = a.model->evaluate(x), vb = b.model->evaluate(x), vc = c.model->evaluate(x);
            CHECK(vb.mean[0] == Approx(va.mean[0]).margin(1e-9));
            CHECK(vc.mean[0] == Approx(-va.mean[0]).margin(1e-9));
            CHECK(vb.cov(0, 0) == Approx(va.cov(0, 0)).epsilon(1e-9));
        }
    }
    // The regression model's generated labels follow the flipped normals too: inside is the enclosed side (phi > 0).
    ModelOptions regression;
    regression.kind = ModelKind::Regression;
    InputData inward;
    inward.soup = inwardSoup;
    const LoadedModel r = loadModel(inward, regression);
    CHECK(r.input.normalsFlipped);
    CHECK(r.model->evaluate(Vec3d(0, 0, 0)).mean[0] > 0);
    CHECK(r.model->evaluate(Vec3d(2, 0, 0)).mean[0] < 0);
}
