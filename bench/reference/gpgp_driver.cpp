// Times the stages of the paper's own implementation (GPGP) on a .gdp, headless (docs/reference.md): the band with
// μ and T, the operators M and L, the Green's function (its showcase's CG), fast marching and the lowest eigenpairs
// (its showcase's Spectra solve), with the defaults its showcase runs with. Prints one line per stage and, last, one
// line "RESULT {json}" for bench/reference.py. gpisvdb's own code; it calls GPGP's functions, built from a copy that
// prepare_gpgp.py made.
//
// Usage: gpgp_driver --input F.gdp [--reg 0.5] [--beta 3] [--eta 0.1] [--qmc 512] [--grid_size N (default: its
//        heuristic)] [--neig 10] [--source X,Y,Z] [--tikhonov 1e-6 (its L's shift, relative to its largest
//        eigenvalue)] [--no-visibility (its L keeps every stencil edge whose far end is in the band, as ours)]
//        [--eigen-direct (L's CHOLMOD factor instead of its CG)] [--no-green] [--no-fmm] [--no-eigen] [--dump PREFIX]
#include <Spectra/SymGEigsSolver.h>  // first, in a block of its own: the MatOp headers use its CompInfo

#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>
#include <omp.h>
#include <Spectra/MatOp/SparseRegularInverse.h>
#include <Spectra/MatOp/SparseSymMatProd.h>

#include <chrono>
#include <cstdio>
#include <sstream>
#include <string>

#include "GaussianPointCloud.h"
#include "HamiltonianFastMarching.h"
#include "NarrowBand.h"
#include "StochasticBarnesHutt.h"

using namespace SGP;
using Clock = std::chrono::steady_clock;

namespace {

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// The band node nearest x: GPGP's showcase snaps its sources to the mean surface's mesh first, which needs
/// geometry-central; the nearest node is the same up to a voxel.
int nearestNode(const Points<dim>& P, const Vector<dim>& x) {
    int best = 0;
    double bestDistance = 1e300;
    for (int i = 0; i < P.cols(); ++i) {
        const double d = (P.col(i) - x).squaredNorm();
        if (d < bestDistance) bestDistance = d, best = i;
    }
    return best;
}

/// L⁻¹ through CHOLMOD's supernodal Cholesky factor, for Spectra's regular-inverse mode (in place of its
/// SparseRegularInverse, which runs a conjugate gradient solve at every step).
class CholmodRegularInverse {
public:
    using Scalar = SGP::scalar;
    explicit CholmodRegularInverse(const smat& L) : L_(L) {
        factor_.compute(L);
        if (factor_.info() != Eigen::Success) throw std::runtime_error("CHOLMOD could not factor L");
    }
    Eigen::Index rows() const { return L_.rows(); }
    void solve(const Scalar* x, Scalar* y) const { Eigen::Map<Vec>(y, rows()) = factor_.solve(Eigen::Map<const Vec>(x, rows())); }
    void perform_op(const Scalar* x, Scalar* y) const { Eigen::Map<Vec>(y, rows()) = L_ * Eigen::Map<const Vec>(x, rows()); }

private:
    const smat& L_;
    Eigen::CholmodSupernodalLLT<smat> factor_;
};

/// GPGP's calculus with one more way to build its Laplacian, for tracing where ours and its differ.
struct DriverCalculus : HamiltonianFastMarching {
    using HamiltonianFastMarching::HamiltonianFastMarching;

    /// Its Laplacian (each edge (x, x ± e) weighted by the mean of its ends' Voronoi weights, an edge whose far end is
    /// outside the band adding to the diagonal alone, then its shift: `tikhonov` × its estimate of L's largest
    /// eigenvalue) with every edge whose far end is in the band kept, as ours keeps it: its own also drops, keeping
    /// the diagonal weight, the edges whose lattice segment leaves the band on the way (its visibility check).
    smat laplacianWithoutVisibility(double tikhonov) {
        if (!nodes.begin()->second.stencil.elements.size()) computeVoronoiStencil();
        const int m = int(nodes.size());
        std::vector<Eigen::Triplet<scalar>> entries;
        Vec diagonal = Vec::Zero(m);
        for (const auto& [key, node] : nodes) {
            const GridElement x = getGridCoord(int(key));
            for (const auto& [offset, weight] : node.stencil.elements)
                for (const int sign : {-1, 1}) {
                    diagonal(node.id) += weight;
                    const auto other = getRestrictionIndex(x + sign * offset);
                    if (!other) continue;
                    entries.emplace_back(node.id, int(*other), -weight);
                    entries.emplace_back(int(*other), node.id, -weight);
                    diagonal(int(*other)) += weight;
                }
        }
        for (int i = 0; i < m; ++i) entries.emplace_back(i, i, diagonal(i));
        smat L(m, m);
        L.setFromTriplets(entries.begin(), entries.end());
        L *= 0.5;
        smat shift(m, m);
        shift.setIdentity();
        L += shift * (tikhonov * getTikhonovParameter(L));
        L.makeCompressed();
        return L;
    }
};

Vector<dim> parsePoint(const std::string& text) {
    Vector<dim> x;
    char comma;
    std::istringstream in(text);
    in >> x(0) >> comma >> x(1) >> comma >> x(2);
    return x;
}

}  // namespace

int main(int argc, char** argv) {
    std::string input, dump;
    double reg = 0.5, beta = 3, eta = 0.1, tikhonov = 1e-6;
    int qmc = 512, gridSize = -1, eigenCount = 10;
    bool green = true, fmm = true, eigen = true, visibility = true, eigenDirect = false;
    Vector<dim> source(-0.286, -0.141, -0.181);  // on spot's side
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&]() { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
        if (a == "--input") input = value();
        else if (a == "--reg") reg = std::stod(value());
        else if (a == "--beta") beta = std::stod(value());
        else if (a == "--eta") eta = std::stod(value());
        else if (a == "--tikhonov") tikhonov = std::stod(value());
        else if (a == "--qmc") qmc = std::stoi(value());
        else if (a == "--grid_size") gridSize = std::stoi(value());
        else if (a == "--neig") eigenCount = std::stoi(value());
        else if (a == "--source") source = parsePoint(value());
        else if (a == "--dump") dump = value();
        else if (a == "--no-green") green = false;
        else if (a == "--no-visibility") visibility = false;
        else if (a == "--eigen-direct") eigenDirect = true;
        else if (a == "--no-fmm") fmm = false;
        else if (a == "--no-eigen") eigen = false;
        else {
            std::fprintf(stderr, "gpgp_driver: unknown argument '%s'\n", a.c_str());
            return 2;
        }
    }
    if (input.empty()) {
        std::fprintf(stderr, "gpgp_driver: --input F.gdp is required\n");
        return 2;
    }
    setvbuf(stdout, nullptr, _IOLBF, 0);
    spdlog::set_level(spdlog::level::warn);
    StochasticCalculus::NQMC = qmc;
    std::ostringstream json;
    json.precision(10);
    json << "{\"input\": \"" << input << "\", \"threads\": " << omp_get_max_threads() << ", \"reg\": " << reg << ", \"beta\": " << beta
         << ", \"eta\": " << eta << ", \"qmc\": " << qmc;

    // === Dipoles, the Barnes–Hut field, the voxel size
    auto t = Clock::now();
    GaussianDipoles<dim> dipoles(input);
    const double lfs = dipoles.estimateScale();
    const double tLoad = since(t);
    t = Clock::now();
    StochasticBarnesHutt field(dipoles, reg * lfs, beta);
    const double tTree = since(t);
    t = Clock::now();
    double h;
    if (gridSize < 0) {
        h = StencilReachHeuristic(dipoles, field, lfs);
        gridSize = int(std::ceil(2.0 / h));
    } else {
        h = 2.0 / gridSize;
    }
    const double tResolution = since(t);
    std::printf("[load, tree, resolution] %.3f + %.3f + %.3f s: %d dipoles, lfs %.6g, h %.6g\n", tLoad, tTree, tResolution, dipoles.size(),
                lfs, h);
    json << ", \"dipoles\": " << dipoles.size() << ", \"lfs\": " << lfs << ", \"smoothing\": " << reg * lfs << ", \"h\": " << h;

    // === The band with μ and T
    t = Clock::now();
    SparseNarrowBand band = BuildAdaptiveNarrowBand(dipoles, field, h, eta);
    const double tBand = since(t);
    t = Clock::now();
    DriverCalculus calculus(band);
    const double tIndex = since(t);
    const int m = calculus.getNumVariables();
    const Points<dim> X = calculus.embedNarrowBand();
    const Vec mu = calculus.getMu();
    const double dx = calculus.getDx(), dx3 = dx * dx * dx;
    double traceT = 0;
    for (const auto& entry : calculus.getNodes()) traceT += entry.second.G.trace();
    std::printf("[band, mu, T] %.3f s (+ %.3f s indexing): %d voxels, iso %.6g, sum mu h^3 %.6g, mu in [%.4g, %.4g]\n", tBand, tIndex, m,
                band.iso, mu.sum() * dx3, mu.minCoeff(), mu.maxCoeff());
    json << ", \"iso\": " << band.iso << ", \"voxels\": " << m << ", \"dx\": " << dx << ", \"mass\": " << mu.sum() * dx3
         << ", \"trace_T_mass\": " << traceT * dx3 << ", \"mu_max\": " << mu.maxCoeff() << ", \"seconds\": {\"load\": " << tLoad
         << ", \"tree\": " << tTree << ", \"resolution\": " << tResolution << ", \"band\": " << tBand << ", \"index\": " << tIndex;

    // === Operators (its M carries h³; its L is in grid units)
    t = Clock::now();
    const smat M = calculus.buildMassMatrix();
    const smat L = visibility ? calculus.buildVoronoiLaplace(tikhonov) : calculus.laplacianWithoutVisibility(tikhonov);
    const double tOperators = since(t);
    std::printf("[operators M, L] %.3f s: nnz(L) %ld\n", tOperators, long(L.nonZeros()));
    json << ", \"operators\": " << tOperators;

    Vec greenValues, distance, values;
    std::string extra;
    if (green) {
        const int s = nearestNode(X, source);
        const Vec rhs = M * Vec::Unit(m, s);
        t = Clock::now();
        SPDSolver cg;
        cg.compute(L);
        greenValues = cg.solve(rhs);
        const double tGreen = since(t);
        std::printf("[Green's function] %.3f s: %ld CG iterations, error %.3g\n", tGreen, long(cg.iterations()), cg.error());
        json << ", \"green\": " << tGreen;
        extra += ", \"green_iterations\": " + std::to_string(cg.iterations());
        std::ostringstream node;
        node.precision(10);
        node << ", \"source_node\": [" << X(0, s) << ", " << X(1, s) << ", " << X(2, s) << "], \"source_mu\": " << mu(s);
        extra += node.str();
    }
    if (fmm) {
        t = Clock::now();
        calculus.precomputeStencils();  // (reads node (0,0,0), adding an empty node there when it is not in the band)
        const double tStencils = since(t);
        const int s = nearestNode(X, source);
        t = Clock::now();
        distance = calculus.run(s);
        const double tMarch = since(t);
        std::printf("[fast marching] %.3f s stencils + %.3f s march\n", tStencils, tMarch);
        json << ", \"fmm_stencils\": " << tStencils << ", \"fmm_march\": " << tMarch;
    }
    if (eigen) {
        t = Clock::now();
        // M v = ν L v, its largest ν = 1/λ: L applied inversely by CG at every step (its showcase's), or through
        // L's sparse Cholesky factor (--eigen-direct: the same eigenpairs, minutes faster).
        Spectra::SparseSymMatProd<scalar> massProduct(M);
        bool ok = false;
        if (eigenDirect) {
            CholmodRegularInverse laplaceSolve(L);
            Spectra::SymGEigsSolver<Spectra::SparseSymMatProd<scalar>, CholmodRegularInverse, Spectra::GEigsMode::RegularInverse> solver(
                massProduct, laplaceSolve, eigenCount, std::min(2 * eigenCount, m));
            solver.init();
            solver.compute(Spectra::SortRule::LargestAlge);
            ok = solver.info() == Spectra::CompInfo::Successful;
            if (ok) values = solver.eigenvalues();
        } else {
            Spectra::SparseRegularInverse<scalar> laplaceSolve(L);
            Spectra::SymGEigsSolver<Spectra::SparseSymMatProd<scalar>, Spectra::SparseRegularInverse<scalar>,
                                    Spectra::GEigsMode::RegularInverse>
                solver(massProduct, laplaceSolve, eigenCount, std::min(2 * eigenCount, m));
            solver.init();
            solver.compute(Spectra::SortRule::LargestAlge);
            ok = solver.info() == Spectra::CompInfo::Successful;
            if (ok) values = solver.eigenvalues();
        }
        const double tEigen = since(t);
        std::printf("[eigenpairs] %.3f s: %s\n", tEigen, ok ? "converged" : "not converged");
        json << ", \"eigen\": " << tEigen;
        if (ok) {
            extra += ", \"eigenvalues_grid_units\": [";
            for (int i = int(values.size()) - 1; i >= 0; --i) {  // L v = λ M v: λ = 1 / Spectra's ν, from the largest λ down
                std::ostringstream v;
                v.precision(10);
                v << 1.0 / values(i);
                extra += v.str() + (i ? ", " : "");
            }
            extra += "]";
        }
    }
    json << "}" << extra << "}";
    if (!dump.empty()) {
        FILE* f = std::fopen((dump + "_voxels.csv").c_str(), "w");
        if (!f) return 1;
        // (precomputeStencils may add a node past the band: the distance vector is then longer by one)
        const bool withGreen = greenValues.size() == m, withDistance = distance.size() >= m;
        std::fprintf(f, "x,y,z,mu,T00,T01,T02,T11,T12,T22,mean%s%s\n", withGreen ? ",green" : "", withDistance ? ",distance" : "");
        std::vector<const StochasticCalculus::ComputeNode*> byId(std::size_t(m), nullptr);
        for (const auto& entry : calculus.getNodes())
            if (entry.second.id >= 0 && entry.second.id < m) byId[std::size_t(entry.second.id)] = &entry.second;
        for (int i = 0; i < m; ++i) {
            const auto& G = byId[std::size_t(i)]->G;
            std::fprintf(f, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", X(0, i), X(1, i), X(2, i), mu(i), G(0, 0), G(0, 1),
                         G(0, 2), G(1, 1), G(1, 2), G(2, 2), byId[std::size_t(i)]->pred.mean(0));
            if (withGreen) std::fprintf(f, ",%.9g", greenValues(i));
            if (withDistance) std::fprintf(f, ",%.9g", distance(i));
            std::fprintf(f, "\n");
        }
        std::fclose(f);
    }
    std::printf("RESULT %s\n", json.str().c_str());
    return 0;
}
