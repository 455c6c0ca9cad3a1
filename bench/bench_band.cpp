// Band figures (issue "Kac–Rice fields ... narrow band"): expected area Σ μ h³ against σ on the unit sphere,
// band size N against σ and η on the bunny (paper Fig. 7 top), BFS against the scan (Fig. 7 bottom), μ+T
// throughput on 1 and 2 threads, bytes per band voxel, the cost per band voxel against n (growth); and (--part
// bound only) what looser Barnes–Hut opening ratios would buy: band time against the model's error, the bound on
// what its expansions can give (docs/benchmarks.md).
// Usage: bench_band [--part area|fig7|scan|scanfine|throughput|growth|all|bound] [--out bench/results/band.json] [--data DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <tbb/global_control.h>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/band/default_band.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/accuracy.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/model/per_point.h"
#include "gpisvdb/stencil/resolution.h"

using namespace gpisvdb;
using Clock = std::chrono::steady_clock;

namespace {
double seconds(Clock::time_point a) { return std::chrono::duration<double>(Clock::now() - a).count(); }

/// Both builders on the same input and options, timed; they must agree (the tests check it).
nlohmann::json compareBuilders(const GpisModel& model, const Samples& samples, const BandOptions& o) {
    auto t = Clock::now();
    const BandResult bfs = buildBand(model, samples, o);
    const double tb = seconds(t);
    t = Clock::now();
    const BandResult scan = scanBand(model, samples, o);
    const double ts = seconds(t);
    const auto bb = scan.band.bbox();
    return {{"h", o.voxelSize},
            {"band_voxels_bfs", bfs.band.size()},
            {"band_voxels_scan", scan.band.size()},
            {"evaluated_bfs", bfs.stats.evaluated},
            {"evaluated_scan", scan.stats.evaluated},
            {"bbox_voxels", {bb.dim().x(), bb.dim().y(), bb.dim().z()}},
            {"seconds_bfs", tb},
            {"seconds_scan", ts},
            {"speedup", ts / tb}};
}

double soupArea(const Samples& s) {
    double a = 0;
    for (const auto& w : s.normal) a += w.norm();
    return a;
}
}  // namespace

int main(int argc, char** argv) {
    std::string part = "all", out = "bench/results/band.json", data = "data";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--part" && i + 1 < argc) part = argv[++i];
        else if (a == "--out" && i + 1 < argc) out = argv[++i];
        else if (a == "--data" && i + 1 < argc) data = argv[++i];
        else {
            std::cerr << "usage: bench_band [--part area|fig7|scan|scanfine|throughput|growth|all|bound] [--out FILE.json] [--data DIR]\n";
            return 2;
        }
    }
    nlohmann::json report;
    {
        std::ifstream in(out);
        if (in) try {
                in >> report;
            } catch (...) {
                report = nlohmann::json::object();
            }
    }
    const TriangleSoup bunny = *readInput(data + "/bunny.obj").soup;

    if (part == "area" || part == "all") {
        // === Σ μ h³ against σ on a 1280-triangle unit sphere. The mass needs h ≲ 1.5 w_μ only (a Gaussian
        // profile summed at spacing h: error ≈ 2 exp(−2π² w²/h²) ≈ 3e-4), 27× fewer voxels than a fine grid
        // h = w_μ/2; the first row checks the two agree (bench_resolution measures the whole range).
        report["sphere_area"] = nlohmann::json::array();
        for (double sigma : {1.0, 1.0, 0.5, 0.25, 0.1}) {
            const bool fine = report["sphere_area"].empty();
            const SoupSamples ss = soupSamples(icosphere(3), {sigma});
            const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
            const Resolution res = chooseResolution(model, ss.samples);
            BandOptions o;
            o.voxelSize = fine ? 0.5 * res.muWidth : std::min(res.hStar, 1.5 * res.muWidth);
            const auto t = Clock::now();
            const BandResult b = buildBand(model, ss.samples, o);
            nlohmann::json row = {{"sigma_rel", sigma},
                                  {"h", o.voxelSize},
                                  {"h_over_mu_width", o.voxelSize / res.muWidth},
                                  {"h_star", res.hStar},
                                  {"mu_width", res.muWidth},
                                  {"voxels", b.band.size()},
                                  {"mass", b.band.mass()},
                                  {"soup_area", soupArea(ss.samples)},
                                  {"sphere_area", 4 * M_PI},
                                  {"relative_error_vs_soup", b.band.mass() / soupArea(ss.samples) - 1},
                                  {"seconds", seconds(t)}};
            std::cout << row.dump() << std::endl;
            report["sphere_area"].push_back(row);
            std::ofstream(out) << report.dump(2) << "\n";
        }
    }
    if (part == "fig7" || part == "all") {
        // === Band size N against σ for three η, at h = h* (Eq. 25 alone, as the paper's Fig. 7)
        report["fig7_band_size"] = nlohmann::json::array();
        for (double sigma : {0.25, 0.5, 1.0, 2.0}) {
            const SoupSamples ss = soupSamples(bunny, {sigma});
            const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
            const Resolution res = chooseResolution(model, ss.samples);
            for (double eta : {0.1, 0.01, 0.001}) {
                BandOptions o;
                o.voxelSize = res.hStar;
                o.etaRelative = eta;
                const auto t = Clock::now();
                const BandResult b = buildBand(model, ss.samples, o);
                const auto bb = b.band.bbox();
                nlohmann::json row = {{"sigma_rel", sigma},
                                      {"eta_rel", eta},
                                      {"h", res.hStar},
                                      {"voxels", b.band.size()},
                                      {"bbox_voxels", {bb.dim().x(), bb.dim().y(), bb.dim().z()}},
                                      {"mass", b.band.mass()},
                                      {"seconds", seconds(t)}};
                std::cout << row.dump() << std::endl;
                report["fig7_band_size"].push_back(row);
            }
            std::ofstream(out) << report.dump(2) << "\n";
        }
    }
    if (part == "scan" || part == "all") {
        // === BFS against the scan at three resolutions (bunny, σ = 1)
        report["bfs_vs_scan"] = nlohmann::json::array();
        const SoupSamples ss = soupSamples(bunny, {1.0});
        const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
        const Resolution res = chooseResolution(model, ss.samples);
        for (double factor : {3.0, 2.0, 1.4}) {
            BandOptions o;
            o.voxelSize = factor * res.hStar;
            const nlohmann::json row = compareBuilders(model, ss.samples, o);
            std::cout << row.dump() << std::endl;
            report["bfs_vs_scan"].push_back(row);
            std::ofstream(out) << report.dump(2) << "\n";
        }
    }
    if (part == "scanfine" || part == "all") {
        // === BFS against the scan at the finest resolution we can afford: bunny, σ = 0.25, h = h* (6.5 M-voxel box)
        const SoupSamples ss = soupSamples(bunny, {0.25});
        const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
        const Resolution res = chooseResolution(model, ss.samples);
        BandOptions o;
        o.voxelSize = res.hStar;
        nlohmann::json row = compareBuilders(model, ss.samples, o);
        row["sigma_rel"] = 0.25;
        std::cout << row.dump() << std::endl;
        report["bfs_vs_scan_fine"] = row;
        std::ofstream(out) << report.dump(2) << "\n";
    }
    if (part == "throughput" || part == "all") {
        // === Band throughput on the bunny at three σ and the default voxel size, 1 and 2 threads, side by side: the
        // default batch path (packets with the far field shared per cell, near field in float), the packets without
        // cells (BarnesHutOptions::cellWidth = 0), the default with the near field in double (floatNearField = false)
        // and the per-point reference path (PerPointModel), with the time per stage of the default build.
        report["throughput"] = nlohmann::json::array();
        for (double sigma : {0.25, 0.5, 1.0}) {
            const SoupSamples ss = soupSamples(bunny, {sigma});
            const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
            BarnesHutOptions inDouble;
            inDouble.floatNearField = false;
            const PerPointModel reference(model);
            BarnesHutOptions noCells;
            noCells.cellWidth = 0;
            const BarnesHutGpis modelPackets(ss.samples, 0.4 * ss.samples.lengthScale, noCells);
            const Resolution res = chooseResolution(modelPackets, ss.samples);
            BandOptions o;
            o.voxelSize = res.h;
            nlohmann::json row = {{"sigma_rel", sigma}, {"h", o.voxelSize}, {"h_star", res.hStar}, {"mu_width", res.muWidth}};
            double massPacket = 0, massDouble = 0, massNoCells = 0, massReference = 0;
            for (int threads : {1, 2}) {
                tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
                const std::string t = "_" + std::to_string(threads) + "t";
                for (const std::string path : {"", "_packets", "_double", "_reference"}) {
                    const bool packets = path.empty();  // (the default path; the name of its keys predates cells)
                    // The reference costs ~8× more: run it on 1 thread, and only where it takes a few minutes at most.
                    if (path == "_reference" && (threads > 1 || row["evaluated"].get<double>() > 6e5)) continue;
                    // Cells keep their tables for later batches: a fresh model per run, so that no run finds another's.
                    const bool cells = packets || path == "_double";
                    const std::optional<BarnesHutGpis> fresh =
                        cells ? std::optional<BarnesHutGpis>(std::in_place, ss.samples, 0.4 * ss.samples.lengthScale,
                                                             packets ? BarnesHutOptions{} : inDouble)
                              : std::nullopt;
                    const GpisModel& m = cells                ? static_cast<const GpisModel&>(*fresh)
                                         : path == "_packets" ? static_cast<const GpisModel&>(modelPackets)
                                                              : reference;
                    const auto start = Clock::now();
                    const BandResult b = buildBand(m, ss.samples, o);
                    const double sec = seconds(start);
                    row["voxels"] = b.band.size();
                    row["evaluated"] = b.stats.evaluated;
                    row["voxels_per_s" + path + t] = double(b.band.size()) / sec;
                    row["evaluated_per_s" + path + t] = double(b.stats.evaluated) / sec;
                    row["seconds" + path + t] = sec;
                    (packets              ? massPacket
                     : path == "_double"  ? massDouble
                     : path == "_packets" ? massNoCells
                                          : massReference) = b.band.mass();
                    if (packets) {
                        row["stage_seconds" + t] = {{"model", b.stats.modelSeconds},
                                                    {"kac_rice", b.stats.kacRiceSeconds},
                                                    {"search", b.stats.searchSeconds},
                                                    {"finish", b.stats.finishSeconds}};
                        row["bytes_per_voxel"] = b.band.bytesPerVoxel();
                        row["cell_cache_bytes"] = fresh->cellCacheBytes();
                    } else if (path == "_packets") {
                        row["speedup_vs_packets" + t] = sec / row["seconds" + t].get<double>();
                    } else {
                        row[std::string(path == "_double" ? "speedup_vs_double" : "speedup") + t] = sec / row["seconds" + t].get<double>();
                    }
                }
            }
            if (massReference > 0) row["mass_relative_difference_vs_reference"] = massPacket / massReference - 1;
            row["mass_relative_difference_vs_double"] = massPacket / massDouble - 1;
            row["mass_relative_difference_vs_packets"] = massPacket / massNoCells - 1;
            row["mass"] = massPacket;
            row["tree_bytes_per_sample"] = double(model.memoryBytes()) / double(ss.samples.size());
            std::cout << row.dump() << std::endl;
            report["throughput"].push_back(row);
            std::ofstream(out) << report.dump(2) << "\n";
        }
    }
    if (part == "growth" || part == "all") {
        // === Issue 17 item 3, the cost per band voxel against n: the bands of sphere soups of 1 280 … 1.31e6 samples
        // (σ_rel 0.5, s = 0.4ℓ) on 2 threads, the default band (buildDefaultBand) with cells and without
        // (cellWidth = 0) side by side. At twice the default voxel size (resolutionScale 2, h ≈ 0.29ℓ), because at
        // the default the 1.31e6-sample band holds ≈ 1.5e8 voxels (≈ 19 GB); this one holds 1.9e7 (≈ 6.6 GB peak).
        report["growth"] = nlohmann::json::array();
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        for (int level = 3; level <= 8; ++level) {
            const Samples samples = soupSamples(icosphere(level), {0.5}).samples;
            DefaultBandOptions options;
            options.resolutionScale = 2;
            nlohmann::json row = {{"input", "sphere_l" + std::to_string(level)},
                                  {"n", samples.size()},
                                  {"threads", 2},
                                  {"resolution_scale", options.resolutionScale}};
            for (const std::string path : {"", "_packets"}) {
                BarnesHutOptions bo;
                if (!path.empty()) bo.cellWidth = 0;
                const BarnesHutGpis model(samples, 0.4 * samples.lengthScale, bo);
                const double expectedTables = model.expectedDenseCacheBytes();  // what the band's estimate counts
                const auto start = Clock::now();
                const DefaultBand d = buildDefaultBand(model, samples, options);
                const double sec = seconds(start);
                const BandStats& st = d.result.stats;
                row["h_over_l"] = d.options.voxelSize / samples.lengthScale;
                row["voxels"] = d.result.band.size();
                row["evaluated"] = st.evaluated;
                row["seconds" + path] = sec;
                row["us_per_voxel" + path] = 1e6 * sec / double(d.result.band.size());
                row["model_us_per_evaluated" + path] = 1e6 * st.modelSeconds / double(st.evaluated);
                row["mass" + path] = d.result.band.mass();
                if (path.empty()) {
                    row["cell_cache_bytes"] = model.cellCacheBytes();
                    row["cell_cache_limit"] = model.cellCacheLimit();
                    row["cell_cache_estimate"] = expectedTables;
                }
            }
            row["speedup_vs_packets"] = row["seconds_packets"].get<double>() / row["seconds"].get<double>();
            std::cout << row.dump() << std::endl;
            report["growth"].push_back(row);
            std::ofstream(out) << report.dump(2) << "\n";
        }
        // At 1e4 samples: log-interpolated between 5 120 and 20 480 (levels 4 and 5).
        const auto& g = report["growth"];
        const double t = std::log(1e4 / 5120.0) / std::log(4.0);
        for (const std::string key : {"us_per_voxel", "model_us_per_evaluated", "us_per_voxel_packets", "model_us_per_evaluated_packets"}) {
            const double at1e4 = std::exp((1 - t) * std::log(g[1][key].get<double>()) + t * std::log(g[2][key].get<double>()));
            report["growth_ratio_vs_1e4"][key] = g[5][key].get<double>() / at1e4;
        }
        std::cout << report["growth_ratio_vs_1e4"].dump() << std::endl;
        std::ofstream(out) << report.dump(2) << "\n";
    }
    if (part == "bound") {
        // === The band at looser opening ratios (β, and the covariance's ratio in units of β; default 6 and 2), 1 and
        // 2 threads, on the bunny at the default voxel size: its time against the model's error on the band's own
        // voxels (every 97th, against the direct sum). With the expansions' orders unchanged the looser ratios break
        // the 1e-3 bound; their time is what a higher-order expansion opening at that ratio could reach at best, were
        // its terms free.
        report["opening_bound"] = nlohmann::json::array();
        const std::pair<double, double> openings[] = {{6, 2}, {6, 1}, {5, 2}, {4, 2}, {4, 1}, {3, 1}};
        for (double sigma : {0.25, 0.5, 1.0}) {
            const SoupSamples ss = soupSamples(bunny, {sigma});
            const double sm = 0.4 * ss.samples.lengthScale;
            BandOptions o;
            o.voxelSize = chooseResolution(BarnesHutGpis(ss.samples, sm), ss.samples).h;
            const DirectGpis direct(ss.samples, sm);
            std::vector<Vec3d> xs;
            std::vector<ValueGradient> ref;
            double defaultSeconds[2] = {0, 0}, defaultMass = 0;
            for (const auto& [beta, ratio] : openings) {
                BarnesHutOptions bo;
                bo.beta = beta;
                bo.covarianceRatio = ratio;
                const BarnesHutGpis model(ss.samples, sm, bo);
                nlohmann::json row = {{"sigma_rel", sigma}, {"h", o.voxelSize}, {"beta", beta}, {"covariance_ratio", ratio}};
                for (int threads : {1, 2}) {
                    tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
                    const auto start = Clock::now();
                    const BandResult b = buildBand(model, ss.samples, o);
                    const double sec = seconds(start);
                    const std::string t = "_" + std::to_string(threads) + "t";
                    if (xs.empty())
                        for (std::size_t i = 0; i < b.band.size(); i += 97) {
                            const openvdb::Coord& k = b.band.coord[i];
                            xs.push_back(o.voxelSize * Vec3d(k.x(), k.y(), k.z()));
                        }
                    if (ref.empty()) ref = direct.evaluate(xs);
                    if (defaultSeconds[threads - 1] == 0) defaultSeconds[threads - 1] = sec, defaultMass = b.band.mass();
                    row["seconds" + t] = sec;
                    row["model_seconds" + t] = b.stats.modelSeconds;
                    row["voxels_per_s" + t] = double(b.band.size()) / sec;
                    row["speedup_vs_default" + t] = defaultSeconds[threads - 1] / sec;
                    row["voxels"] = b.band.size();
                    row["mass_relative_difference_vs_default"] = b.band.mass() / defaultMass - 1;
                }
                const ModelError e = compareModels(ref, model.evaluate(xs));
                row["error_mean"] = *std::max_element(e.maxRel.begin(), e.maxRel.begin() + 4);
                row["error_covariance"] = *std::max_element(e.maxRel.begin() + 4, e.maxRel.end());
                row["error_points"] = xs.size();
                std::cout << row.dump() << std::endl;
                report["opening_bound"].push_back(row);
                std::ofstream(out) << report.dump(2) << "\n";
            }
        }
    }
    std::ofstream(out) << report.dump(2) << "\n";
    std::cout << "wrote " << out << "\n";
}
