#include "gpisvdb/tasks/ray_query.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "../core/standard_normal.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr double kMaxPoints = 1e8;
constexpr double kMaxRayPoints = 1e6;                       // one ray's points, all evaluated at once (160 B each)
constexpr std::size_t kBatchPoints = std::size_t(1) << 18;  // points evaluated at once (160 B each)

/// ϕ(z) / Φ(−z), the inverse Mills ratio, without underflow (Φ(−z) underflows past z ≈ 38).
double millsRatio(double z) {
    if (z < 30) return normalPdf(z) / normalCdf(-z);
    const double iz2 = 1.0 / (z * z);
    return z * (1 + iz2 * (1 - 2 * iz2));  // asymptotic: z + 1/z − 2/z³, relative error < 1e-7 here
}

/// At one point of a ray: P(φ < u) and the first-hit rate λ = ρ⁺ / P(φ < u).
struct PointRate {
    double outside = 1;
    double rate = 0;  ///< world units⁻¹
};

PointRate pointRate(const ValueGradient& z, const Vec3d& d, double u) {
    const double sigma2 = z.cov(0, 0);
    const double m = z.mean[0] - u;  // γ − u: > 0 inside
    PointRate p;
    if (!(sigma2 > 0)) {  // a certain φ: no crossing inside a step (a sign change between steps ends the survival)
        p.outside = m < 0 ? 1.0 : 0.0;
        return p;
    }
    const double sigma = std::sqrt(sigma2);
    const Vec3d g(z.mean[1], z.mean[2], z.mean[3]);
    const Vec3d c0g(z.cov(0, 1), z.cov(0, 2), z.cov(0, 3));
    const double mv = d.dot(g), c = d.dot(c0g);
    const double vv = d.dot(z.cov.bottomRightCorner<3, 3>() * d);
    // === v = d·∇φ given φ = u: mean mv + c (u − γ)/σ², variance vv − c²/σ²; E[v⁺] of that normal
    const double mc = mv - c * m / sigma2;
    const double sc = std::sqrt(std::max(vv - c * c / sigma2, 0.0));
    const double positive = sc > 0 ? mc * normalCdf(mc / sc) + sc * normalPdf(mc / sc) : std::max(mc, 0.0);
    // === λ = p_φ(u) E[v⁺ | φ = u] / P(φ < u) = (ϕ(z)/Φ(−z)) E[v⁺ | φ = u] / σ,  z = (γ − u)/σ
    const double zs = m / sigma;
    p.outside = normalCdf(-zs);
    p.rate = millsRatio(zs) * positive / sigma;
    return p;
}

void checkRay(const Ray& r) {
    if (!r.origin.allFinite() || !r.direction.allFinite() || !(r.direction.norm() > 0))
        throw ParameterError("a ray needs a finite origin and a finite, non-zero direction (Ray::origin, Ray::direction)",
                             {"Ray::origin", "Ray::direction"});
    if (!(r.length > 0) || !std::isfinite(r.length))
        throw ParameterError("a ray's length (Ray::length) must be finite and > 0", {"Ray::length"});
}

/// S(t_j) from the rates at the points t_j (trapezoid rule on λ), and the ray's RayHit.
RayHit finish(const std::vector<double>& t, const std::vector<PointRate>& rates, std::vector<double>* survivalOut) {
    const std::size_t m = t.size();
    std::vector<double> S(m);
    S[0] = rates[0].outside;
    for (std::size_t j = 1; j < m; ++j) {
        // Never above P(outside at t_j): a step that jumps over an entry (or a certain φ that changed sign) lands
        // where the ray is inside whatever the rate says
        S[j] = std::min(S[j - 1] * std::exp(-0.5 * (rates[j - 1].rate + rates[j].rate) * (t[j] - t[j - 1])), rates[j].outside);
    }
    RayHit h;
    h.insideAtOrigin = 1 - S[0];
    h.hit = 1 - S[m - 1];
    // === Moments of T given a hit: mass 1 − S(0) at t = 0, S(t_{j−1}) − S(t_j) at the step's middle
    double mass = h.insideAtOrigin, first = 0, second = 0;
    for (std::size_t j = 1; j < m; ++j) {
        const double w = S[j - 1] - S[j], mid = 0.5 * (t[j - 1] + t[j]);
        mass += w, first += w * mid, second += w * mid * mid;
    }
    if (mass > 0) {
        h.expected = first / mass;
        h.stddev = std::sqrt(std::max(second / mass - h.expected * h.expected, 0.0));
    } else {
        h.expected = h.stddev = std::numeric_limits<double>::quiet_NaN();
    }
    if (survivalOut) *survivalOut = std::move(S);
    return h;
}

}  // namespace

std::size_t rayPointCount(const Ray& ray, double step) {
    checkRay(ray);
    if (!(step > 0) || !std::isfinite(step))
        throw ParameterError("the step along rays (RayQueryOptions::step) must be finite and > 0", {"RayQueryOptions::step"});
    const double steps = std::ceil(ray.length / step);
    if (steps + 1 > kMaxRayPoints)
        throw ParameterError("a ray of length " + numberText(ray.length) + " at steps of " + numberText(step) +
                                 " needs more than 1e6 points: use a larger step (RayQueryOptions::step)",
                             {"RayQueryOptions::step"});
    return std::size_t(steps) + 1;
}

std::vector<double> rayParameters(const Ray& ray, double step) {
    const std::size_t n = rayPointCount(ray, step) - 1;
    std::vector<double> t(n + 1);
    for (std::size_t j = 0; j < n; ++j) t[j] = double(j) * step;
    t[n] = ray.length;
    return t;
}

std::vector<RayHit> queryRays(const GpisModel& model, const std::vector<Ray>& rays, const RayQueryOptions& options,
                              const Progress& progress) {
    if (!std::isfinite(options.iso)) throw ParameterError("the iso-value (RayQueryOptions::iso) must be finite", {"RayQueryOptions::iso"});
    // === The points of every ray, counted before any is evaluated
    double total = 0;
    for (const Ray& r : rays) total += double(rayPointCount(r, options.step));
    if (total > kMaxPoints)
        throw ParameterError("the rays need " + numberText(total) +
                                 " points, more than 1e8: use a larger step "
                                 "(RayQueryOptions::step) or fewer rays",
                             {"RayQueryOptions::step"});
    std::vector<RayHit> hits(rays.size());
    // === Batches of whole rays, each evaluated at once (the model's batch call is the parallel one)
    std::size_t done = 0;
    for (std::size_t first = 0; first < rays.size();) {
        progress.checkInterrupt();
        progress.update("rays", double(done) / total);
        std::vector<Vec3d> xs;
        std::vector<std::vector<double>> ts;
        std::size_t last = first;
        while (last < rays.size() && (last == first || xs.size() < kBatchPoints)) {
            const Ray& r = rays[last];
            const Vec3d d = r.direction.normalized();
            ts.push_back(rayParameters(r, options.step));
            for (double t : ts.back()) xs.push_back(r.origin + t * d);
            ++last;
        }
        const std::vector<ValueGradient> values = model.evaluate(xs, progress.interruptOnly());
        std::size_t k = 0;
        for (std::size_t i = first; i < last; ++i) {
            const Vec3d d = rays[i].direction.normalized();
            const std::vector<double>& t = ts[i - first];
            std::vector<PointRate> rates(t.size());
            for (std::size_t j = 0; j < t.size(); ++j) rates[j] = pointRate(values[k++], d, options.iso);
            hits[i] = finish(t, rates, nullptr);
        }
        done += xs.size();
        first = last;
    }
    progress.update("rays", 1.0);
    return hits;
}

RayProfile rayProfile(const GpisModel& model, const Ray& ray, const RayQueryOptions& options) {
    RayProfile p;
    p.t = rayParameters(ray, options.step);
    const Vec3d d = ray.direction.normalized();
    std::vector<Vec3d> xs;
    for (double t : p.t) xs.push_back(ray.origin + t * d);
    const std::vector<ValueGradient> values = model.evaluate(xs);
    std::vector<PointRate> rates(p.t.size());
    for (std::size_t j = 0; j < p.t.size(); ++j) rates[j] = pointRate(values[j], d, options.iso);
    finish(p.t, rates, &p.survival);
    return p;
}

}  // namespace gpisvdb
