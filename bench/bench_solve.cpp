// Preconditioners for the Green's function solve (operators issue, in progress): Jacobi against incomplete
// Cholesky on the bunny band, time to tolerance 1e-6 (median of 3), iterations, operator assembly time.
// Usage: bench_solve [--out bench/results/solve.json] [--data DIR]
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/tasks/green.h"

using namespace gpisvdb;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
    std::string out = "bench/results/solve.json", data = "../shared/data";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--out" && i + 1 < argc) out = argv[++i];
        else if (a == "--data" && i + 1 < argc) data = argv[++i];
        else {
            std::cerr << "usage: bench_solve [--out FILE.json] [--data DIR]\n";
            return 2;
        }
    }
    nlohmann::json report;
    for (const auto& [sigma, h] : std::vector<std::pair<double, double>>{{2.0, 0.2}, {1.0, 0.1}}) {
        const Samples s = makeSamples(readInput(data + "/bunny.obj"), {sigma}).samples;
        const BarnesHutGpis model(s, 0.4 * s.lengthScale);
        BandOptions o;
        o.voxelSize = h;
        const Band band = buildBand(model, s, o).band;
        auto t0 = Clock::now();
        const SparseMatrixF L = assembleLaplacian(band);
        const double assembly = std::chrono::duration<double>(Clock::now() - t0).count();
        nlohmann::json row = {{"input", "bunny"}, {"sigma_rel", sigma}, {"h", h}, {"voxels", band.size()},
                              {"nonzeros_per_row", double(L.nonZeros()) / double(band.size())},
                              {"assembly_s", assembly}};
        for (auto pc : {Preconditioner::Jacobi, Preconditioner::IncompleteCholesky}) {
            std::vector<double> t;
            GreenResult g;
            for (int r = 0; r < 3; ++r) {
                PcgOptions po;
                po.preconditioner = pc;
                po.maxIterations = 100000;
                t0 = Clock::now();
                g = greensFunction(band, AssembledOperator(L), Vec3d(0.5, 6, 1), po);
                t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
            }
            std::sort(t.begin(), t.end());
            const std::string k = pc == Preconditioner::Jacobi ? "jacobi" : "incomplete_cholesky";
            row[k] = {{"iterations", g.solver.iterations}, {"relative_residual", g.solver.relativeResidual},
                      {"median_s", t[1]}};
        }
        row["jacobi_speedup_over_ic"] = row["incomplete_cholesky"]["median_s"].get<double>() / row["jacobi"]["median_s"].get<double>();
        std::cout << row.dump() << std::endl;
        report["preconditioners"].push_back(row);
    }
    std::ofstream(out) << report.dump(2) << "\n";
    std::cout << "wrote " << out << "\n";
}
