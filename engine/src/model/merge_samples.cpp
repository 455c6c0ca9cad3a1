#include "gpisvdb/model/merge_samples.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "gpisvdb/core/errors.h"
#include "lattice_cell.h"

namespace gpisvdb {

namespace {

/// A cell's running sums.
struct Merged {
    Vec3d w = Vec3d::Zero();             // Σ w_i
    Vec3d areaPosition = Vec3d::Zero();  // Σ |w_i| p_i
    Vec3d position = Vec3d::Zero();      // Σ p_i (the centroid where every |w_i| is 0)
    double area = 0;                     // Σ |w_i|
    double areaVariance = 0;             // Σ |w_i|² v_i
    double variance = 0;                 // Σ v_i (where every |w_i| is 0)
    Mat3d normalCovariance = Mat3d::Zero();
    std::size_t count = 0;
    std::size_t first = 0;  // the cell's first sample
};

}  // namespace

Samples mergeSamples(const Samples& samples, double cell) {
    if (!(cell > 0) || !std::isfinite(cell))
        throw ParameterError("the merging cell (ModelOptions::mergeRel × s) must be finite and > 0 (got " + numberText(cell) + ")",
                             {"ModelOptions::mergeRel"});
    const std::size_t n = samples.size();
    // Cell indices as 64-bit integers, exact in double: |p| / cell below 2^52.
    double reach = 0;
    for (const Vec3d& p : samples.position) reach = std::max(reach, p.cwiseAbs().maxCoeff());
    if (!(reach / cell < 4.5e15))
        throw ParameterError("the merging cell " + numberText(cell) + " is too small for coordinates as large as " + numberText(reach) +
                                 " (ModelOptions::mergeRel × s must exceed their largest absolute value / 4.5e15)",
                             {"ModelOptions::mergeRel"});
    // === Sum each cell's samples, the cells numbered in the order of their first sample
    std::unordered_map<detail::CellKey, std::size_t, detail::CellKeyHash> index;
    index.reserve(n);
    std::vector<Merged> cells;
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3d& p = samples.position[i];
        const auto [it, added] = index.try_emplace(detail::CellKey::of(p, cell), cells.size());
        if (added) cells.emplace_back().first = i;
        Merged& m = cells[it->second];
        const Vec3d& w = samples.normal[i];
        const double a = w.norm(), v = samples.positionVariance[i];
        m.w += w;
        m.areaPosition += a * p;
        m.position += p;
        m.area += a;
        m.areaVariance += a * a * v;
        m.variance += v;
        m.normalCovariance += samples.normalCovariance[i].matrix();
        ++m.count;
    }
    // === One dipole per cell (docs/math.md#merging)
    Samples out;
    out.lengthScale = samples.lengthScale;
    out.position.reserve(cells.size());
    out.normal.reserve(cells.size());
    out.positionVariance.reserve(cells.size());
    out.normalCovariance.reserve(cells.size());
    for (const Merged& m : cells) {
        if (m.count == 1) {
            out.position.push_back(samples.position[m.first]);
            out.normal.push_back(samples.normal[m.first]);
            out.positionVariance.push_back(samples.positionVariance[m.first]);
            out.normalCovariance.push_back(samples.normalCovariance[m.first]);
            continue;
        }
        const double wNorm2 = m.w.squaredNorm();
        out.position.push_back(m.area > 0 ? Vec3d(m.areaPosition / m.area) : Vec3d(m.position / double(m.count)));
        out.normal.push_back(m.w);
        double v = m.variance / double(m.count);
        if (m.area > 0) v = m.areaVariance / (wNorm2 >= 1e-12 * m.area * m.area ? wNorm2 : m.area * m.area);
        out.positionVariance.push_back(v);
        out.normalCovariance.push_back(Sym3::from(m.normalCovariance));
    }
    return out;
}

}  // namespace gpisvdb
