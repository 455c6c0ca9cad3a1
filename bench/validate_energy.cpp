// Paper Fig. 6 (top): the expected Dirichlet energy fᵀ L f on a unit-sphere soup as σ falls, against the
// Dirichlet energy of the smooth sphere (8π/3 for f = x₁) and against the cotan energy of f on the GPIS mean
// surface (the paper's reference), for the adaptive-stencil L and for the naive K = M D_φ G_φ.
// Usage: validate_energy [--level L] [--sigma S1,S2,...] [--h-over-hstar F (default 1) | --h-over-wmu F] [--eta E]
//                        [--out FILE.json]
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/ops/first_order.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/stencil/resolution.h"

using namespace gpisvdb;
using Clock = std::chrono::steady_clock;

namespace {

struct TestFunction {
    const char* name;
    double (*f)(const Vec3d&);
    double sphereEnergy;  ///< ∫_S |∇_S f|² dA on the unit sphere (NaN when not known in closed form)
};

const TestFunction kFunctions[] = {
    {"x1", [](const Vec3d& x) { return x.x(); }, 8 * M_PI / 3},
    {"sin3", [](const Vec3d& x) { return std::sin(3 * x.x()) * std::sin(3 * x.y()) * std::sin(3 * x.z()); }, std::nan("")},
};

double quadratic(const SymmetricOperator& A, const std::vector<float>& f) {
    std::vector<float> Af;
    A.apply(f, Af);
    double e = 0;
    for (std::size_t i = 0; i < f.size(); ++i) e += double(f[i]) * double(Af[i]);
    return e;
}

openvdb::FloatGrid::Ptr meanGrid(const Band& band) {
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setTransform(band.index->transform().copy());
    auto acc = g->getAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) acc.setValue(band.coord[i], band.mean[i]);
    return g;
}

std::vector<double> parseList(const std::string& s) {
    std::vector<double> v;
    std::stringstream in(s);
    std::string item;
    while (std::getline(in, item, ',')) v.push_back(std::stod(item));
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    int level = 3;
    std::vector<double> sigmas{1, 0.5, 0.25, 0.1};
    double hOverWmu = 0, hOverHstar = 1, eta = 1e-6;  // default: the paper's resolution h = h* (Eq. 25)
    std::string out = "bench/results/energy.json";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--level" && i + 1 < argc) level = std::stoi(argv[++i]);
        else if (a == "--sigma" && i + 1 < argc) sigmas = parseList(argv[++i]);
        else if (a == "--h-over-wmu" && i + 1 < argc) hOverWmu = std::stod(argv[++i]), hOverHstar = 0;
        else if (a == "--h-over-hstar" && i + 1 < argc) hOverHstar = std::stod(argv[++i]), hOverWmu = 0;
        else if (a == "--eta" && i + 1 < argc) eta = std::stod(argv[++i]);
        else if (a == "--out" && i + 1 < argc) out = argv[++i];
        else {
            std::cerr << "usage: validate_energy [--level L] [--sigma S1,S2,...] [--h-over-wmu F | --h-over-hstar F] [--eta E] "
                         "[--out FILE.json]\n";
            return 2;
        }
    }
    if (!(hOverHstar > 0) && !(hOverWmu > 0)) {
        std::cerr << "validate_energy: the voxel-size factor must be > 0\n";
        return 2;
    }
    const TriangleSoup soup = icosphere(level);
    nlohmann::json rows = nlohmann::json::array();
    openvdb::FloatGrid::Ptr finestMean;
    double finestH = 1e300;
    for (double sigma : sigmas) {
        const auto t0 = Clock::now();
        const SoupSamples ss = soupSamples(soup, {sigma});
        const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
        const Resolution res = chooseResolution(model, ss.samples);
        BandOptions o;
        o.voxelSize = hOverHstar > 0 ? hOverHstar * res.hStar : hOverWmu * res.muWidth;
        o.etaRelative = eta;
        const BandResult br = buildBand(model, ss.samples, o);
        const Band& band = br.band;
        const double secondsBand = std::chrono::duration<double>(Clock::now() - t0).count();
        const LaplacianOperator L(band);
        const NaiveLaplacianOperator K(band);
        nlohmann::json row = {{"sigma_rel", sigma},         {"h", band.voxelSize}, {"h_over_wmu", band.voxelSize / res.muWidth},
                              {"h_star", res.hStar},        {"w_mu", res.muWidth}, {"eta_rel", eta},
                              {"voxels", band.size()},      {"mass", band.mass()}, {"max_stencil_l1", br.stats.maxStencilL1},
                              {"seconds_band", secondsBand}};
        for (const TestFunction& tf : kFunctions) {
            std::vector<float> f(band.size());
            for (std::size_t i = 0; i < band.size(); ++i)
                f[i] = float(tf.f(band.voxelSize * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z())));
            const double eL = quadratic(L, f), eK = quadratic(K, f);
            nlohmann::json e = {{"L", eL}, {"naive", eK}};
            if (std::isfinite(tf.sphereEnergy))
                e["sphere"] = tf.sphereEnergy, e["L_error_vs_sphere"] = eL / tf.sphereEnergy - 1,
                e["naive_error_vs_sphere"] = eK / tf.sphereEnergy - 1;
            row[tf.name] = e;
        }
        std::cerr << row.dump() << std::endl;
        rows.push_back(row);
        if (band.voxelSize < finestH) finestH = band.voxelSize, finestMean = meanGrid(band);
    }
    // === The mean surface of the finest band, and f's cotan energy on it (σ-independent: γ does not depend on σ)
    const SurfaceMesh mesh = meanSurface(*finestMean, 0.5);
    nlohmann::json reference = {{"mesh_h", finestH}, {"mesh_triangles", mesh.triangles.size()}, {"area", surfaceArea(mesh)}};
    for (const TestFunction& tf : kFunctions) {
        std::vector<double> f(mesh.vertices.size());
        for (std::size_t v = 0; v < f.size(); ++v) f[v] = tf.f(Vec3d(mesh.vertices[v][0], mesh.vertices[v][1], mesh.vertices[v][2]));
        const double ref = dirichletEnergy(mesh, f);
        reference[tf.name] = ref;
        for (auto& row : rows) {
            row[tf.name]["mean_surface"] = ref;
            row[tf.name]["L_error_vs_mean_surface"] = row[tf.name]["L"].get<double>() / ref - 1;
            row[tf.name]["naive_error_vs_mean_surface"] = row[tf.name]["naive"].get<double>() / ref - 1;
        }
    }
    nlohmann::json report = {{"command", "validate_energy"},    {"sphere_level", level},     {"triangles", soup.triangles.size()},
                             {"reference_8pi_3", 8 * M_PI / 3}, {"mean_surface", reference}, {"rows", rows}};
    std::cout << report.dump(2) << std::endl;
    std::ofstream(out) << report.dump(2) << "\n";
}
