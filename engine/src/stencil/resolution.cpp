#include "gpisvdb/stencil/resolution.h"

#include <algorithm>
#include <cmath>
#include <Eigen/Eigenvalues>
#include <tbb/parallel_for.h>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/stencil/selling.h"

namespace gpisvdb {

Mat3d regularise(const Mat3d& T, double maxAnisotropy, bool& changed) {
    const Eigen::SelfAdjointEigenSolver<Mat3d> eig(T, Eigen::EigenvaluesOnly);  // once per band voxel: no vectors
    const double lmax = eig.eigenvalues().maxCoeff(), lmin = eig.eigenvalues().minCoeff();
    const double floor = lmax / (maxAnisotropy * maxAnisotropy);
    changed = lmax > 0 && lmin < floor;
    if (!changed) return T;
    Mat3d R = T;
    R.diagonal().array() += floor - lmin;
    return R;
}

Resolution chooseResolution(const GpisModel& model, const Samples& samples, const ResolutionOptions& options, const Progress& progress) {
    if (!(options.resolutionScale > 0) || !std::isfinite(options.resolutionScale))
        throw ParameterError("the resolution scale (ResolutionOptions::resolutionScale) must be finite and > 0",
                             {"ResolutionOptions::resolutionScale"});
    if (!(options.maxAnisotropy >= 1))
        throw ParameterError("the anisotropy cap (ResolutionOptions::maxAnisotropy) must be >= 1", {"ResolutionOptions::maxAnisotropy"});
    const QmcRule rule(options.qmcSamples);
    // === The samples evaluated: all, or every k-th (ResolutionOptions::maxSamples)
    const std::size_t n = samples.size();
    const std::size_t stride = options.maxSamples > 0 && n > options.maxSamples ? (n + options.maxSamples - 1) / options.maxSamples : 1;
    std::vector<std::size_t> taken;
    for (std::size_t i = 0; i < n; i += stride) taken.push_back(i);
    std::vector<Vec3d> subset;
    if (stride > 1)
        for (std::size_t i : taken) subset.push_back(samples.position[i]);
    const std::vector<ValueGradient> z = model.evaluate(stride > 1 ? subset : samples.position, progress);
    std::vector<int> width(z.size(), 0);
    std::vector<double> muWidth(z.size(), 0), mu(z.size(), 0), muPeak(z.size(), 0);
    tbb::parallel_for(std::size_t(0), z.size(), [&](std::size_t i) {
        progress.checkInterruptAt(i);
        const SurfaceDensity d = kacRice(z[i], options.iso, rule);
        bool changed = false;
        if (d.mu > 0) width[i] = selling(regularise(d.T, options.maxAnisotropy, changed)).width();
        const double g = z[i].mean.tail<3>().norm();
        muWidth[i] = g > 0 ? std::sqrt(std::max(0.0, z[i].cov(0, 0))) / g : 0.0;
        mu[i] = d.mu;
        // μ across the surface ≈ a Gaussian of width w_i about the mean surface, the sample at (γ − u)/‖∇γ‖ from it.
        const double offset = muWidth[i] > 0 ? (z[i].mean[0] - options.iso) / g / muWidth[i] : 0.0;
        muPeak[i] = d.mu * std::exp(std::min(50.0, 0.5 * offset * offset));
    });
    Resolution r;
    // === The band's cross-section from each sample's width where μ > η (see Resolution::bandVolume)
    std::nth_element(mu.begin(), mu.begin() + long(mu.size() / 2), mu.end());  // (mu is not read after this)
    const double eta = std::min(options.etaRelative, 0.5) * mu[mu.size() / 2];
    double takenArea = 0;
    for (std::size_t i = 0; i < z.size(); ++i) {
        const double a = samples.normal[taken[i]].norm();
        takenArea += a;
        if (eta > 0 && muPeak[i] > eta) r.bandVolume += a * 2.0 * muWidth[i] * std::sqrt(2.0 * std::log(muPeak[i] / eta));
    }
    for (const Vec3d& w : samples.normal) r.area += w.norm();
    if (takenArea > 0) r.bandVolume *= r.area / takenArea;
    r.maxStencilL1 = std::max(1, *std::max_element(width.begin(), width.end()));
    r.hStar = options.resolutionScale * samples.lengthScale / r.maxStencilL1;
    std::nth_element(muWidth.begin(), muWidth.begin() + long(muWidth.size() / 2), muWidth.end());
    r.muWidth = muWidth[muWidth.size() / 2];
    // w_μ is scaled by c too, so that --resolution-scale refines the grid whichever term binds (at small σ the
    // w_μ term does, and scaling h* alone would change nothing).
    r.h = r.muWidth > 0 ? std::min(r.hStar, options.resolutionScale * kMuWidthFactor * r.muWidth) : r.hStar;
    return r;
}

}  // namespace gpisvdb
