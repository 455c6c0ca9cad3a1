// Spectrum (spectral issue): time and peak memory of the k lowest eigenpairs (k = 20, 200) on bunny bands of
// growing N, and the choice of method: Lanczos on L⁻¹M with L factored by CHOLMOD (supernodal; the engine's) or by
// Eigen's SimplicialLLT. One band per process call; peak memory per stage is the resident-set high-water mark,
// reset before each stage (/proc/self/clear_refs) with large blocks returned to the system at once (mallopt).
// Usage: bench_spectrum [--data DIR] [--sigma 1] [--scales 1,0.8,0.63] [--counts 20,200] [--methods cholmod,simplicial]
//        [--out FILE.json]  (rows are appended to FILE.json's "runs")
#include <malloc.h>

#include <Eigen/SparseCholesky>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <Spectra/SymGEigsShiftSolver.h>
#include <sstream>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/stencil/resolution.h"
#include "gpisvdb/tasks/spectrum.h"

#include "timing.h"

using namespace gpisvdb;
using bench::Clock;
using bench::seconds;

namespace {

std::vector<double> numbers(const std::string& s) {
    std::vector<double> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) out.push_back(std::stod(item));
    return out;
}

/// Resident-set high-water mark (bytes) since the last reset.
double peakBytes() {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("VmHWM:", 0) == 0) return 1024.0 * std::stod(line.substr(6));
    return 0;
}

double currentBytes() {
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind("VmRSS:", 0) == 0) return 1024.0 * std::stod(line.substr(6));
    return 0;
}

/// The BLAS this process loaded (CHOLMOD's supernodal factor spends its time there).
std::string blasName() {
    std::ifstream in("/proc/self/maps");
    std::string line;
    while (std::getline(in, line))
        if (line.find("openblas") != std::string::npos) return "OpenBLAS";
    return "reference BLAS";
}

void resetPeak() {
    malloc_trim(0);
    std::ofstream("/proc/self/clear_refs") << "5";
}

// === The alternative: the same Lanczos with Eigen's SimplicialLLT (AMD ordering) as the inverse
struct SimplicialInverse {
    using Scalar = double;
    const Eigen::SimplicialLLT<SparseMatrixD>& factor;
    Eigen::Index rows() const { return factor.rows(); }
    Eigen::Index cols() const { return factor.cols(); }
    void set_shift(double) {}
    void perform_op(const double* x, double* y) const {
        Eigen::Map<Eigen::VectorXd>(y, rows()) = factor.solve(Eigen::Map<const Eigen::VectorXd>(x, rows()));
    }
};

struct Mass {
    using Scalar = double;
    const Eigen::VectorXd& m;
    Eigen::Index rows() const { return m.size(); }
    Eigen::Index cols() const { return m.size(); }
    void perform_op(const double* x, double* y) const {
        Eigen::Map<Eigen::VectorXd>(y, m.size()) = m.cwiseProduct(Eigen::Map<const Eigen::VectorXd>(x, m.size()));
    }
};

nlohmann::json simplicialRun(const SparseMatrixD& L, const Eigen::VectorXd& mass, int k) {
    resetPeak();
    const double base = currentBytes();
    auto t = Clock::now();
    Eigen::SimplicialLLT<SparseMatrixD> factor(L);
    const double factorS = seconds(t);
    const double factorNnz = double(factor.matrixL().nestedExpression().nonZeros());
    t = Clock::now();
    SimplicialInverse op{factor};
    Mass bop{mass};
    const Eigen::Index ncv = std::max<Eigen::Index>(2 * k, k + 20);
    Spectra::SymGEigsShiftSolver<SimplicialInverse, Mass, Spectra::GEigsMode::ShiftInvert> lanczos(op, bop, k, ncv, 0.0);
    lanczos.init();
    lanczos.compute(Spectra::SortRule::LargestMagn, 1000, 1e-10, Spectra::SortRule::SmallestAlge);
    const double lanczosS = seconds(t);
    const Eigen::VectorXd values = lanczos.eigenvalues();
    return {{"method", "simplicial"},
            {"k", k},
            {"factor_s", factorS},
            {"lanczos_s", lanczosS},
            {"total_s", factorS + lanczosS},
            {"factor_nonzeros", factorNnz},
            {"peak_bytes_above_band", peakBytes() - base},
            {"lambda_0", values.size() ? values(0) : 0.0},
            {"converged", lanczos.info() == Spectra::CompInfo::Successful}};
}

nlohmann::json cholmodRun(const SparseMatrixD& L, const Eigen::VectorXd& mass, int k) {
    resetPeak();
    const double base = currentBytes();
    EigenOptions o;
    o.count = k;
    const EigenResult r = lowestEigenpairs(L, mass, o);
    return {{"method", "cholmod"},
            {"k", k},
            {"factor_s", r.factorSeconds},
            {"lanczos_s", r.lanczosSeconds},
            {"total_s", r.factorSeconds + r.lanczosSeconds},
            {"cholmod_peak_bytes", r.factorBytes},
            {"factor_nonzeros", r.factorNonzeros},
            {"ordering", r.ordering},
            {"peak_bytes_above_band", peakBytes() - base},
            {"lambda_0", r.values(0)},
            {"max_residual", r.residuals.maxCoeff()},
            {"orthonormality_error", r.orthonormalityError},
            {"solves", r.solves},
            {"restarts", r.restarts},
            {"subspace", r.subspace}};
}

}  // namespace

int main(int argc, char** argv) {
    std::string data = "data", out, methods = "cholmod,simplicial";
    double sigma = 1.0;
    std::vector<double> scales = {1.0}, counts = {20, 200};
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string a = argv[i], v = argv[i + 1];
        if (a == "--data") data = v;
        else if (a == "--sigma") sigma = std::stod(v);
        else if (a == "--scales") scales = numbers(v);
        else if (a == "--counts") counts = numbers(v);
        else if (a == "--methods") methods = v;
        else if (a == "--out") out = v;
    }
    mallopt(M_MMAP_THRESHOLD, 1 << 20);  // blocks ≥ 1 MB come from mmap and go back on free: peaks per stage are real
    nlohmann::json results = nlohmann::json::object();
    if (!out.empty() && std::ifstream(out).good()) results = nlohmann::json::parse(std::ifstream(out));
    const Samples s = makeSamples(readInput(data + "/bunny.obj"), {sigma}).samples;
    const BarnesHutGpis model(s, 0.4 * s.lengthScale);
    const Resolution res = chooseResolution(model, s);
    for (double scale : scales) {
        BandOptions bo;
        bo.voxelSize = scale * res.hStar;
        auto t = Clock::now();
        const Band band = buildBand(model, s, bo).band;
        const double bandS = seconds(t);
        const SparseMatrixD L = assembleLaplacianDouble(band);
        const Eigen::VectorXd mass = massVector(band);
        const double bandBytes = currentBytes();
        std::cerr << "N = " << band.size() << " (h = " << bo.voxelSize << "), band " << bandS << " s\n";
        for (double k : counts) {
            for (const std::string method : {"cholmod", "simplicial"}) {
                if (methods.find(method) == std::string::npos) continue;
                nlohmann::json row = method == "cholmod" ? cholmodRun(L, mass, int(k)) : simplicialRun(L, mass, int(k));
                row.update({{"input", "bunny"},
                            {"sigma_rel", sigma},
                            {"h", bo.voxelSize},
                            {"h_over_hstar", scale},
                            {"voxels", band.size()},
                            {"band_s", bandS},
                            {"resident_bytes_before", bandBytes},
                            {"L_nonzeros", L.nonZeros()},
                            {"blas", blasName()}});
                row["peak_bytes"] = bandBytes + row["peak_bytes_above_band"].get<double>();
                std::cerr << row.dump() << "\n";
                results["runs"].push_back(row);
                if (!out.empty()) std::ofstream(out) << results.dump(2) << "\n";
            }
        }
    }
    if (out.empty()) std::cout << results.dump(2) << "\n";
    return 0;
}
