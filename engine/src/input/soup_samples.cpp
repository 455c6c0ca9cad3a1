#include <cmath>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/triangle_soup.h"

namespace gpisvdb {

namespace {
// A triangle is degenerate when its area is negligible against its longest edge (scale free).
constexpr double kDegenerateRatio = 1e-12;

bool degenerate(const Vec3d& area2, double maxEdge2) { return !(area2.norm() > kDegenerateRatio * maxEdge2); }
}  // namespace

double meanEdgeLength(const TriangleSoup& soup) {
    double sum = 0;
    std::size_t count = 0;
    for (const auto& t : soup.triangles) {
        const Vec3d& a = soup.vertices[t[0]];
        const Vec3d& b = soup.vertices[t[1]];
        const Vec3d& c = soup.vertices[t[2]];
        const double e[3] = {(b - a).norm(), (c - b).norm(), (a - c).norm()};
        if (degenerate((b - a).cross(c - a), std::max({e[0] * e[0], e[1] * e[1], e[2] * e[2]}))) continue;
        sum += e[0] + e[1] + e[2];
        count += 3;
    }
    return count ? sum / double(count) : 0.0;
}

SoupSamples soupSamples(const TriangleSoup& soup, const SoupNoiseOptions& options) {
    if (!(options.sigmaRel > 0) || !std::isfinite(options.sigmaRel))
        throw ParameterError(
            "the relative noise σ (SoupNoiseOptions::sigmaRel) must be finite and > 0 (got " + numberText(options.sigmaRel) + ")",
            {"SoupNoiseOptions::sigmaRel"});
    SoupSamples out;
    const double ell = meanEdgeLength(soup);
    if (!(ell > 0)) throw InputError("the mesh has no triangle of non-zero area");
    out.sigma = options.sigmaRel * ell;
    const double s2 = out.sigma * out.sigma;
    Samples& S = out.samples;
    S.lengthScale = ell;
    // Exactly: what samplesBytes counts, not up to twice that (zero-area triangles left out leave a little unused)
    S.position.reserve(soup.triangles.size());
    S.normal.reserve(soup.triangles.size());
    S.positionVariance.reserve(soup.triangles.size());
    S.normalCovariance.reserve(soup.triangles.size());
    for (const auto& t : soup.triangles) {
        const Vec3d& xu = soup.vertices[t[0]];
        const Vec3d& xv = soup.vertices[t[1]];
        const Vec3d& xw = soup.vertices[t[2]];
        const Vec3d e[3] = {xw - xv, xu - xw, xv - xu};
        const Vec3d area2 = (xv - xu).cross(xw - xu);
        if (degenerate(area2, std::max({e[0].squaredNorm(), e[1].squaredNorm(), e[2].squaredNorm()}))) {
            ++out.degenerateSkipped;
            continue;
        }
        // === App. B: ε = (ε_u + ε_v + ε_w)/3, ε' = ½ Σ [e]× ε_vertex; cross terms cancel (Σ e = 0)
        Mat3d cov = Mat3d::Zero();
        for (const Vec3d& ei : e) cov += ei.squaredNorm() * Mat3d::Identity() - ei * ei.transpose();
        S.position.push_back((xu + xv + xw) / 3.0);
        S.normal.push_back(0.5 * area2);
        S.positionVariance.push_back(s2 / 3.0);
        S.normalCovariance.push_back(Sym3::from((s2 / 4.0) * cov));
    }
    return out;
}

}  // namespace gpisvdb
