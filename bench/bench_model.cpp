// Queries per second of DirectGpis and BarnesHutGpis (in packets, and one point at a time) against n, on 1 and 2 threads, with the
// Barnes–Hut error (docs/benchmarks.md states the norm), tree build time and bytes per sample; and the error against β. Usage: bench_model
// [--quick] [--out bench/results/model.json] [--data DIR]
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <tbb/global_control.h>

#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/accuracy.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/model/per_point.h"

using namespace gpisvdb;
using Clock = std::chrono::steady_clock;

namespace {

double seconds(Clock::time_point a) { return std::chrono::duration<double>(Clock::now() - a).count(); }

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

/// Query points within 3ℓ of random samples: where the fields are used (the band lives there).
std::vector<Vec3d> nearPoints(const Samples& s, std::size_t count, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(-1, 1);
    std::vector<Vec3d> xs;
    for (std::size_t i = 0; i < count; ++i) xs.push_back(s.position[rng() % s.size()] + 3 * s.lengthScale * Vec3d(U(rng), U(rng), U(rng)));
    return xs;
}

/// Band-like queries: `blocks` lattice blocks of 8³ points at spacing 0.3ℓ (a VDB leaf of a band at h ≈ h*), each
/// with a random sample at its centre.
std::vector<Vec3d> leafBlocks(const Samples& s, std::size_t blocks, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const double h = 0.3 * s.lengthScale;
    std::vector<Vec3d> xs;
    for (std::size_t b = 0; b < blocks; ++b) {
        const Vec3d c = s.position[rng() % s.size()];
        for (int i = 0; i < 8; ++i)
            for (int j = 0; j < 8; ++j)
                for (int k = 0; k < 8; ++k) xs.push_back(c + h * Vec3d(i - 3.5, j - 3.5, k - 3.5));
    }
    return xs;
}

/// Median seconds per query over `repeats` runs of the batch (evaluateDense with `dense`).
double perQuery(const GpisModel& m, const std::vector<Vec3d>& xs, int repeats, bool dense = false) {
    std::vector<double> t;
    for (int r = 0; r < repeats; ++r) {
        const auto start = Clock::now();
        if (dense) m.evaluateDense(xs);
        else m.evaluate(xs);
        t.push_back(seconds(start) / double(xs.size()));
    }
    return median(t);
}

}  // namespace

int main(int argc, char** argv) {
    bool quick = false;
    std::string out = "bench/results/model.json", data = "data";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick") quick = true;
        else if (a == "--out" && i + 1 < argc) out = argv[++i];
        else if (a == "--data" && i + 1 < argc) data = argv[++i];
        else {
            std::cerr << "usage: bench_model [--quick] [--out FILE.json] [--data DIR]\n";
            return 2;
        }
    }
    nlohmann::json report;
    report["machine"] = {{"hardware_concurrency", std::thread::hardware_concurrency()}};
    report["beta_default"] = BarnesHutOptions{}.beta;
    report["error_norm"] =
        "per number q: max over points |BH - direct| / scale_q; scales: gamma 1, gradient max|grad gamma|, c_ab max sqrt(c_aa c_bb)";

    struct Input {
        std::string name;
        Samples samples;
    };
    std::vector<Input> inputs;
    for (int level : quick ? std::vector<int>{3, 5} : std::vector<int>{3, 5, 6, 7, 8})
        inputs.push_back({"sphere_l" + std::to_string(level), soupSamples(icosphere(level), {0.5}).samples});
    inputs.push_back({"cloud_sphere_20k", makeSamples(readInput(data + "/sphere_20k_normal.xyz"), {0.5}).samples});
    inputs.push_back({"bunny", makeSamples(readInput(data + "/bunny.obj"), {0.5}).samples});

    for (const Input& in : inputs) {
        const Samples& s = in.samples;
        const double sm = 0.4 * s.lengthScale;
        nlohmann::json row = {{"input", in.name}, {"n", s.size()}};
        const auto start = Clock::now();
        const BarnesHutGpis bh(s, sm);
        row["bh_build_s"] = seconds(start);
        row["bh_bytes_per_sample"] = double(bh.memoryBytes()) / double(s.size());
        const DirectGpis direct(s, sm);
        // The direct sum costs n per query: fewer queries as n grows keep each run to about a second.
        const std::size_t nDirect = std::clamp<std::size_t>(std::size_t(2e7 / double(s.size())), 32, 2000);
        const auto xsDirect = nearPoints(s, nDirect, 1);
        const auto xsBH = nearPoints(s, quick ? 2000 : 8000, 2);
        const auto errPoints = nearPoints(s, std::min<std::size_t>(nDirect, 400), 3);
        const ModelError err = compareModels(direct.evaluate(errPoints), bh.evaluate(errPoints));
        row["bh_error_worst"] = err.worst();
        row["bh_error_per_number"] = err.maxRel;
        // Barnes–Hut in packets (the batch path) and one point at a time (the reference path), side by side.
        const PerPointModel bhPerPoint(bh);
        {
            // Cost per band-like voxel (lattice blocks, what the band evaluates) against n: packets and reference.
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
            const auto xsLeaf = leafBlocks(s, quick ? 4 : 16, 5);
            row["leaf_block_us_per_point_1t"] = 1e6 * perQuery(bh, xsLeaf, 3);
            row["leaf_block_us_per_point_reference_1t"] = 1e6 * perQuery(bhPerPoint, xsLeaf, 1);
            // The far field shared per cell (evaluateDense, docs/model.md#cells), side by side.
            // No table is kept between the repeats (cellCacheBytes = 0): each run tabulates its cells.
            BarnesHutOptions cellOptions;
            cellOptions.cellCacheBytes = 0;
            const BarnesHutGpis bhCells(s, sm, cellOptions);
            row["leaf_block_us_per_point_cells_1t"] = 1e6 * perQuery(bhCells, xsLeaf, 3, true);
            row["cells_error_worst"] = compareModels(direct.evaluate(errPoints), bhCells.evaluateDense(errPoints)).worst();
        }
        for (int threads : {1, 2}) {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
            const double td = perQuery(direct, xsDirect, 3), tb = perQuery(bh, xsBH, 3), tp = perQuery(bhPerPoint, xsBH, 3);
            const std::string k = std::to_string(threads) + "t";
            row["direct_qps_" + k] = 1.0 / td;
            row["bh_qps_" + k] = 1.0 / tb;
            row["bh_per_point_qps_" + k] = 1.0 / tp;
            row["speedup_" + k] = td / tb;
            row["packet_speedup_" + k] = tp / tb;
        }
        std::cout << row.dump() << std::endl;
        report["scaling"].push_back(row);
    }

    // === Error and cost against β on the bunny
    {
        const Samples& s = inputs.back().samples;
        const double sm = 0.4 * s.lengthScale;
        const auto xs = nearPoints(s, 1000, 4);
        const auto ref = DirectGpis(s, sm).evaluate(xs);
        for (double beta : {2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0}) {
            BarnesHutOptions o;
            o.beta = beta;
            const BarnesHutGpis bh(s, sm, o);
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
            const double tq = perQuery(bh, xs, 3);
            const ModelError e = compareModels(ref, bh.evaluate(xs));
            nlohmann::json row = {{"beta", beta},
                                  {"error_mean_max", *std::max_element(e.maxRel.begin(), e.maxRel.begin() + 4)},
                                  {"error_cov_max", *std::max_element(e.maxRel.begin() + 4, e.maxRel.end())},
                                  {"error_worst", e.worst()},
                                  {"qps_1t", 1.0 / tq}};
            std::cout << row.dump() << std::endl;
            report["beta_sweep_bunny"].push_back(row);
        }
    }
    // === Cells (evaluateDense, cells of 12 s = 4.8ℓ): error and cost against the Chebyshev nodes per axis, on
    // band-like blocks of the largest soup
    {
        const Samples& s = inputs[inputs.size() - 3].samples;
        const double sm = 0.4 * s.lengthScale;
        const auto xs = leafBlocks(s, quick ? 4 : 16, 6);
        const BarnesHutGpis bh(s, sm);
        std::vector<Vec3d> some;
        for (std::size_t i = 0; i < xs.size(); i += 32) some.push_back(xs[i]);
        const auto ref = DirectGpis(s, sm).evaluate(some);
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        nlohmann::json base = {{"input", inputs[inputs.size() - 3].name},
                               {"cell_nodes", 0},
                               {"us_per_point_1t", 1e6 * perQuery(bh, xs, 3)},
                               {"error_worst", compareModels(ref, bh.evaluate(some)).worst()}};
        std::cout << base.dump() << std::endl;
        report["cells_sweep"].push_back(base);
        for (int nodes : {2, 3, 4, 5, 6}) {
            BarnesHutOptions o;
            o.cellNodes = nodes;
            o.cellCacheBytes = 0;
            const BarnesHutGpis cells(s, sm, o);
            nlohmann::json row = {{"input", base["input"]},
                                  {"cell_width_s", o.cellWidth},
                                  {"cell_nodes", nodes},
                                  {"us_per_point_1t", 1e6 * perQuery(cells, xs, 3, true)},
                                  {"error_worst", compareModels(ref, cells.evaluateDense(some)).worst()}};
            std::cout << row.dump() << std::endl;
            report["cells_sweep"].push_back(row);
        }
    }
    std::ofstream(out) << report.dump(2) << "\n";
    std::cout << "wrote " << out << "\n";
}
