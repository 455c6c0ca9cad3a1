#include "gpisvdb/band/default_band.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

double physicalMemory() { return double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE)); }

DefaultBand buildDefaultBand(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options,
                             const Progress& progress) {
    const BandOptions& bo = options.band;
    if (!(bo.etaRelative > 0) || !std::isfinite(bo.etaRelative))
        throw ParameterError("the band threshold η (BandOptions::etaRelative) must be finite and > 0 (got " +
                                 numberText(bo.etaRelative) + ")",
                             {"BandOptions::etaRelative"});
    if (!(bo.voxelSize >= 0) || !std::isfinite(bo.voxelSize))
        throw ParameterError("the voxel size (BandOptions::voxelSize) must be finite and > 0 (got " + numberText(bo.voxelSize) + ")",
                             {"BandOptions::voxelSize"});
    if (!(options.maxMemory >= 0) || !std::isfinite(options.maxMemory))
        throw ParameterError("the memory limit (DefaultBandOptions::maxMemory) must be finite and > 0 bytes (got " +
                                 numberText(options.maxMemory) + ")",
                             {"DefaultBandOptions::maxMemory"});
    DefaultBand out;
    out.maxMemory = options.maxMemory > 0 ? options.maxMemory : 0.5 * physicalMemory();

    // === Resolution (paper Eq. 25 and μ's width)
    ResolutionOptions ro;
    const double iso = std::isnan(bo.iso) ? model.naturalIso() : bo.iso;
    if (!std::isfinite(iso))
        throw ParameterError("the iso-value u (BandOptions::iso) must be finite", {"BandOptions::iso"});
    ro.iso = iso;
    ro.qmcSamples = bo.qmcSamples;
    ro.resolutionScale = options.resolutionScale;
    ro.maxAnisotropy = bo.maxAnisotropy;
    out.resolution = chooseResolution(model, samples, ro, progress.interruptOnly());
    out.options = bo;
    out.options.iso = iso;
    if (!(out.options.voxelSize > 0)) out.options.voxelSize = out.resolution.h;
    const double h = out.options.voxelSize;

    // === Estimate before allocating: area × (width where μ > η) / h³, plus the rejected shell
    double area = 0;
    for (const auto& w : samples.normal) area += w.norm();
    const double eta = std::min(bo.etaRelative, 0.5);
    const double thickness = 2.0 * out.resolution.muWidth * std::sqrt(2.0 * std::log(1.0 / eta)) + 4.0 * h;
    const double estimate = area * thickness / (h * h * h);
    if (!(estimate <= kMaxBandVoxels))  // absurd whatever the memory: refused before the model is evaluated
        throw MemoryLimitError("the band would need about " + numberText(estimate) + " voxels at voxel size " + numberText(h) +
                                   ", more than the " + numberText(kMaxBandVoxels) +
                                   " a band can hold: use a voxel size (BandOptions::voxelSize) of " +
                                   numberText(h * std::cbrt(estimate / kMaxBandVoxels) * 1.1) + " or larger",
                               {"BandOptions::voxelSize"});
    if (estimate * kBuildBytesPerVoxel > out.maxMemory) {
        const double suggest = h * std::cbrt(estimate * kBuildBytesPerVoxel / out.maxMemory) * 1.1;
        throw MemoryLimitError("the band would need about " + numberText(estimate) + " voxels (" +
                                   numberText(estimate * kBuildBytesPerVoxel / 1e9) + " GB) at voxel size " + numberText(h) +
                                   ", more than the memory limit (DefaultBandOptions::maxMemory) allows: use a voxel size "
                                   "(BandOptions::voxelSize) of " + numberText(suggest) + " or larger",
                               {"DefaultBandOptions::maxMemory", "BandOptions::voxelSize"});
    }
    out.options.maxVoxels = std::size_t(out.maxMemory / kBuildBytesPerVoxel);
    out.result = buildBand(model, samples, out.options, progress);
    return out;
}

}  // namespace gpisvdb
