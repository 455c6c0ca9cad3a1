// Operators and solvers (operators issue): paper Sec. 9 table on the bunny (band + operators, CG), our PCG
// against Eigen's ConjugateGradient and OpenVDB's math::pcg::solve on the same system and tolerance, operator
// applications per second, Jacobi against incomplete Cholesky, bytes per band voxel; tolerances below float's
// reach: the float PCG alone against mixed-precision iterative refinement (issue 18 item 4); the multigrid
// preconditioners against Jacobi on nested bands (issue 18 item 3); OpenVDB's tools::poisson on the same voxels.
// Usage: bench_solve [--part table|solvers|tolerance|multigrid|poisson|all] [--out bench/results/solve.json] [--data DIR]
//                    [--repeat R] [--sigmas 0.25,0.5,1] [--scales 2,1,0.5] [--amg θ,entries,aggressive-levels]
#include <algorithm>
#include <chrono>
#include <Eigen/IterativeLinearSolvers>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <openvdb/math/ConjGradient.h>
#include <openvdb/tools/PoissonSolver.h>
#include <tbb/global_control.h>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/stencil/resolution.h"
#include "gpisvdb/tasks/green.h"

#include "timing.h"

using namespace gpisvdb;
using bench::Clock;

namespace {

using bench::seconds;
int gRepeat = 5;
BoomerAmgOptions gAmg;  // --amg θ,entries,aggressive

template <class F>
double median(F&& f) {
    return bench::medianSeconds(gRepeat, f);
}

/// ‖b − A x‖₂ / ‖b‖₂ recomputed in double.
double trueResidual(const SparseMatrixF& A, const std::vector<float>& b, const std::vector<float>& x) {
    const Eigen::VectorXd xd = Eigen::Map<const Eigen::VectorXf>(x.data(), long(x.size())).cast<double>();
    const Eigen::VectorXd bd = Eigen::Map<const Eigen::VectorXf>(b.data(), long(b.size())).cast<double>();
    return (bd - A.cast<double>() * xd).norm() / bd.norm();
}

struct Problem {
    std::string name;
    double sigma = 0;
    Band band;
    BandStats stats;
    double secondsModel = 0, secondsResolution = 0, secondsBand = 0;
    Vec3d source;
};

Problem bunnyBand(const std::string& data, double sigma, double hScale) {
    Problem p;
    p.name = "bunny";
    p.sigma = sigma;
    auto t = Clock::now();
    const Samples s = makeSamples(readInput(data + "/bunny.obj"), {sigma}).samples;
    const BarnesHutGpis model(s, 0.4 * s.lengthScale);
    p.secondsModel = seconds(t);
    t = Clock::now();
    const Resolution res = chooseResolution(model, s);
    p.secondsResolution = seconds(t);
    BandOptions o;
    o.voxelSize = hScale * res.hStar;
    t = Clock::now();
    BandResult br = buildBand(model, s, o);
    p.secondsBand = seconds(t);
    p.band = std::move(br.band);
    p.stats = br.stats;
    p.source = s.position[s.size() / 2];
    return p;
}

// === OpenVDB's PCG on its own stencil matrix, with a Jacobi preconditioner of ours (same arithmetic as our Jacobi)
constexpr openvdb::math::pcg::SizeType kStencil = 96;
using VdbMatrix = openvdb::math::pcg::SparseStencilMatrix<float, kStencil>;

struct VdbJacobi final : openvdb::math::pcg::Preconditioner<float> {
    std::vector<float> inv;
    explicit VdbJacobi(const VdbMatrix& A, const SparseMatrixF& L) : Preconditioner<float>(A), inv(std::size_t(L.rows())) {
        for (int i = 0; i < L.rows(); ++i) inv[std::size_t(i)] = 1.0f / L.coeff(i, i);
    }
    void apply(const openvdb::math::pcg::Vector<float>& r, openvdb::math::pcg::Vector<float>& z) override {
        for (std::size_t i = 0; i < inv.size(); ++i) z[i] = inv[i] * r[i];
    }
};

/// OpenVDB's fixed-width stencil matrix holding L; null when a row has more than kStencil entries.
std::unique_ptr<VdbMatrix> vdbMatrix(const SparseMatrixF& L) {
    for (int i = 0; i < L.rows(); ++i)
        if (L.outerIndexPtr()[i + 1] - L.outerIndexPtr()[i] > int(kStencil)) return nullptr;
    auto A = std::make_unique<VdbMatrix>(openvdb::math::pcg::SizeType(L.rows()));
    for (int i = 0; i < L.rows(); ++i) {
        for (SparseMatrixF::InnerIterator it(L, i); it; ++it)
            A->setValue(openvdb::math::pcg::SizeType(i), openvdb::math::pcg::SizeType(it.col()), it.value());
    }
    return A;
}

nlohmann::json solvers(const Problem& p, double tolerance) {
    const Band& band = p.band;
    const std::size_t n = band.size();
    nlohmann::json row = {{"input", p.name}, {"sigma_rel", p.sigma}, {"h", band.voxelSize}, {"voxels", n}, {"tolerance", tolerance}};
    auto t = Clock::now();
    const SparseMatrixF L = assembleLaplacian(band);
    row["assembly_s"] = seconds(t);
    t = Clock::now();
    const LaplacianOperator free(band);
    row["matrix_free_setup_s"] = seconds(t);
    const AssembledOperator assembled(L);
    std::vector<float> b(n, 0.0f);
    const std::size_t y = nearestBandVoxel(band, p.source);
    b[y] = 1.0f;  // the Green's function right-hand side M δ_y = e_y

    // === Operator applications per second, and bytes per band voxel
    std::vector<float> u(n, 1.0f), out(n);
    for (std::size_t i = 0; i < n; ++i) u[i] = float(std::sin(0.001 * double(i)));
    const auto vdbA = vdbMatrix(L);
    const double tFree = median([&] { free.apply(u.data(), out.data()); });
    const double tAssembled = median([&] { assembled.apply(u.data(), out.data()); });
    row["applications_per_s"] = {{"matrix_free", 1 / tFree}, {"assembled_csr", 1 / tAssembled}};
    if (vdbA) {
        openvdb::math::pcg::Vector<float> vu(n), vout(n);
        for (std::size_t i = 0; i < n; ++i) vu[i] = u[i];
        row["applications_per_s"]["openvdb_stencil_matrix"] = 1 / median([&] { vdbA->vectorMultiply(vu, vout); });
    }
    int longest = 0;
    for (int i = 0; i < L.rows(); ++i) longest = std::max(longest, L.outerIndexPtr()[i + 1] - L.outerIndexPtr()[i]);
    row["longest_row"] = longest;
    row["nonzeros_per_row"] = double(L.nonZeros()) / double(n);
    const PcgSolver jacobi(free);
    row["bytes_per_voxel"] = {{"band", band.bytesPerVoxel()},
                              {"assembled_L", double(L.nonZeros() * 8 + (L.rows() + 1) * 4) / double(n)},
                              {"matrix_free_L", double(free.memoryBytes()) / double(n)},
                              {"pcg_jacobi_work", double(jacobi.memoryBytes()) / double(n)}};

    // === Solvers to the same tolerance; the true residual recomputed in double afterwards
    auto ours = [&](const SymmetricOperator& A, Preconditioner pc, int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        PcgOptions o;
        o.tolerance = tolerance;
        o.maxIterations = 100000;
        o.preconditioner = pc;
        std::vector<float> x;
        PcgResult r;
        const double s = median([&] {
            x.clear();
            r = PcgSolver(A, o).solve(b, x);
        });
        return nlohmann::json{{"median_s", s}, {"iterations", r.iterations}, {"true_relative_residual", trueResidual(L, b, x)}};
    };
    row["ours_matrix_free_jacobi_2t"] = ours(free, Preconditioner::Jacobi, 2);
    row["ours_matrix_free_jacobi_1t"] = ours(free, Preconditioner::Jacobi, 1);
    row["ours_assembled_jacobi_2t"] = ours(assembled, Preconditioner::Jacobi, 2);
    row["ours_assembled_jacobi_1t"] = ours(assembled, Preconditioner::Jacobi, 1);
    row["ours_assembled_ic_2t"] = ours(assembled, Preconditioner::IncompleteCholesky, 2);
    {
        Eigen::ConjugateGradient<SparseMatrixF, Eigen::Lower | Eigen::Upper, Eigen::DiagonalPreconditioner<float>> cg;
        cg.setTolerance(float(tolerance));
        cg.setMaxIterations(100000);
        Eigen::VectorXf x;
        const Eigen::Map<const Eigen::VectorXf> bm(b.data(), long(n));
        const double s = median([&] {
            cg.compute(L);
            x = cg.solve(bm);
        });
        const std::vector<float> xs(x.data(), x.data() + n);
        row["eigen_cg_jacobi"] = {{"median_s", s}, {"iterations", cg.iterations()}, {"true_relative_residual", trueResidual(L, b, xs)}};
    }
    if (vdbA) {
        openvdb::math::pcg::State term = openvdb::math::pcg::terminationDefaults<float>();
        term.iterations = 100000;
        term.relativeError = tolerance;
        term.absoluteError = 0;
        openvdb::math::pcg::Vector<float> vb(n), vx(n);
        for (std::size_t i = 0; i < n; ++i) vb[i] = b[i];
        openvdb::math::pcg::State st{};
        const double s = median([&] {
            vx.fill(0.0f);
            VdbJacobi P(*vdbA, L);
            st = openvdb::math::pcg::solve(*vdbA, vb, vx, P, static_cast<const openvdb::math::pcg::State&>(term));
        });
        const std::vector<float> xs(vx.data(), vx.data() + n);
        row["openvdb_pcg_jacobi"] = {
            {"median_s", s}, {"iterations", st.iterations}, {"success", st.success}, {"true_relative_residual", trueResidual(L, b, xs)}};
    }
    // Ratios of solve times (> 1: ours is faster), our default (matrix-free, Jacobi, 2 threads) against the rest.
    const double oursS = row["ours_matrix_free_jacobi_2t"]["median_s"].get<double>();
    auto ratio = [&](const char* key) { return row[key]["median_s"].get<double>() / oursS; };
    row["speedup_of_ours_matrix_free"] = {{"over_eigen_cg", ratio("eigen_cg_jacobi")},
                                          {"over_ours_assembled", ratio("ours_assembled_jacobi_2t")},
                                          {"over_ours_ic", ratio("ours_assembled_ic_2t")}};
    if (vdbA) row["speedup_of_ours_matrix_free"]["over_openvdb_pcg"] = ratio("openvdb_pcg_jacobi");
    const double oursAssembled = row["ours_assembled_jacobi_2t"]["median_s"].get<double>();
    row["speedup_of_ours_assembled"] = {{"over_eigen_cg", row["eigen_cg_jacobi"]["median_s"].get<double>() / oursAssembled}};
    if (vdbA) row["speedup_of_ours_assembled"]["over_openvdb_pcg"] = row["openvdb_pcg_jacobi"]["median_s"].get<double>() / oursAssembled;
    return row;
}

/// Paper Sec. 9: band + operators and CG time for the Green's function on the bunny at three σ, h = h*.
nlohmann::json secNineRow(const Problem& p, double tolerance) {
    const Band& band = p.band;
    auto t = Clock::now();
    const LaplacianOperator L(band);
    const double ops = seconds(t);
    t = Clock::now();
    PcgOptions o;
    o.tolerance = tolerance;
    o.preconditioner = Preconditioner::Jacobi;  // the paper's CG; the multigrid has its own part
    const GreenResult g = greensFunction(band, L, p.source, o);
    const double cg = seconds(t);
    const auto bb = band.bbox();
    return {{"input", p.name},
            {"sigma_rel", p.sigma},
            {"h", band.voxelSize},
            {"bbox_voxels", {bb.dim().x(), bb.dim().y(), bb.dim().z()}},
            {"voxels", band.size()},
            {"evaluated_voxels", p.stats.evaluated},
            {"model_s", p.secondsModel},
            {"resolution_s", p.secondsResolution},
            {"band_s", p.secondsBand},
            {"operators_s", ops},
            {"band_and_operators_s", p.secondsModel + p.secondsResolution + p.secondsBand + ops},
            {"cg_s", cg},
            {"cg_iterations", g.solver.iterations},
            {"cg_relative_residual", g.solver.relativeResidual}};
}

/// The Green's function's system L f = e_y solved to 1e-6 … 1e-12 by the float PCG alone and by refinement in
/// double; each solution's residual recomputed independently with L assembled in double.
nlohmann::json tolerances(const Problem& p) {
    const Band& band = p.band;
    const std::size_t n = band.size();
    const LaplacianOperator L(band);
    const SparseMatrixD Ld = assembleLaplacianDouble(band);
    std::vector<double> b(n, 0.0);
    b[nearestBandVoxel(band, p.source)] = 1.0;
    const Eigen::Map<const Eigen::VectorXd> bd(b.data(), long(n));
    nlohmann::json row = {
        {"input", p.name}, {"sigma_rel", p.sigma}, {"h", band.voxelSize}, {"voxels", n}, {"runs", nlohmann::json::array()}};
    const char* names[] = {"automatic", "off", "always"};
    for (auto [tolerance, refinement] :
         {std::pair{1e-6, Refinement::Off}, std::pair{1e-6, Refinement::Automatic}, std::pair{1e-6, Refinement::Always},
          std::pair{1e-8, Refinement::Off}, std::pair{1e-8, Refinement::Automatic}, std::pair{1e-10, Refinement::Automatic},
          std::pair{1e-12, Refinement::Automatic}}) {
        PcgOptions o;
        o.tolerance = tolerance;
        o.maxIterations = 100000;
        o.refinement = refinement;
        o.preconditioner = Preconditioner::Jacobi;
        std::vector<double> x;
        PcgResult r;
        const double s = median([&] {
            x.clear();
            r = PcgSolver(L, o).solve(b, x);
        });
        const Eigen::Map<const Eigen::VectorXd> xd(x.data(), long(n));
        const nlohmann::json run = {{"tolerance", tolerance},
                                    {"refinement", names[int(refinement)]},
                                    {"median_s", s},
                                    {"iterations", r.iterations},
                                    {"refinements", r.refinements},
                                    {"inner_iterations", r.innerIterations},
                                    {"restarts", r.restarts},
                                    {"converged", r.converged},
                                    {"relative_residual", r.relativeResidual},
                                    {"true_relative_residual", (bd - Ld * xd).norm() / bd.norm()},
                                    {"float_rounded_residual", r.floatResidual}};
        std::cout << run.dump() << std::endl;
        row["runs"].push_back(run);
    }
    return row;
}

/// Jacobi (matrix-free) against the multigrid preconditioners — BoomerAMG on the assembled L, and the aggregation
/// multigrid on the matrix-free L — on the Green's function's system to 1e-6: set-up, solve, iterations, memory,
/// hierarchy.
nlohmann::json multigridRow(const Problem& p, double tolerance) {
    const Band& band = p.band;
    const std::size_t n = band.size();
    nlohmann::json row = {{"input", p.name}, {"sigma_rel", p.sigma}, {"h", band.voxelSize}, {"voxels", n}};
    std::vector<float> b(n, 0.0f);
    b[nearestBandVoxel(band, p.source)] = 1.0f;
    // One timed run: the matrix-free operator (the multigrid's set-up assembles L for hypre and frees it), the
    // solver's set-up, then the median solve.
    auto timed = [&](const PcgOptions& o) {
        auto t = Clock::now();
        const LaplacianOperator L(band);
        const double operatorS = seconds(t);
        t = Clock::now();
        const PcgSolver solver(L, o);
        const double setupS = seconds(t);
        std::vector<float> x;
        PcgResult r;
        const double s = median([&] {
            x.assign(n, 0.0f);
            r = solver.solve(b, x);
        });
        nlohmann::json out = {{"operator_s", operatorS},
                              {"setup_s", setupS},
                              {"solve_s", s},
                              {"total_s", operatorS + setupS + s},
                              {"iterations", r.iterations},
                              {"relative_residual", r.relativeResidual},
                              {"bytes_per_voxel", double(solver.memoryBytes() + L.memoryBytes()) / double(n)}};
        if (const BoomerAmg* amg = solver.multigrid()) {
            out["levels"] = amg->levels();
            out["operator_complexity"] = amg->operatorComplexity();
            out["options"] = {{"strong_threshold", o.multigrid.strongThreshold},
                              {"max_interpolation_entries", o.multigrid.maxInterpolationEntries},
                              {"aggressive_levels", o.multigrid.aggressiveLevels}};
        }
        if (const AggregationMultigrid* agg = solver.aggregation()) {
            out["levels"] = agg->levels();
            out["operator_complexity"] = agg->operatorComplexity();
        }
        return out;
    };
    PcgOptions o;
    o.tolerance = tolerance;
    o.maxIterations = 100000;
    o.preconditioner = Preconditioner::Jacobi;
    row["jacobi"] = timed(o);
    o.preconditioner = Preconditioner::Multigrid;
    o.multigrid = gAmg;
    row["multigrid"] = timed(o);
    row["speedup_total"] = row["jacobi"]["total_s"].get<double>() / row["multigrid"]["total_s"].get<double>();
    o.preconditioner = Preconditioner::Aggregation;
    row["aggregation"] = timed(o);
    row["aggregation_speedup_total"] = row["jacobi"]["total_s"].get<double>() / row["aggregation"]["total_s"].get<double>();
    return row;
}

/// The reference of issue 18: OpenVDB's own Jacobi-preconditioned CG (tools::poisson::solve, the 7-point Laplacian
/// with homogeneous Dirichlet conditions) on an isotropic band of the same voxels, against our PCG — Jacobi and the
/// aggregation multigrid — on the same voxels with T = I (our stencil then is the same 7-point Laplacian, times h),
/// and on the GPIS band itself. The right-hand side: a unit source at the voxel nearest the source point.
nlohmann::json poissonRow(const Problem& p, double tolerance) {
    const Band& gpis = p.band;
    const std::size_t n = gpis.size();
    const std::size_t y = nearestBandVoxel(gpis, p.source);
    nlohmann::json row = {{"input", p.name}, {"sigma_rel", p.sigma}, {"h", gpis.voxelSize}, {"voxels", n}};
    std::vector<BandVoxel> voxels(n);
    for (std::size_t i = 0; i < n; ++i) {
        voxels[i].coord = gpis.coord[i];
        voxels[i].mu = 1.0;
        voxels[i].T = Mat3d::Identity();
    }
    const Band iso = bandFromVoxels(std::move(voxels), gpis.voxelSize, 1.0).band;
    // === OpenVDB: the band's voxels as the active set, −e_y as ∇²x = b's right-hand side. Our L gives an edge that
    // leaves the band h λ/2 on the diagonal (the outside voxel has no stencil to add its half, laplacian.h), so the
    // boundary op adds 1/2 where OpenVDB's Dirichlet op adds 1: then its matrix is −L/h and A x = e_y. Its stopping
    // test is on the residual's largest entry (‖r‖∞/‖b‖∞), ours on ‖r‖₂/‖b‖₂, so its solution is also mapped to ours
    // (u = x/h) and ‖e_y − L u‖₂ reported (docs/benchmarks.md#poisson).
    {
        const LaplacianOperator Liso(iso);
        openvdb::FloatTree source(0.0f);
        for (std::size_t i = 0; i < n; ++i) source.setValueOn(gpis.coord[i], i == y ? -1.0f : 0.0f);
        auto l2Residual = [&](const openvdb::FloatTree& x) {
            std::vector<double> u(n), Lu(n);
            for (std::size_t i = 0; i < n; ++i)
                u[iso.index->tree().getValue(gpis.coord[i])] = double(x.getValue(gpis.coord[i])) / iso.voxelSize;
            Liso.apply(u.data(), Lu.data());
            double s = 0;
            const std::size_t yi = std::size_t(iso.index->tree().getValue(gpis.coord[y]));
            for (std::size_t i = 0; i < n; ++i) s += std::pow((i == yi ? 1.0 : 0.0) - Lu[i], 2);
            return std::sqrt(s);
        };
        openvdb::math::pcg::State state = openvdb::math::pcg::terminationDefaults<float>();
        state.iterations = 100000;
        state.relativeError = tolerance;
        state.absoluteError = 0;
        openvdb::math::pcg::State result;
        openvdb::FloatTree::Ptr x;
        const double s = median([&] {
            openvdb::util::NullInterrupter interrupter;
            result = state;
            const auto halfDirichlet = [](const openvdb::Coord&, const openvdb::Coord&, double&, double& diagonal) { diagonal -= 0.5; };
            x = openvdb::tools::poisson::solveWithBoundaryConditions(source, halfDirichlet, result, interrupter);
        });
        const double l2 = l2Residual(*x);
        row["openvdb_poisson_jacobi"] = {{"iterations", result.iterations},
                                         {"relative_error_inf", result.relativeError},
                                         {"relative_residual_of_its_solution", l2},
                                         {"success", result.success},
                                         {"total_s", s}};
    }
    // === Ours on the same voxels with T = I, then on the GPIS band
    for (const auto& [name, band] : {std::pair<const char*, const Band*>{"isotropic", &iso}, {"gpis", &gpis}}) {
        std::vector<float> b(n, 0.0f);
        b[nearestBandVoxel(*band, p.source)] = 1.0f;
        for (const Preconditioner pc : {Preconditioner::Jacobi, Preconditioner::Aggregation}) {
            PcgOptions o;
            o.tolerance = tolerance;
            o.maxIterations = 100000;
            o.preconditioner = pc;
            std::vector<float> x;
            PcgResult r;
            const double s = median([&] {
                const LaplacianOperator L(*band);
                x.assign(n, 0.0f);
                r = solvePcg(L, b, x, o);
            });
            row[std::string(name) + "_" + (pc == Preconditioner::Jacobi ? "jacobi" : "aggregation")] = {
                {"iterations", r.iterations}, {"relative_residual", r.relativeResidual}, {"total_s", s}};
        }
    }
    return row;
}

std::vector<double> parseList(const std::string& s) {
    std::vector<double> v;
    std::size_t i = 0;
    while (i < s.size()) {
        std::size_t j = s.find(',', i);
        if (j == std::string::npos) j = s.size();
        v.push_back(std::stod(s.substr(i, j - i)));
        i = j + 1;
    }
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    std::string part = "all", out = "bench/results/solve.json", data = "data";
    std::vector<double> sigmas = {0.25, 0.5, 1.0}, scales = {2.0, 1.0, 0.5};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--part" && i + 1 < argc) part = argv[++i];
        else if (a == "--out" && i + 1 < argc) out = argv[++i];
        else if (a == "--data" && i + 1 < argc) data = argv[++i];
        else if (a == "--repeat" && i + 1 < argc) gRepeat = std::max(1, std::stoi(argv[++i]));
        else if (a == "--sigmas" && i + 1 < argc) sigmas = parseList(argv[++i]);
        else if (a == "--scales" && i + 1 < argc) scales = parseList(argv[++i]);
        else if (a == "--amg" && i + 1 < argc) {
            const std::vector<double> v = parseList(argv[++i]);
            if (v.size() != 3) {
                std::cerr << "bench_solve: --amg takes θ,entries,aggressive-levels\n";
                return 2;
            }
            gAmg.strongThreshold = v[0];
            gAmg.maxInterpolationEntries = int(v[1]);
            gAmg.aggressiveLevels = int(v[2]);
        } else {
            std::cerr << "usage: bench_solve [--part table|solvers|tolerance|multigrid|poisson|all] [--out FILE.json] [--data DIR] "
                         "[--repeat R] [--sigmas S,...] [--scales C,...] [--amg θ,entries,aggressive]\n";
            return 2;
        }
    }
    if (part != "table" && part != "solvers" && part != "tolerance" && part != "multigrid" && part != "poisson" && part != "all") {
        std::cerr << "bench_solve: unknown --part '" << part << "'\n";
        return 2;
    }
    openvdb::initialize();
    nlohmann::json report;
    {
        std::ifstream in(out);
        if (in) try {
                in >> report;
            } catch (...) {
                report = nlohmann::json::object();
            }
    }
    report["machine"] = "2-core x86-64 (project machine), 2 threads unless a key says 1t";
    if (part == "table" || part == "all") {
        report["sec9_table"] = nlohmann::json::array();
        for (double sigma : {0.25, 0.5, 1.0}) {
            const Problem p = bunnyBand(data, sigma, 1.0);
            const nlohmann::json row = secNineRow(p, 1e-6);
            std::cout << row.dump() << std::endl;
            report["sec9_table"].push_back(row);
        }
    }
    if (part == "solvers" || part == "all") {
        report["solvers"] = nlohmann::json::array();
        for (auto [sigma, hScale] : {std::pair{1.0, 1.0}, std::pair{1.0, 0.5}, std::pair{0.25, 1.0}}) {
            const Problem p = bunnyBand(data, sigma, hScale);
            const nlohmann::json row = solvers(p, 1e-6);
            std::cout << row.dump() << std::endl;
            report["solvers"].push_back(row);
        }
    }
    if (part == "tolerance" || part == "all") {
        report["tolerances"] = nlohmann::json::array();
        for (double hScale : {1.0, 0.5}) {
            const Problem p = bunnyBand(data, 0.5, hScale);
            const nlohmann::json row = tolerances(p);
            std::cout << row["voxels"] << " voxels done" << std::endl;
            report["tolerances"].push_back(row);
        }
    }
    if (part == "poisson" || part == "all") {
        report["poisson"] = nlohmann::json::array();
        for (double hScale : {2.0, 1.0, 0.5}) {
            const Problem p = bunnyBand(data, 1.0, hScale);
            const nlohmann::json row = poissonRow(p, 1e-6);
            std::cout << row.dump() << std::endl;
            report["poisson"].push_back(row);
        }
    }
    if (part == "multigrid" || part == "all") {
        // Nested bands: each voxel size half the last gives ≈ 4× the voxels (a thin band: area / h², times the
        // band's width in voxels, which also grows as h shrinks).
        report["multigrid"] = nlohmann::json::array();
        for (double sigma : sigmas)
            for (double hScale : scales) {
                const Problem p = bunnyBand(data, sigma, hScale);
                const nlohmann::json row = multigridRow(p, 1e-6);
                std::cout << row.dump() << std::endl;
                report["multigrid"].push_back(row);
            }
    }
    report.erase("preconditioners");
    std::ofstream(out) << report.dump(2) << "\n";
    std::cout << "wrote " << out << "\n";
}
