// The model on scans of growing density (issue 38 item 6, docs/benchmarks.md#scan-model): unit-sphere clouds of
// random points with their own σ (world units) at a fixed smoothing s (world units, the default's 1.2 σ for such
// clouds) — what a denser scan of the same object gives. Per size: the samples' time (areas, ℓ), the Barnes–Hut
// tree's build time and bytes per sample, and the cost per band-like voxel on one thread (lattice blocks of 8³ at
// spacing h, world units, each centred on a random sample): the cells' path (evaluateDense, what the band runs),
// its tables made afresh in each run, and the packets' path (evaluate); then the cells' path on the samples merged
// into Gaussian dipoles at cells of m × s (docs/math.md#merging), what the model sums by default where s > ℓ.
// Usage: bench_scan_model [--sizes 10000,100000,1000000] [--sigma 0.01] [--h 0.004] [--blocks 16] [--repeat 3]
//        [--cell-width 12] [--leaf-size 32] [--beta 6] [--covariance-ratio 2] (BarnesHutOptions) [--merge 1]
//        [--out bench/results/scan_model.json]
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <tbb/global_control.h>

#include "gpisvdb/input/point_cloud.h"
#include "gpisvdb/input/samples.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/load_model.h"
#include "gpisvdb/model/merge_samples.h"

#include "timing.h"

using namespace gpisvdb;

namespace {

PointCloud sphereCloud(std::size_t n, double sigma, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g;
    PointCloud c;
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3d d = Vec3d(g(rng), g(rng), g(rng)).normalized();
        c.positions.push_back(d);
        c.normals.push_back(d);
        c.sigmas.push_back(sigma);
    }
    return c;
}

std::vector<Vec3d> leafBlocks(const Samples& s, double h, std::size_t blocks, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::vector<Vec3d> xs;
    for (std::size_t b = 0; b < blocks; ++b) {
        const Vec3d c = s.position[rng() % s.size()];
        for (int i = 0; i < 8; ++i)
            for (int j = 0; j < 8; ++j)
                for (int k = 0; k < 8; ++k) xs.push_back(c + h * Vec3d(i - 3.5, j - 3.5, k - 3.5));
    }
    return xs;
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<std::size_t> sizes = {10000, 100000, 1000000};
    double sigma = 0.01, h = 0.004;
    std::size_t blocks = 16;
    int repeat = 3;
    double merge = kDefaultMergeRel;
    std::string out = "bench/results/scan_model.json";
    BarnesHutOptions options;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string a = argv[i], v = argv[i + 1];
        if (a == "--sizes") {
            sizes.clear();
            std::stringstream list(v);
            for (std::string item; std::getline(list, item, ',');) sizes.push_back(std::size_t(std::stod(item)));
        } else if (a == "--sigma") sigma = std::stod(v);
        else if (a == "--h") h = std::stod(v);
        else if (a == "--blocks") blocks = std::size_t(std::stod(v));
        else if (a == "--repeat") repeat = std::stoi(v);
        else if (a == "--cell-width") options.cellWidth = std::stod(v);
        else if (a == "--leaf-size") options.leafSize = std::stoi(v);
        else if (a == "--beta") options.beta = std::stod(v);
        else if (a == "--covariance-ratio") options.covarianceRatio = std::stod(v);
        else if (a == "--merge") merge = std::stod(v);
        else if (a == "--out") out = v;
        else {
            std::cerr << "unknown option " << a << "\n";
            return 2;
        }
    }
    const double smoothing = 1.2 * sigma;  // the default for clouds with their own σ (docs/math.md#smoothing)
    nlohmann::json rows = nlohmann::json::array();
    for (const std::size_t n : sizes) {
        const PointCloud cloud = sphereCloud(n, sigma, 7);
        auto t0 = bench::Clock::now();
        const Samples samples = cloudSamples(cloud).samples;
        const double samplesSeconds = bench::seconds(t0);
        t0 = bench::Clock::now();
        const BarnesHutGpis bh(samples, smoothing, options);
        const double buildSeconds = bench::seconds(t0);
        BarnesHutOptions cold = options;
        cold.cellCacheBytes = 0;
        const BarnesHutGpis bhCold(samples, smoothing, cold);
        const std::vector<Vec3d> xs = leafBlocks(samples, h, blocks, 5);
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        const double cells = bench::medianSeconds(repeat, [&] { bhCold.evaluateDense(xs); }) / double(xs.size());
        const double packets = bench::medianSeconds(repeat, [&] { bh.evaluate(xs); }) / double(xs.size());
        // === The same on the merged dipoles (the band's default where s > ℓ)
        t0 = bench::Clock::now();
        const Samples merged = mergeSamples(samples, merge * smoothing);
        const double mergeSeconds = bench::seconds(t0);
        const BarnesHutGpis bhMerged(merged, smoothing, cold);
        const double cellsMerged = bench::medianSeconds(repeat, [&] { bhMerged.evaluateDense(xs); }) / double(xs.size());
        const nlohmann::json row = {
            {"points", n},
            {"length_scale", samples.lengthScale},
            {"smoothing", smoothing},
            {"smoothing_over_length_scale", smoothing / samples.lengthScale},
            {"samples_seconds_all_threads", samplesSeconds},
            {"tree_build_seconds_all_threads", buildSeconds},
            {"sample_bytes", samplesBytes(1)},
            {"tree_bytes_per_sample", double(bh.memoryBytes()) / double(n)},
            {"cells_us_per_voxel_1t", 1e6 * cells},
            {"packets_us_per_voxel_1t", 1e6 * packets},
            {"merged_dipoles", merged.size()},
            {"merge_seconds_1t", mergeSeconds},
            {"merged_cells_us_per_voxel_1t", 1e6 * cellsMerged},
        };
        std::cerr << row.dump() << "\n";
        rows.push_back(row);
    }
    std::ofstream(out) << nlohmann::json{{"bench", "scan_model"},
                                         {"sigma", sigma},
                                         {"h", h},
                                         {"blocks", blocks},
                                         {"repeat", repeat},
                                         {"cell_width", options.cellWidth},
                                         {"leaf_size", options.leafSize},
                                         {"beta", options.beta},
                                         {"covariance_ratio", options.covarianceRatio},
                                         {"merge_rel", merge},
                                         {"rows", rows}}
                              .dump(2)
                       << "\n";
    std::cerr << "wrote " << out << "\n";
}
