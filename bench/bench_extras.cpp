// Hodge decomposition, smoothed distance and the regression GPIS (issue 7): Hodge solve time vs N on unit-sphere
// bands; the smoothed distance on a 128³ grid, k-d tree against brute force (ratio, and the largest difference
// against the stated bound); the regression model's build and query times vs the number of labels.
// Usage: bench_extras [--grid 128] [--labels-max 800] [--out FILE.json]
// (≈ 12 min on 2 cores: the brute-force 128³ grid alone is ~6 min, once, at α = 20.)
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/regression_gpis.h"
#include "gpisvdb/tasks/hodge.h"
#include "gpisvdb/tasks/smoothed_distance.h"

#include "timing.h"

using namespace gpisvdb;
using bench::Clock;
using bench::medianSeconds;
using bench::seconds;

namespace {

Band sphereBand(int subdivisions, double sigmaRel, double h) {
    const SoupSamples ss = soupSamples(icosphere(subdivisions), {sigmaRel});
    const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
    BandOptions o;
    o.voxelSize = h;
    return buildBand(model, ss.samples, o).band;
}

}  // namespace

int main(int argc, char** argv) {
    int grid = 128;
    std::size_t labelsMax = 800;
    std::string outPath = "bench/results/extras.json";
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string a = argv[i];
        if (a == "--grid") grid = std::stoi(argv[i + 1]);
        else if (a == "--out") outPath = argv[i + 1];
        else if (a == "--labels-max") labelsMax = std::stoul(argv[i + 1]);
    }
    nlohmann::json out;
    out["machine"] = {{"hardware_threads", std::thread::hardware_concurrency()}};
    out["command"] = "build/bin/bench_extras --grid " + std::to_string(grid);

    // === Hodge: solve time vs N (mixed preset, Neumann, PCG Jacobi to 1e-5)
    for (double h : {0.08, 0.056, 0.04, 0.028}) {
        const Band band = sphereBand(3, 1.0, h);
        const std::vector<float> V = hodgePreset(band, HodgePreset::Mixed);
        HodgeResult r;
        const double t = medianSeconds(3, [&] { r = hodgeDecomposition(band, V); });
        out["hodge"].push_back({{"h", h},
                                {"voxels", band.size()},
                                {"seconds", t},
                                {"iterations", r.solver.iterations},
                                {"divergence_residual", r.divergenceResidual},
                                {"s_inner_product", r.sInnerProduct}});
        std::cout << "hodge h " << h << ": N " << band.size() << ", " << t << " s, " << r.solver.iterations << " iterations" << std::endl;
    }

    // === Smoothed distance on a grid³ over the unit-sphere band: tree vs brute force
    {
        const Band band = sphereBand(2, 1.0, 0.08);
        for (double alpha : {20.0}) {  // brute force costs the same for any α; the tree is slowest for smooth α near the band
            SmoothedDistanceOptions o;
            o.alpha = alpha;
            o.padding = 0.25;
            const openvdb::CoordBBox box = band.bbox();
            o.gridVoxelSize = (band.voxelSize * (box.max().x() - box.min().x()) + 2 * o.padding) / (grid - 1);
            SmoothedDistanceResult tree, brute;
            const double tTree = medianSeconds(1, [&] { tree = smoothedDistanceGrid(band, o); });
            nlohmann::json row = {{"alpha", alpha},        {"band_voxels", band.size()},   {"grid_points", tree.points},
                                  {"tree_seconds", tTree}, {"mean_terms", tree.meanTerms}, {"tolerance", tree.tolerance}};
            std::cout << "distance alpha " << alpha << ": " << tree.points << " points, tree " << tTree << " s, " << tree.meanTerms
                      << " terms per point" << std::endl;
            if (alpha == 20.0) {
                o.bruteForce = true;
                const double tBrute = medianSeconds(1, [&] { brute = smoothedDistanceGrid(band, o); });
                double worst = 0;
                auto acc = brute.grid->getConstAccessor();
                for (auto it = tree.grid->cbeginValueOn(); it; ++it)
                    worst = std::max(worst, double(std::abs(*it - acc.getValue(it.getCoord()))));
                row["brute_force_seconds"] = tBrute;
                row["speedup"] = tBrute / tTree;
                row["max_difference"] = worst;
                std::cout << "  brute force " << tBrute << " s (x" << tBrute / tTree << "), max diff " << worst << " (bound "
                          << tree.tolerance << ", float storage)" << std::endl;
            }
            out["smoothed_distance"].push_back(row);
        }
    }

    // === Regression GPIS: build and query vs labels
    {
        const SoupSamples ss = soupSamples(icosphere(4), {0.5});
        std::mt19937_64 rng(1);
        std::normal_distribution<double> N;
        std::vector<Vec3d> xs(5000);
        for (auto& x : xs) x = (1.0 + 0.05 * N(rng)) * Vec3d(N(rng), N(rng), N(rng)).normalized();
        for (std::size_t n = 50; n <= labelsMax; n *= 2) {
            TrainingOptions to;
            to.surfacePoints = n;
            double spacing = 0;
            const LabelledPoints t = trainingFromSamples(ss.samples, to, &spacing);
            RegressionGpisOptions ro;
            ro.smoothing = 0.4 * spacing;
            std::unique_ptr<RegressionGpis> model;
            const double tBuild = medianSeconds(3, [&] { model = std::make_unique<RegressionGpis>(t, ro); });
            const double tQuery = medianSeconds(3, [&] { model->evaluate(xs); });
            out["regression"].push_back({{"labels", t.size()},
                                         {"build_seconds", tBuild},
                                         {"query_points", xs.size()},
                                         {"query_seconds", tQuery},
                                         {"us_per_point", 1e6 * tQuery / double(xs.size())},
                                         {"memory_bytes", model->memoryBytes()}});
            std::cout << "regression " << t.size() << " labels: build " << tBuild << " s, " << 1e6 * tQuery / double(xs.size())
                      << " us/point" << std::endl;
        }
    }
    std::ofstream(outPath) << out.dump(2) << "\n";
    std::cout << "wrote " << outPath << "\n";
}
