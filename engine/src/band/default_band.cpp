#include "gpisvdb/band/default_band.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/memory_estimate.h"

namespace gpisvdb {

double physicalMemory() { return double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE)); }

double bandBuildBytes(double voxels, double evaluated, std::size_t batchVoxels, double firstLevel) {
    // While searching: the visited mask and frontier, and either all the found voxels (at the end) or a batch in
    // flight with the voxels found so far (the largest BFS level, ≈ 0.35 of the evaluated voxels, comes when about
    // 0.4 of the band is found; measured on the bunny, a sphere and a cloud, docs/memory.md#band). Then, gathering
    // the channels into leaf order: the found voxels, the index tree, the leaf order (4 B) and the largest channel
    // gathered (the stencil).
    const double batch = kBatchBytesPerVoxel * std::min(double(batchVoxels), kLargestLevelShare * evaluated);
    const double search = kSearchBytesPerEvaluatedVoxel * evaluated +
                          std::max(kFoundBytesPerVoxel * voxels, kFoundBeforeLargestLevel * kFoundBytesPerVoxel * voxels + batch);
    const double gather = voxels * (kFoundBytesPerVoxel + kIndexTreeBytesPerVoxel + 4.0 + double(sizeof(VoxelStencil)));
    // The first level: its coordinates and its evaluated voxels held whole, and the voxels it keeps
    const double first =
        kSearchBytesPerEvaluatedVoxel * evaluated + firstLevel * (double(sizeof(openvdb::Coord) + sizeof(BandVoxel)) + kFoundBytesPerVoxel);
    return std::max({search, gather, first});
}

double bandWriteBytes(double voxels) {
    // The band and the grid being written: a Vec3f grid's leaves hold 12 bytes a voxel where the index tree's hold 4.
    return voxels * (kFoundBytesPerVoxel + 4.0 * kIndexTreeBytesPerVoxel);
}

BandEstimate estimateBand(double bandVolume, double area, double h, std::size_t batchVoxels, double baselineBytes, VoxelValues values) {
    BandEstimate e;
    // === Voxel counts: the shell where μ > η (Resolution::bandVolume) and about half a voxel on either side (with
    // voxel or column values, the reach of the cubes' cross-sections or of the axes' segments); the build also
    // evaluates the rejected shell, a voxel or two on each side (measured, docs/memory.md#band).
    const bool reach = values != VoxelValues::Point;
    const double shell = reach ? kVoxelValueShellVoxels : kBandShellVoxels;
    const double volume = reach ? kVoxelValueBandVolume * bandVolume : bandVolume;
    e.voxels = (volume + shell * area * h) / (h * h * h);
    e.evaluated = (volume + (shell + 3.0) * area * h) / (h * h * h);
    e.memory.baselineBytes = baselineBytes;
    const double build = bandBuildBytes(e.voxels, e.evaluated, batchVoxels), write = bandWriteBytes(e.voxels);
    e.memory.parts = {{build >= write ? "building the band" : "writing the band as .vdb", std::max(build, write)}};
    if (values == VoxelValues::Column)
        e.memory.parts.emplace_back("the centres' Gaussians (column values)",
                                    kColumnCentreBytes * kColumnCentresPerEvaluatedVoxel * e.evaluated);
    return e;
}

DefaultBandPlan planDefaultBand(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options,
                                const Progress& progress) {
    const BandOptions& bo = options.band;
    if (!(bo.etaRelative > 0) || !std::isfinite(bo.etaRelative))
        throw ParameterError(
            "the band threshold η (BandOptions::etaRelative) must be finite and > 0 (got " + numberText(bo.etaRelative) + ")",
            {"BandOptions::etaRelative"});
    if (!(bo.voxelSize >= 0) || !std::isfinite(bo.voxelSize))
        throw ParameterError("the voxel size (BandOptions::voxelSize) must be finite and > 0 (got " + numberText(bo.voxelSize) + ")",
                             {"BandOptions::voxelSize"});
    if (!(options.maxBandVoxels == 0 || (options.maxBandVoxels >= 1000 && std::isfinite(options.maxBandVoxels))))
        throw ParameterError(
            "the band-voxel budget (DefaultBandOptions::maxBandVoxels) must be 0 (none) or a finite "
            "number >= 1000 (got " +
                numberText(options.maxBandVoxels) + ")",
            {"DefaultBandOptions::maxBandVoxels"});
    if (!(options.maxMemory >= 0) || !std::isfinite(options.maxMemory))
        throw ParameterError(
            "the memory limit (DefaultBandOptions::maxMemory) must be finite and > 0 bytes (got " + numberText(options.maxMemory) + ")",
            {"DefaultBandOptions::maxMemory"});
    DefaultBandPlan out;
    out.maxMemory = options.maxMemory > 0 ? options.maxMemory : 0.5 * physicalMemory();

    // === Resolution (paper Eq. 25 and μ's width)
    ResolutionOptions ro;
    const double iso = std::isnan(bo.iso) ? model.naturalIso() : bo.iso;
    if (!std::isfinite(iso)) throw ParameterError("the iso-value u (BandOptions::iso) must be finite", {"BandOptions::iso"});
    ro.iso = iso;
    ro.qmcSamples = bo.qmcSamples;
    ro.resolutionScale = options.resolutionScale;
    ro.maxAnisotropy = bo.maxAnisotropy;
    ro.etaRelative = bo.etaRelative;
    out.resolution = chooseResolution(model, samples, ro, progress.interruptOnly());
    out.options = bo;
    out.options.iso = iso;
    const bool given = out.options.voxelSize > 0;
    double h = given ? out.options.voxelSize : out.resolution.h;
    VoxelValues values = options.values.value_or(VoxelValues::Point);

    // === Estimate before allocating (docs/memory.md#band)
    const double baseline = settledResidentBytes();
    // What the model keeps while it evaluates the band (its cell tables, docs/memory.md#band) does not depend on h.
    const double modelCache = model.expectedDenseCacheBytes();
    const auto estimate = [&](double hh) {
        BandEstimate e = estimateBand(out.resolution.bandVolume, out.resolution.area, hh, bo.batchVoxels, baseline, values);
        if (modelCache > 0) e.memory.parts.emplace_back("the model's tables", modelCache);
        return e;
    };
    out.accuracyVoxelSize = h;
    out.accuracyVoxels = estimate(h).voxels;

    // === The band-voxel budget (docs/band.md#budget): the default h raised, in steps of 1 %, until the band fits
    out.maxBandVoxels = given ? 0.0 : options.maxBandVoxels;
    const auto fitBudget = [&] {
        if (given || !(options.maxBandVoxels > 0) || !(estimate(h).voxels > options.maxBandVoxels)) return;
        for (int k = 0; k < 5000 && estimate(h).voxels > options.maxBandVoxels; ++k) h *= 1.01;
        out.budgeted = true;
    };
    fitBudget();
    // === The values: column values where the budget raised h well above μ's width (docs/band.md#coarse-voxels), and
    // the budget fitted again to their band, whose segments reach further than the centres. A voxel size given is
    // the user's choice of cost, and keeps the centres' values unless column values are asked for.
    if (!options.values && out.budgeted && h > kColumnValuesRatio * out.resolution.muWidth) {
        values = VoxelValues::Column;
        fitBudget();
    }
    out.options.voxelSize = h;
    out.options.values = values;
    out.estimate = estimate(h);
    const double voxels = out.estimate.voxels;
    if (!(voxels <= kMaxBandVoxels))  // absurd whatever the memory: refused before the model is evaluated
        throw MemoryLimitError("the band would need about " + numberText(voxels) + " voxels at voxel size " + numberText(h) +
                                   ", more than the " + numberText(kMaxBandVoxels) +
                                   " a band can hold: use a voxel size (BandOptions::voxelSize) of " +
                                   numberText(h * std::cbrt(voxels / kMaxBandVoxels) * 1.1) + " or larger",
                               {"BandOptions::voxelSize"});
    // As every stage's: the limit bounds what the band adds to the resident set at its start.
    const double need = out.estimate.memory.stageBytes();
    if (need > out.maxMemory && modelCache >= out.maxMemory)  // no voxel size fits
        throw MemoryLimitError("the model's cell tables alone would need about " + numberText(modelCache / 1e6) +
                                   " MB while the band is built, more than the memory limit (DefaultBandOptions::maxMemory) "
                                   "allows: raise the limit",
                               {"DefaultBandOptions::maxMemory"});
    if (need > out.maxMemory) {
        double fits = h;  // the smallest voxel size, in steps of 2 %, whose estimate fits
        for (int k = 0; k < 2000 && estimate(fits).memory.stageBytes() > out.maxMemory; ++k) fits *= 1.02;
        throw MemoryLimitError("the band would need about " + numberText(voxels) + " voxels (" + numberText(need / 1e9) +
                                   " GB) at voxel size " + numberText(h) +
                                   ", more than the memory limit (DefaultBandOptions::maxMemory) allows: use a voxel size "
                                   "(BandOptions::voxelSize) of " +
                                   numberText(fits) + " or larger",
                               {"DefaultBandOptions::maxMemory", "BandOptions::voxelSize"});
    }
    // The backstop while building, should the estimate be low: evaluated voxels are ≈ 1.4–1.6 band voxels (measured).
    const double perVoxel = need / std::max(1.0, voxels);
    out.options.maxVoxels = std::size_t(kEvaluatedPerBandVoxel * out.maxMemory / perVoxel);
    return out;
}

DefaultBand buildPlannedBand(const GpisModel& model, const Samples& samples, const DefaultBandPlan& plan, const BandBuilder& build,
                             const Progress& progress) {
    DefaultBand out;
    static_cast<DefaultBandPlan&>(out) = plan;
    out.result = build ? build(model, samples, out.options, progress) : buildBand(model, samples, out.options, progress);
    return out;
}

DefaultBand buildDefaultBand(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options, const Progress& progress) {
    return buildPlannedBand(model, samples, planDefaultBand(model, samples, options, progress), options.build, progress);
}

double smoothingForPlan(const DefaultBandPlan& plan, const LoadedModel& model) {
    const double want = kVoxelSmoothing * plan.options.voxelSize;
    return plan.options.values == VoxelValues::Voxel && model.trainingSize == 0 && model.smoothing < want ? want : 0.0;
}

DefaultBandPlan replanForSmoothing(const GpisModel& model, const Samples& samples, const DefaultBandOptions& options,
                                   const DefaultBandPlan& first, const Progress& progress) {
    DefaultBandOptions again = options;
    again.band.voxelSize = first.options.voxelSize;
    again.band.iso = first.options.iso;
    again.values = VoxelValues::Voxel;
    DefaultBandPlan second = planDefaultBand(model, samples, again, progress);
    second.accuracyVoxelSize = first.accuracyVoxelSize;
    second.accuracyVoxels = first.accuracyVoxels;
    second.budgeted = first.budgeted;
    second.maxBandVoxels = first.maxBandVoxels;
    return second;
}

DefaultBandPlan planDefaultBandFor(std::shared_ptr<const LoadedModel>& model, const ModelOptions& modelOptions,
                                   const DefaultBandOptions& options, const Progress& progress) {
    const DefaultBandPlan first = planDefaultBand(*model->model, model->input.samples, options, progress);
    const double s = smoothingForPlan(first, *model);
    if (!(s > 0)) return first;
    // === The analysis scale: s follows h, and the band is planned again at the same h (docs/band.md#coarse-voxels)
    model = std::make_shared<const LoadedModel>(withSmoothing(*model, modelOptions, s, SmoothingSource::VoxelSize));
    return replanForSmoothing(*model->model, model->input.samples, options, first, progress);
}

namespace {

/// What a band's values gave on the unit-sphere soup at σ_rel 0.5 against the centres' values at h = w_μ
/// (docs/benchmarks.md#coarse-voxels, #column-values): up to each h / w_μ, the expected area's, the Dirichlet energy's
/// and the l = 1 gap's error.
struct MeasuredAccuracy {
    double ratio;
    const char* errors;
};
constexpr MeasuredAccuracy kPointAccuracy[] = {
    {1.25, "within 0.5 % (the default's own rule)"},
    {2, "area and energy within 0.1 %, l = 1 gap -0.8 %"},
    {4, "area +2.2 %, energy +2.2 %, l = 1 gap -4.9 %"},
    {8, "area +13 %, energy +36 %, l = 1 gap -25 %"},
};
constexpr MeasuredAccuracy kColumnAccuracy[] = {
    {2, "area +0.02 %, energy -0.02 %, l = 1 gap -0.6 %"},
    {4, "area +0.02 %, energy -0.11 %, l = 1 gap -3.0 %"},
    {8, "area -0.28 %, energy -0.21 %, l = 1 gap -15 %"},
    {16, "area +20 %, energy +33 %, l = 1 gap -53 %"},
};

template <std::size_t N>
std::string accuracyNote(double ratio, const MeasuredAccuracy (&table)[N], const char* anchor) {
    for (const MeasuredAccuracy& m : table)
        if (ratio <= m.ratio * (1 + 1e-9))
            return std::string(" (measured on a sphere up to h/w_mu = ") + numberText(m.ratio) + ": " + m.errors + "; docs/benchmarks.md#" +
                   anchor + ")";
    return " (coarser than any h/w_mu measured, " + numberText(table[N - 1].ratio) + ": docs/benchmarks.md#" + anchor + ")";
}

}  // namespace

std::string voxelSizeNote(const DefaultBandPlan& band) {
    const double h = band.options.voxelSize, w = band.resolution.muWidth;
    std::string note = "voxel size " + numberText(h);
    if (!(w > 0)) return note;
    const double ratio = h / w;
    note += " = " + numberText(std::round(ratio * 100) / 100) + " w_mu (mu's width " + numberText(w) + ")";
    switch (band.options.values) {
        case VoxelValues::Point:
            return note + "; mu and T are the values at the voxels' centres" + accuracyNote(ratio, kPointAccuracy, "coarse-voxels");
        case VoxelValues::Column:
            return note + "; mu and T are their means along the voxels' axes (column values)" +
                   accuracyNote(ratio, kColumnAccuracy, "column-values");
        default:
            return note +
                   "; mu and T are the voxels' own shares, s at least 2h (their accuracy by h/w_mu: "
                   "docs/benchmarks.md#coarse-voxels)";
    }
}

}  // namespace gpisvdb
