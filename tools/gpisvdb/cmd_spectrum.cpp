// gpisvdb spectrum INPUT -k K -o OUT.vdb: the k lowest eigenpairs of the GPIS Laplacian (paper Sec. 10.1).
#include <chrono>
#include <cstdio>
#include <iostream>

#include "band_job.h"
#include "commands.h"
#include "gpisvdb/output/write_vdb.h"
#include "spectrum_job.h"

namespace gpisvdb::cli {

namespace {

/// `gpisvdb spectrum` once its flags are parsed.
void execute(SpectrumArgs& a, Clock::time_point start) {
    if (a.eigen.count < 1) throw ParameterError("-k must be >= 1");
    BandCommand run = startBandCommand(a.input, a.output, a.flags);
    const BandJob& job = run.job;
    const Band& band = job.result.band;
    // === Eigenpairs, then one float grid per eigenvector
    const auto tSolve = Clock::now();
    nlohmann::json memoryStage;
    const EigenResult e = runSpectrum(job, a.eigen, run.progress, &memoryStage);
    const double secondsSolve = std::chrono::duration<double>(Clock::now() - tSolve).count();
    std::vector<std::vector<float>> vectors(std::size_t(e.values.size()));
    std::vector<NamedChannel> grids;
    for (Eigen::Index i = 0; i < e.values.size(); ++i) {
        vectors[std::size_t(i)].assign(e.vectors.col(i).data(), e.vectors.col(i).data() + e.vectors.rows());
        grids.push_back({eigenGridName(int(i)), &vectors[std::size_t(i)]});
    }
    openvdb::MetaMap meta = bandMetadata(job, a.flags);
    for (Eigen::Index i = 0; i < e.values.size(); ++i)
        meta.insertMeta(eigenGridName(int(i)) + "_eigenvalue", openvdb::DoubleMetadata(e.values(i)));
    meta.insertMeta("spectrum_max_residual", openvdb::DoubleMetadata(e.residuals.maxCoeff()));
    writeBandVdb(band, run.out->tempPath(), meta, grids, {}, a.flags.vdb);
    run.out->commit();
    const double total = std::chrono::duration<double>(Clock::now() - start).count();
    if (run.report) {
        nlohmann::json report = app::bandReport(job);
        report["spectrum"] = spectrumReport(e);
        report["memory"]["stages"] = {{"spectrum", memoryStage}};
        report["timings_s"] = {{"model", job.secondsModel}, {"band", job.secondsBand}, {"solve", secondsSolve}, {"total", total}};
        report["outputs"] = {a.output};
        commitReport(*run.report, report);
    }
    if (!a.flags.model.quiet)
        std::cerr << "spectrum: " << band.size() << " voxels, " << e.values.size() << " eigenpairs, lambda " << e.values(0) << " ... "
                  << e.values(e.values.size() - 1) << ", max residual " << e.residuals.maxCoeff() << ", " << total << " s\n";
}

}  // namespace

void addSpectrum(CLI::App& app, Action& action) {
    addCommand<SpectrumArgs>(
        app, action, "spectrum",
        {"lowest eigenpairs of the GPIS Laplacian (L u = lambda M u), as a .vdb",
         "Eigenvectors are M-orthonormal (sum of u_i u_j mu h^3 = delta_ij), u = 0 outside the band; eigenvalues\n"
         "(world units^-2) ascending in the report (spectrum.eigenvalues, spectrum.residuals) and the file metadata.\n"
         "Example:\n  gpisvdb spectrum bunny.obj -k 20 -o spectrum.vdb --sigma 1 --report spectrum.json"},
        [](CLI::App& cmd, SpectrumArgs& a) { addSpectrumFlags(cmd, a, "output .vdb (band grids and eigen_000, eigen_001, ...)"); },
        bandThreads<SpectrumArgs>, [](SpectrumArgs& a, Clock::time_point start) { execute(a, start); });
}

}  // namespace gpisvdb::cli
