// gpisvdb hodge INPUT (--field FILE.vdb[:GRID] | --preset rotation|gradient|mixed) -o OUT.vdb: Hodge decomposition of
// a vector field on the GPIS (paper Eq. 29, Fig. 10).
#include <openvdb/tools/Interpolation.h>

#include <chrono>
#include <iostream>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/tasks/hodge.h"
#include "vdb_file.h"

namespace gpisvdb::cli {

namespace {

/// A Vec3 grid of a .vdb ("FILE.vdb" takes its only vector grid; "FILE.vdb:NAME" the grid NAME), sampled
/// trilinearly in world space at the band's voxel centres; 0 where the grid is inactive.
std::vector<float> readField(const std::string& spec, const Band& band) {
    const auto [path, name] = VdbFile::splitSpec(spec);
    const openvdb::Vec3SGrid::Ptr field = VdbFile::read(path).vectorGrid(name);
    std::vector<float> V(3 * band.size());
    const openvdb::tools::GridSampler<openvdb::Vec3SGrid, openvdb::tools::BoxSampler> sampler(*field);
    for (std::size_t i = 0; i < band.size(); ++i) {
        const openvdb::Vec3s v = sampler.wsSample(openvdb::Vec3d(band.coord[i].asVec3d() * band.voxelSize));
        for (int c = 0; c < 3; ++c) {
            if (!std::isfinite(v[c])) throw InputError(spec + ": the field holds NaN or infinite values in the band");
            V[3 * i + std::size_t(c)] = v[c];
        }
    }
    return V;
}

struct Args {
    std::string input, output, field, preset, boundary = "neumann";
    BandFlags flags;
    PcgOptions solver;
};

/// The flags of `gpisvdb hodge`.
void addFlags(CLI::App& cmd, Args& a) {
    cmd.add_option("INPUT", a.input, kInputHelp)->required();
    auto* field = cmd.add_option("--field", a.field,
                                 "vector field FILE.vdb or FILE.vdb:GRID (Vec3s grid, world units), sampled at the band's voxels");
    auto* preset = cmd.add_option("--preset", a.preset,
                                  "built-in field: rotation (about z through the mu-centroid), gradient (grad_phi z) or mixed (their sum)")
                       ->check(CLI::IsMember({"rotation", "gradient", "mixed"}));
    field->excludes(preset);
    cmd.add_option("-o,--output", a.output, "output .vdb (band grids, hodge_input, hodge_gradient, hodge_free, hodge_potential)")
        ->required();
    cmd.add_option("--boundary", a.boundary, "condition on the potential at the band's boundary: neumann (free) or dirichlet (0)")
        ->check(CLI::IsMember({"neumann", "dirichlet"}))
        ->capture_default_str();
    addBandFlags(cmd, a.flags);
    addSolverFlags(cmd, a.solver, SolverFlags::ToleranceOnly);
}

/// The vector field to decompose: a preset's, or one read from a .vdb (vector grid, or three float grids).
std::vector<float> inputField(const Args& a, const Band& band) {
    if (a.preset.empty()) return readField(a.field, band);
    const HodgePreset p = a.preset == "rotation"   ? HodgePreset::Rotation
                          : a.preset == "gradient" ? HodgePreset::Gradient
                                                   : HodgePreset::Mixed;
    return hodgePreset(band, p);
}

openvdb::MetaMap hodgeMetadata(const Args& a, const BandJob& job, const HodgeResult& r) {
    openvdb::MetaMap meta = bandMetadata(job, a.flags);
    meta.insertMeta("hodge_field", openvdb::StringMetadata(a.preset.empty() ? a.field : "preset:" + a.preset));
    meta.insertMeta("hodge_boundary", openvdb::StringMetadata(a.boundary));
    meta.insertMeta("hodge_divergence_residual", openvdb::DoubleMetadata(r.divergenceResidual));
    meta.insertMeta("hodge_s_inner_product", openvdb::DoubleMetadata(r.sInnerProduct));
    meta.insertMeta("solver_iterations", openvdb::Int32Metadata(r.solver.iterations));
    meta.insertMeta("solver_relative_residual", openvdb::DoubleMetadata(r.solver.relativeResidual));
    meta.insertMeta("solver_float_residual", openvdb::DoubleMetadata(r.solver.floatResidual));
    meta.insertMeta("solver_refinements", openvdb::Int32Metadata(r.solver.refinements));
    return meta;
}

nlohmann::json hodgeSection(const Args& a, const Band& band, const std::vector<float>& V, const HodgeResult& r) {
    return {{"field", a.preset.empty() ? a.field : "preset:" + a.preset},
            {"boundary", a.boundary},
            {"divergence_residual", r.divergenceResidual},
            {"s_inner_product", r.sInnerProduct},
            {"s_norm_input", std::sqrt(sInnerProduct(band, V, V))},
            {"s_norm_gradient", std::sqrt(sInnerProduct(band, r.gradient, r.gradient))},
            {"s_norm_free", std::sqrt(sInnerProduct(band, r.free, r.free))}};
}

/// `gpisvdb hodge` once its flags are parsed.
void execute(Args& a, Clock::time_point start) {
    if (a.field.empty() == a.preset.empty())
        throw ParameterError("give exactly one of --field FILE.vdb[:GRID] and --preset rotation|gradient|mixed");
    checkPcgOptions(a.solver);
    BandCommand run = startBandCommand(a.input, a.output, a.flags);
    const BandJob& job = run.job;
    const Band& band = job.result.band;

    // === The field on the band, then the decomposition
    const std::vector<float> V = inputField(a, band);
    HodgeOptions ho;
    ho.solver = a.solver, ho.boundary = a.boundary == "dirichlet" ? Boundary::Dirichlet : Boundary::Neumann;
    // The decomposition's memory: estimated and refused before it allocates, measured over it (docs/memory.md)
    const MemoryEstimate memory = estimateStage(job, "Hodge decomposition", {{"hodge", hodgeBytes(band.size(), ho)}});
    const bool stageOnly = resetPeakResident();
    const auto tSolve = Clock::now();
    const HodgeResult r = hodgeDecomposition(band, V, ho, run.progress);
    const double secondsSolve = std::chrono::duration<double>(Clock::now() - tSolve).count();
    const double solvePeak = peakResidentBytes();
    requireConverged(r.solver, a.solver);

    const openvdb::MetaMap meta = hodgeMetadata(a, job, r);
    writeBandVdb(band, run.out->tempPath(), meta, {{"hodge_potential", &r.potential}},
                 {{"hodge_input", &V}, {"hodge_gradient", &r.gradient}, {"hodge_free", &r.free}}, a.flags.vdb);
    run.out->commit();
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    if (run.report) {
        nlohmann::json report = app::bandReport(job);
        report["solver"] = app::solverReport(r.solver, a.solver);
        report["memory"]["stages"] = {{"hodge", memoryStageReport(memory, solvePeak, stageOnly)}};
        report["hodge"] = hodgeSection(a, band, V, r);
        report["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"solve", secondsSolve}, {"total", total}};
        report["outputs"] = {a.output};
        commitReport(*run.report, report);
    }
    if (!a.flags.model.quiet)
        std::cerr << "hodge: " << band.size() << " voxels, PCG " << r.solver.iterations
                  << " iterations, D_phi V_free / D_phi V = " << r.divergenceResidual << ", S-cosine " << r.sInnerProduct << ", " << total
                  << " s\n";
}

}  // namespace

void addHodge(CLI::App& app, Action& action) {
    addCommand<Args>(app, action, "hodge",
                     {"Hodge decomposition of a vector field on the GPIS into a gradient and a mu-divergence-free part, as a .vdb",
                      "V = grad_phi psi + V_free with D_phi V_free = 0: (G^T BlockDiag(h^3 T) G) psi = G^T (M x I) V by the PCG.\n"
                      "The two parts are orthogonal in the inner product S = mu^2 T^-1 (paper App. E).\n"
                      "Examples:\n  gpisvdb hodge bunny.obj --preset mixed -o hodge.vdb --sigma 1\n"
                      "  gpisvdb hodge bunny.obj --field wind.vdb:vel -o hodge.vdb --report hodge.json"},
                     addFlags, bandThreads<Args>, [](Args& a, Clock::time_point start) { execute(a, start); });
}

}  // namespace gpisvdb::cli
