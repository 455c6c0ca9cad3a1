#include "gpisvdb/tasks/collision.h"

#include <algorithm>
#include <cmath>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/tasks/plausible_surfaces.h"

namespace gpisvdb {

namespace {

constexpr double kMaxPoints = 1e8;
constexpr double kDrawBytes = 256e6;  // the draws' noise and tree held at once: the draws go in chunks within it

/// Each triangle's divisions m (its longest edge over the step, rounded up) and the points they make in all:
/// the vertices and (m + 1)(m + 2)/2 lattice points per triangle, counted before anything is allocated.
std::vector<int> latticeDivisions(const std::vector<Vec3d>& vertices, const std::vector<std::array<int, 3>>& triangles, double step,
                                  double& total) {
    if (!(step > 0) || !std::isfinite(step))
        throw ParameterError("the spacing of the points on the mesh (CollisionOptions::step) must be finite and > 0",
                             {"CollisionOptions::step"});
    std::vector<int> divisions(triangles.size());
    total = double(vertices.size());
    for (std::size_t t = 0; t < triangles.size(); ++t) {
        const auto& f = triangles[t];
        for (int c : f)
            if (c < 0 || std::size_t(c) >= vertices.size()) throw InputError("a triangle of the mesh names a vertex it does not have");
        const Vec3d &a = vertices[std::size_t(f[0])], &b = vertices[std::size_t(f[1])], &c = vertices[std::size_t(f[2])];
        const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
        const double m = std::ceil(longest / step);
        if (!(m <= kMaxPoints)) total = HUGE_VAL;
        else divisions[t] = int(m), total += 0.5 * (m + 1) * (m + 2);
        if (total > kMaxPoints)
            throw ParameterError("the mesh sampled at spacing " + numberText(step) +
                                     " needs more than 1e8 points: use a "
                                     "larger spacing (CollisionOptions::step)",
                                 {"CollisionOptions::step"});
    }
    return divisions;
}

}  // namespace

std::size_t meshSamplePointCount(const std::vector<Vec3d>& vertices, const std::vector<std::array<int, 3>>& triangles, double step) {
    double total = 0;
    latticeDivisions(vertices, triangles, step, total);
    return std::size_t(total);
}

std::vector<Vec3d> meshSamplePoints(const std::vector<Vec3d>& vertices, const std::vector<std::array<int, 3>>& triangles, double step) {
    double total = 0;
    const std::vector<int> divisions = latticeDivisions(vertices, triangles, step, total);
    std::vector<Vec3d> points(vertices);
    points.reserve(std::size_t(total));
    for (std::size_t t = 0; t < triangles.size(); ++t) {
        const auto& f = triangles[t];
        const Vec3d &a = vertices[std::size_t(f[0])], &b = vertices[std::size_t(f[1])], &c = vertices[std::size_t(f[2])];
        const int m = divisions[t];
        for (int i = 0; i <= m; ++i)
            for (int j = 0; i + j <= m; ++j) {
                const bool corner = (i == 0 && j == 0) || i == m || j == m;  // the vertices, already there
                if (!corner) points.push_back(a + (double(i) / m) * (b - a) + (double(j) / m) * (c - a));
            }
    }
    return points;
}

CollisionResult collisionProbability(const GpisModel& model, const Samples& samples, double s, const std::vector<Vec3d>& vertices,
                                     const std::vector<std::array<int, 3>>& triangles, const CollisionOptions& options,
                                     const Progress& progress) {
    if (options.draws < 1 || options.draws > 10000)
        throw ParameterError("the number of draws (CollisionOptions::draws) must be between 1 and 10000", {"CollisionOptions::draws"});
    if (!std::isfinite(options.iso))
        throw ParameterError("the iso-value (CollisionOptions::iso) must be finite", {"CollisionOptions::iso"});
    if (vertices.empty()) throw InputError("the mesh has no vertices");
    for (const Vec3d& v : vertices)
        if (!v.allFinite()) throw InputError("the mesh has a vertex that is not finite");
    CollisionResult result;
    const std::vector<Vec3d> points = meshSamplePoints(vertices, triangles, options.step);
    result.points = points.size();

    // === γ and c₀₀ at the points (the model's batch evaluation), and the largest one-point probability
    progress.update("collision", 0.0);
    const std::vector<ValueGradient> values = model.evaluate(points, progress.interruptOnly());
    std::vector<double> gamma(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        gamma[i] = values[i].mean[0];
        const double sd = std::sqrt(std::max(values[i].cov(0, 0), 0.0)), m = values[i].mean[0] - options.iso;
        const double inside = sd > 0 ? 0.5 * std::erfc(-m / (sd * M_SQRT2)) : (m > 0 ? 1.0 : 0.0);
        result.largestInside = std::max(result.largestInside, inside);
    }

    // === The draws, in chunks whose noise and tree stay within kDrawBytes: a draw collides when φ_k > u somewhere
    SurfaceDrawOptions drawOptions;
    drawOptions.seed = options.seed;
    drawOptions.openingRatio = options.openingRatio;
    drawOptions.count = 1;
    const double perDraw = SurfaceDraws::bytes(samples.size(), drawOptions);
    const int chunk = int(std::clamp(std::floor(kDrawBytes / perDraw), 1.0, 64.0));
    int collided = 0;
    for (int first = 0; first < options.draws; first += chunk) {
        progress.checkInterrupt();
        progress.update("collision", double(first) / options.draws);
        drawOptions.firstDraw = first;
        drawOptions.count = std::min(chunk, options.draws - first);
        const SurfaceDraws draws(samples, s, drawOptions);
        const std::size_t n = std::size_t(drawOptions.count);
        // A bitwise OR over the points: the same whatever order the threads take them in
        const std::vector<char> hit = tbb::parallel_reduce(
            tbb::blocked_range<std::size_t>(0, points.size(), 64), std::vector<char>(n, 0),
            [&](const tbb::blocked_range<std::size_t>& r, std::vector<char> acc) {
                for (std::size_t i = r.begin(); i < r.end(); ++i) {
                    progress.checkInterruptAt(i);
                    const std::vector<double> e = draws.perturbation(points[i]);
                    for (std::size_t k = 0; k < n; ++k) acc[k] |= char(gamma[i] + e[k] > options.iso);
                }
                return acc;
            },
            [](std::vector<char> a, const std::vector<char>& b) {
                for (std::size_t k = 0; k < a.size(); ++k) a[k] |= b[k];
                return a;
            });
        for (char h : hit) collided += h;
    }
    progress.update("collision", 1.0);
    const double n = double(options.draws);
    result.probability = collided / n;
    result.standardError = std::sqrt(result.probability * (1 - result.probability) / n);
    return result;
}

}  // namespace gpisvdb
