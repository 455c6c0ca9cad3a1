// The default voxel size (issue 17, item 6): how mass, Dirichlet energy, spectrum and geodesics depend on h / w_μ,
// w_μ = median √c₀₀/‖∇γ‖ at the samples (μ's width across the surface), on grids given as multiples of w_μ (not
// capped at h*). Sphere: the 1280-triangle unit-sphere soup (s = 0.4ℓ, Barnes–Hut); bunny: data/bunny.obj.
// Each (input, σ) runs its grids from the coarsest to the finest and compares every run with the finest one made.
// Per run, on the band a user gets (default η = 0.01): voxels, band time, Σ μ h³, the 10 lowest eigenvalues, and
// geodesic distances and path lengths from a source to fixed targets. Sphere only, on a second band with η = 10⁻⁶
// (the Dirichlet energy needs it, docs/operators.md): fᵀ L f for f = x₁ against 8π/3.
// Pictures (--part pictures): μ on the mean surface of the sphere (σ_rel 1) and of the bunny's ears (σ_rel 0.5
// unless --sigma), and on a slice through the ears, at h / w_μ = 0.5, 1, 1.25, 1.5, 2, 3 (unless --ratios): one PNG
// (--picture, default docs/images/resolution_mu.png); --vdb-dir also writes each band for a volume renderer.
// --values: μ and T at the voxels' centres (point, the default), the voxels' own shares (voxel, kacRiceVoxel), their
// means along the voxels' axes (column, kacRiceColumn), or as `gpisvdb` chooses them (auto: column values where
// h > 2 w_μ). voxel-auto: voxel values where h > 1.25 w_μ, so that `--values voxel-auto --ratios 1,2,4,8` compares
// coarse voxel-valued bands with a point-valued reference at h = w_μ (bench/results/coarse_voxels.json).
// Usage: bench_resolution [--part sphere|bunny|pictures|all] [--sigma S1,S2,...] [--ratios R1,R2,...] [--max-voxels N]
//        [--max-spectrum-voxels N] [--data DIR] [--out bench/results/resolution.json] [--picture FILE.png]
//        [--vdb-dir DIR] [--values point|voxel|column|auto|voxel-auto] [--sphere-level L (icosphere level, default 3)]
// Rows of the (input, σ) pairs run replace those already in --out; the others stay.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <openvdb/tools/Interpolation.h>
#include <sstream>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/band/default_band.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/output/mean_surface.h"
#include "gpisvdb/output/render.h"
#include "gpisvdb/output/write_vdb.h"
#include "gpisvdb/stencil/resolution.h"
#include "gpisvdb/tasks/geodesic.h"
#include "gpisvdb/tasks/spectrum.h"

#include "timing.h"

using namespace gpisvdb;
using bench::Clock;
using bench::seconds;

namespace {

std::vector<double> numbers(const std::string& s) {
    std::vector<double> v;
    std::stringstream in(s);
    for (std::string item; std::getline(in, item, ',');) v.push_back(std::stod(item));
    return v;
}

Vec3d world(const Band& band, std::size_t i) { return band.voxelSize * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z()); }

double angle(const Vec3d& a, const Vec3d& b) { return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)); }

double soupArea(const Samples& s) {
    double a = 0;
    for (const auto& w : s.normal) a += w.norm();
    return a;
}

/// fᵀ L f for f = x₁ at the voxel centres (as validate_energy: f in float, the sum in double).
double energyX1(const Band& band) {
    const LaplacianOperator L(band);
    std::vector<float> f(band.size()), Lf;
    for (std::size_t i = 0; i < band.size(); ++i) f[i] = float(world(band, i).x());
    L.apply(f, Lf);
    double e = 0;
    for (std::size_t i = 0; i < f.size(); ++i) e += double(f[i]) * double(Lf[i]);
    return e;
}

/// The band's mean surface {γ = ½} with μ sampled trilinearly at its vertices: what `gpisvdb render --grid mu` and
/// the demo draw. Where h does not resolve μ's profile across the surface, the sampled value depends on where
/// the surface crosses the grid, and the picture shows moiré.
struct MuSurface {
    openvdb::FloatGrid::Ptr mu;
    SurfaceMesh mesh;
};

MuSurface muSurface(const Band& band) {
    MuSurface m;
    openvdb::FloatGrid::Ptr mean;
    for (const auto& g : bandGrids(band)) {
        if (g->getName() == "mean") mean = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        if (g->getName() == "mu") m.mu = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
    }
    m.mesh = meanSurface(*mean, 0.5);
    sampleAtVertices(m.mesh, *m.mu);
    return m;
}

/// μ at the mean surface's vertices: its mean and its coefficient of variation (on the sphere μ is nearly
/// constant there, so the variation is the grid's moiré plus the soup's own facets).
nlohmann::json muSurfaceStats(const SurfaceMesh& mesh) {
    const std::vector<float>& v = mesh.arrays.back();
    double m = 0, q = 0;
    for (float x : v) m += x;
    m /= double(std::max<std::size_t>(1, v.size()));
    for (float x : v) q += (x - m) * (x - m);
    return {{"vertices", v.size()}, {"mean", m}, {"cv", std::sqrt(q / double(std::max<std::size_t>(1, v.size()))) / m}};
}

/// Relative RMS difference between μ of `grid` and `reference` values at the points (the finest run's surface).
double muDifference(const openvdb::FloatGrid& grid, const std::vector<openvdb::Vec3s>& points, const std::vector<float>& reference) {
    openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> sampler(grid);
    double d = 0, r = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double x = sampler.wsSample(openvdb::Vec3d(points[i]));
        d += (x - reference[i]) * (x - reference[i]), r += double(reference[i]) * reference[i];
    }
    return std::sqrt(d / std::max(r, 1e-300));
}

struct Input {
    std::string name;
    TriangleSoup soup;
    double sigma;
    bool sphere;
};

/// The runs of one (input, σ), coarsest first, then each compared with the finest.
nlohmann::json runInput(const Input& in, const std::vector<double>& ratiosAsked, double maxVoxels, double maxSpectrumVoxels,
                        const std::string& valueMode) {
    const SoupSamples ss = soupSamples(in.soup, {in.sigma});
    const Samples& samples = ss.samples;
    const BarnesHutGpis model(samples, 0.4 * samples.lengthScale);
    const Resolution res = chooseResolution(model, samples);
    const double area = soupArea(samples);
    std::vector<double> ratios = ratiosAsked;
    std::sort(ratios.rbegin(), ratios.rend());  // coarsest first: each run predicts the next one's size
    // Geodesic source and targets (snapped to the nearest band voxel): on the sphere the north pole and six targets
    // 63°–180° away, the antipode among them (one path is a noisy figure: it follows U's valley, which shifts with
    // the grid; the mean and the worst of their errors are kept); on the bunny the points of docs/geodesic.md.
    const Vec3d source = in.sphere ? Vec3d(0, 0, 1) : Vec3d(0.5, 6, 1);
    const std::vector<Vec3d> targets = in.sphere ? std::vector<Vec3d>{Vec3d(0, 0, -1),
                                                                      Vec3d(1, 0, 0),
                                                                      Vec3d(0, 1, 0),
                                                                      Vec3d(0.3, -0.5, -0.8).normalized(),
                                                                      Vec3d(-0.7, -0.7, 0.5).normalized(),
                                                                      Vec3d(-0.5, 0.6, -0.3).normalized()}
                                                 : std::vector<Vec3d>{Vec3d(-2, 9, 0), Vec3d(3, 4, -2)};
    nlohmann::json rows = nlohmann::json::array();
    std::vector<MuSurface> surfaces;      // each run's μ grid and mean surface, to compare with the finest's
    std::vector<std::size_t> surfaceRow;  // the row of each
    double lastH = 0, lastN = 0, lastThickN = 0;
    for (double ratio : ratios) {
        const double h = ratio * res.muWidth;
        nlohmann::json row = {
            {"input", in.name},    {"sigma_rel", in.sigma}, {"h_over_wmu", ratio}, {"h", h},           {"h_over_hstar", h / res.hStar},
            {"h_star", res.hStar}, {"w_mu", res.muWidth},   {"default_h", res.h},  {"soup_area", area}};
        const double cube = lastH > 0 ? std::pow(lastH / h, 3) : 0;
        if (lastN * cube > maxVoxels) {
            row["skipped"] = "predicted " + std::to_string(long(lastN * cube)) + " band voxels > --max-voxels";
            std::cerr << row.dump() << std::endl;
            rows.push_back(row);
            continue;
        }
        // === The band a user gets (η = 0.01)
        BandOptions o;
        o.voxelSize = h;
        if (valueMode == "voxel-auto") o.values = ratio > kMuWidthFactor ? VoxelValues::Voxel : VoxelValues::Point;
        else if (valueMode == "auto") o.values = ratio > kColumnValuesRatio ? VoxelValues::Column : VoxelValues::Point;
        else o.values = voxelValuesNamed(valueMode);
        row["values"] = voxelValuesName(o.values);
        // With voxel values the winding model's s follows h, as `gpisvdb` makes it (planDefaultBandFor)
        const GpisModel* rowModel = &model;
        std::unique_ptr<BarnesHutGpis> analysis;
        if (o.values == VoxelValues::Voxel && 0.4 * samples.lengthScale < kVoxelSmoothing * h) {
            analysis = std::make_unique<BarnesHutGpis>(samples, kVoxelSmoothing * h);
            rowModel = analysis.get();
        }
        row["smoothing"] = analysis ? kVoxelSmoothing * h : 0.4 * samples.lengthScale;
        auto t = Clock::now();
        const BandResult br = buildBand(*rowModel, samples, o);
        const Band& band = br.band;
        row["band_seconds"] = seconds(t);
        row["voxels"] = band.size();
        row["evaluated"] = br.stats.evaluated;
        row["max_stencil_l1"] = br.stats.maxStencilL1;
        row["mass"] = band.mass();
        row["mass_vs_soup_area"] = band.mass() / area - 1;
        lastH = h, lastN = double(band.size());
        {
            MuSurface ms = muSurface(band);
            row["mu_on_mean_surface"] = muSurfaceStats(ms.mesh);
            surfaces.push_back(std::move(ms));
            surfaceRow.push_back(rows.size());
        }
        std::cerr << "  " << in.name << " sigma " << in.sigma << " h/w_mu " << ratio << ": " << band.size() << " voxels" << std::endl;

        // === Dirichlet energy of x₁ on the η = 10⁻⁶ band (sphere only)
        if (in.sphere) {
            const double predicted = lastThickN > 0 ? lastThickN * cube : 2.2 * double(band.size());
            if (predicted > maxVoxels) {
                row["energy_skipped"] = "predicted " + std::to_string(long(predicted)) + " voxels at eta 1e-6 > --max-voxels";
            } else {
                BandOptions thick = o;
                thick.etaRelative = 1e-6;
                t = Clock::now();
                const BandResult tr = buildBand(*rowModel, samples, thick);
                const Band& b = tr.band;
                const double tb = seconds(t);
                const double e = energyX1(b);
                lastThickN = double(b.size());
                row["energy"] = {{"eta_rel", 1e-6},
                                 {"voxels", b.size()},
                                 {"band_seconds", tb},
                                 {"mass", b.mass()},
                                 {"x1", e},
                                 {"x1_vs_8pi_3", e / (8 * M_PI / 3) - 1}};
            }
        }
        // === The 10 lowest eigenvalues (l = 0, the l = 1 triple, the l = 2 quintuple on the sphere, docs/spectrum.md)
        if (double(band.size()) <= maxSpectrumVoxels) {
            EigenOptions eo;
            eo.count = 10;
            const EigenResult er = spectrum(band, eo);
            std::vector<double> values(er.values.data(), er.values.data() + er.values.size());
            nlohmann::json s = {{"values", values},
                                {"factor_seconds", er.factorSeconds},
                                {"lanczos_seconds", er.lanczosSeconds},
                                {"max_residual", er.residuals.maxCoeff()}};
            if (in.sphere && values.size() >= 9) {
                const double l0 = values[0];
                const double l1 = (values[1] + values[2] + values[3]) / 3 - l0;
                double l2 = 0;
                for (int i = 4; i < 9; ++i) l2 += values[std::size_t(i)] / 5;
                l2 -= l0;
                const double r2 = band.mass() / (4 * M_PI);  // r² from the expected area
                s["lambda0"] = l0;
                s["l1_gap"] = l1;                              // mean(λ₁..λ₃) − λ₀
                s["l1_split"] = (values[3] - values[1]) / l1;  // the triple's spread, relative
                s["l2_over_l1"] = l2 / l1;                     // 3 on a sphere
                s["l1_gap_vs_2_over_r2"] = l1 / (2 / r2) - 1;
            }
            row["spectrum"] = s;
        } else {
            row["spectrum_skipped"] = "band voxels > --max-spectrum-voxels";
        }
        // === Geodesic distance and paths
        t = Clock::now();
        const GeodesicResult g = geodesicDistance(band, {source}, targets);
        nlohmann::json geo = {{"seconds", seconds(t)}, {"unreached", g.march.unreached}, {"targets", nlohmann::json::array()}};
        double radius = 0, mass = 0;  // μ-weighted mean radius of the band (the sphere the band is centred on)
        for (std::size_t i = 0; i < band.size(); ++i) radius += band.mu[i] * world(band, i).norm(), mass += band.mu[i];
        radius /= mass;
        const Vec3d src = world(band, g.sourceIndex[0]);
        for (std::size_t k = 0; k < targets.size(); ++k) {
            const GeodesicPath& p = g.paths[k];
            nlohmann::json tj = {{"target", {targets[k].x(), targets[k].y(), targets[k].z()}},
                                 {"U", p.distance},
                                 {"length", p.length},
                                 {"points", p.points.size()},
                                 {"reached_source", p.reachedSource}};
            if (in.sphere) {
                const double arc = angle(world(band, g.targetIndex[k]), src) * radius;
                double off = 0;  // largest distance of a path point from the sphere of radius `radius`
                for (const Vec3d& x : p.points) off = std::max(off, std::abs(x.norm() - radius));
                tj["arc"] = arc;
                tj["length_vs_arc"] = p.length / arc - 1;
                tj["max_off_sphere_over_h"] = off / h;
            }
            geo["targets"].push_back(tj);
        }
        if (in.sphere) {
            double mean = 0, worst = 0;
            for (const auto& tj : geo["targets"]) {
                const double e = tj["length_vs_arc"].get<double>();
                mean += std::abs(e) / double(targets.size()), worst = std::max(worst, std::abs(e));
            }
            geo["length_vs_arc_mean_abs"] = mean;
            geo["length_vs_arc_max_abs"] = worst;
        }
        if (in.sphere) {
            // U/θ on the voxels nearest the mean radius, θ ∈ [0.4, 2.6] (as tests/test_geodesic.cpp): U's isotropy
            std::vector<double> q;
            for (std::size_t i = 0; i < band.size(); ++i) {
                const Vec3d x = world(band, i);
                const double theta = angle(x, src);
                if (std::abs(x.norm() - radius) > h / 2 || theta < 0.4 || theta > 2.6) continue;
                q.push_back(g.march.distance[i] / theta);
            }
            double m = 0, v = 0;
            for (double x : q) m += x;
            m /= double(std::max<std::size_t>(1, q.size()));
            for (double x : q) v += (x - m) * (x - m);
            geo["radius"] = radius;
            geo["u_over_theta"] = {
                {"voxels", q.size()}, {"mean", m}, {"spread", std::sqrt(v / double(std::max<std::size_t>(1, q.size()))) / m}};
        }
        row["geodesic"] = geo;
        std::cerr << row.dump() << std::endl;
        rows.push_back(row);
    }
    // === Against the finest run made
    const nlohmann::json* finest = nullptr;
    for (const auto& r : rows)
        if (r.contains("voxels") && (!finest || r["h"].get<double>() < (*finest)["h"].get<double>())) finest = &r;
    if (!finest) return rows;
    const nlohmann::json ref = *finest;
    const nlohmann::json* finestEnergy = nullptr;
    for (const auto& r : rows)
        if (r.contains("energy") && (!finestEnergy || r["h"].get<double>() < (*finestEnergy)["h"].get<double>())) finestEnergy = &r;
    const nlohmann::json refE = finestEnergy ? *finestEnergy : nlohmann::json();
    const nlohmann::json* finestSpectrum = nullptr;
    for (const auto& r : rows)
        if (r.contains("spectrum") && (!finestSpectrum || r["h"].get<double>() < (*finestSpectrum)["h"].get<double>())) finestSpectrum = &r;
    const nlohmann::json refS = finestSpectrum ? *finestSpectrum : nlohmann::json();
    for (auto& r : rows) {
        if (!r.contains("voxels")) continue;
        r["vs_finest"] = {{"h_over_wmu", ref["h_over_wmu"]}, {"mass", r["mass"].get<double>() / ref["mass"].get<double>() - 1}};
        if (r.contains("energy") && !refE.is_null())
            r["vs_finest"]["energy_h_over_wmu"] = refE["h_over_wmu"],
            r["vs_finest"]["energy_x1"] = r["energy"]["x1"].get<double>() / refE["energy"]["x1"].get<double>() - 1;
        if (r.contains("spectrum") && !refS.is_null()) {
            const auto& a = r["spectrum"]["values"];
            const auto& b = refS["spectrum"]["values"];
            double worst = 0;
            for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
                worst = std::max(worst, std::abs(a[i].get<double>() / b[i].get<double>() - 1));
            r["vs_finest"]["spectrum_h_over_wmu"] = refS["h_over_wmu"];
            r["vs_finest"]["eigenvalues_max"] = worst;
            r["vs_finest"]["lambda0"] = a[0].get<double>() / b[0].get<double>() - 1;
            if (r["spectrum"].contains("l1_gap"))
                r["vs_finest"]["l1_gap"] = r["spectrum"]["l1_gap"].get<double>() / refS["spectrum"]["l1_gap"].get<double>() - 1;
        }
        for (std::size_t k = 0; k < surfaces.size(); ++k)
            if (&rows[surfaceRow[k]] == &r)
                r["vs_finest"]["mu_on_surface_rms"] =
                    muDifference(*surfaces[k].mu, surfaces.back().mesh.vertices, surfaces.back().mesh.arrays.back());
        nlohmann::json u = nlohmann::json::array(), len = nlohmann::json::array();
        for (std::size_t k = 0; k < r["geodesic"]["targets"].size(); ++k) {
            const auto& a = r["geodesic"]["targets"][k];
            const auto& b = ref["geodesic"]["targets"][k];
            u.push_back(a["U"].get<double>() / b["U"].get<double>() - 1);
            len.push_back(a["length"].get<double>() / b["length"].get<double>() - 1);
        }
        r["vs_finest"]["geodesic_U"] = u;
        r["vs_finest"]["path_length"] = len;
        double mean = 0, worst = 0;
        for (const auto& x : len)
            mean += std::abs(x.get<double>()) / double(len.size()), worst = std::max(worst, std::abs(x.get<double>()));
        r["vs_finest"]["path_length_mean_abs"] = mean;
        r["vs_finest"]["path_length_max_abs"] = worst;
    }
    return rows;
}

/// The bands of one picture subject at each h / w_μ: μ's grid and mean surface, and the figures of each.
struct PictureSet {
    std::string name;
    Resolution res;
    std::vector<MuSurface> surfaces;
    nlohmann::json rows = nlohmann::json::array();
};

PictureSet pictureSet(const std::string& name, const TriangleSoup& soup, double sigma, const std::vector<double>& ratios,
                      const std::string& vdbDir) {
    PictureSet set;
    set.name = name;
    const SoupSamples ss = soupSamples(soup, {sigma});
    const BarnesHutGpis model(ss.samples, 0.4 * ss.samples.lengthScale);
    set.res = chooseResolution(model, ss.samples);
    for (double ratio : ratios) {
        BandOptions o;
        o.voxelSize = ratio * set.res.muWidth;
        auto t = Clock::now();
        const Band band = buildBand(model, ss.samples, o).band;
        set.surfaces.push_back(muSurface(band));
        if (!vdbDir.empty()) {
            std::ostringstream file;
            file << vdbDir << "/" << name << "_" << ratio << ".vdb";
            writeBandVdb(band, file.str(), openvdb::MetaMap());
        }
        nlohmann::json row = {{"h_over_wmu", ratio},
                              {"h", o.voxelSize},
                              {"voxels", band.size()},
                              {"seconds", seconds(t)},
                              {"mu_on_mean_surface", muSurfaceStats(set.surfaces.back().mesh)}};
        std::cerr << name << " " << row.dump() << std::endl;
        set.rows.push_back(row);
    }
    const SurfaceMesh& finest = set.surfaces.front().mesh;
    for (std::size_t k = 0; k < set.surfaces.size(); ++k)
        set.rows[k]["mu_on_surface_rms_vs_finest"] = muDifference(*set.surfaces[k].mu, finest.vertices, finest.arrays.back());
    return set;
}

/// One picture, one column per h / w_μ: μ on the mean surface of the unit-sphere soup at σ_rel 1 (μ is nearly
/// constant there, so any pattern is the grid's), μ on the mean surface of the bunny's ears (triangles with
/// centroid y > 7.5, σ_rel `sigma`: the whole bunny at h = w_μ/2 would need ≈ 5 M voxels) and on the slice
/// y = 8.5 through them. With `vdbDir`, each band is also written there for a volume renderer (vdb_render).
nlohmann::json runPictures(const std::string& data, double sigma, std::vector<double> ratios, const std::string& png,
                           const std::string& vdbDir) {
    std::sort(ratios.begin(), ratios.end());  // finest first: the reference of mu_on_surface_rms_vs_finest
    const double big = 1e9;
    const TriangleSoup ears = cutBox(*readInput(data + "/bunny.obj").soup, Vec3d(-big, -big, -big), Vec3d(big, 7.5, big));
    const PictureSet sphere = pictureSet("sphere", icosphere(3), 1.0, ratios, vdbDir);
    const PictureSet bunny = pictureSet("ears", ears, sigma, ratios, vdbDir);
    // Titles on the top row only (h / w_μ, one per column): the ears' mesh reaches the top of its panels.
    std::vector<RenderPanel> panels;
    for (const PictureSet* set : {&sphere, &bunny})
        for (std::size_t k = 0; k < ratios.size(); ++k) {
            RenderPanel p;
            if (set == &sphere) {
                std::ostringstream t;
                t << "h = " << ratios[k] << " w_mu";
                p.title = t.str();
            }
            p.surface = &set->surfaces[k].mesh, p.array = "mu", p.colormap = Colormap::Magma;
            panels.push_back(p);
        }
    for (std::size_t k = 0; k < ratios.size(); ++k) {
        RenderPanel p;
        p.sliceGrid = bunny.surfaces[k].mu.get(), p.slice = {1, 8.5}, p.colormap = Colormap::Magma;
        panels.push_back(p);
    }
    RenderOptions ro;
    ro.columns = int(ratios.size());
    ro.panelWidth = 180, ro.panelHeight = 165;  // 6 columns: a picture of < 300 kB for docs/images
    ro.azimuth = 60, ro.elevation = 20;
    std::ostringstream caption;
    caption << "rows: mu on the mean surface of the unit-sphere soup (sigma 1 l), of the bunny's ears (y > 7.5, sigma " << sigma
            << " l), and on the slice y = 8.5 through the ears";
    ro.caption = caption.str();
    if (!png.empty()) renderPng(panels, ro, png);
    auto json = [](const PictureSet& set, const std::string& input, double s) {
        return nlohmann::json{{"input", input}, {"sigma_rel", s}, {"w_mu", set.res.muWidth}, {"h_star", set.res.hStar}, {"rows", set.rows}};
    };
    return {{"picture", png},
            {"sphere", json(sphere, "unit-sphere soup, icosphere(3)", 1.0)},
            {"ears", json(bunny, "bunny ears (data/bunny.obj, triangles with centroid y > 7.5)", sigma)}};
}

}  // namespace

int main(int argc, char** argv) {
    std::string part = "all", out = "bench/results/resolution.json", data = "data";
    std::vector<double> sigmas{1, 0.5, 0.25}, ratios{0.5, 0.75, 1, 1.25, 1.5, 2, 3};
    double maxVoxels = 1.1e6, maxSpectrumVoxels = 7e5;  // "about 1 M": σ_rel 0.25 at h = w_μ has 1.03 M
    std::string picture = "docs/images/resolution_mu.png", vdbDir, valueMode = "point";
    int sphereLevel = 3;  // icosphere(3): 1280 triangles
    bool ratiosGiven = false;
    bool sigmaGiven = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--part" && i + 1 < argc) part = argv[++i];
        else if (a == "--sigma" && i + 1 < argc) sigmas = numbers(argv[++i]), sigmaGiven = true;
        else if (a == "--ratios" && i + 1 < argc) ratios = numbers(argv[++i]), ratiosGiven = true;
        else if (a == "--max-voxels" && i + 1 < argc) maxVoxels = std::stod(argv[++i]);
        else if (a == "--max-spectrum-voxels" && i + 1 < argc) maxSpectrumVoxels = std::stod(argv[++i]);
        else if (a == "--data" && i + 1 < argc) data = argv[++i];
        else if (a == "--out" && i + 1 < argc) out = argv[++i];
        else if (a == "--picture" && i + 1 < argc) picture = argv[++i];
        else if (a == "--vdb-dir" && i + 1 < argc) vdbDir = argv[++i];
        else if (a == "--values" && i + 1 < argc) valueMode = argv[++i];
        else if (a == "--sphere-level" && i + 1 < argc) sphereLevel = std::stoi(argv[++i]);
        else {
            std::cerr << "usage: bench_resolution [--part sphere|bunny|pictures|all] [--sigma S1,S2,...] [--ratios R1,R2,...] "
                         "[--max-voxels N] [--max-spectrum-voxels N] [--data DIR] [--out FILE.json] [--picture FILE.png] "
                         "[--vdb-dir DIR] [--values point|voxel|column|auto|voxel-auto] [--sphere-level L]\n";
            return 2;
        }
    }
    if (valueMode != "point" && valueMode != "voxel" && valueMode != "auto" && valueMode != "column" && valueMode != "voxel-auto") {
        std::cerr << "bench_resolution: --values must be point, voxel, column, auto or voxel-auto\n";
        return 2;
    }
    if (part != "sphere" && part != "bunny" && part != "pictures" && part != "all") {
        std::cerr << "bench_resolution: --part must be sphere, bunny, pictures or all\n";
        return 2;
    }
    nlohmann::json report = nlohmann::json::object();
    {
        std::ifstream in(out);
        if (in) try {
                in >> report;
            } catch (...) {
                report = nlohmann::json::object();
            }
    }
    std::vector<Input> inputs;
    if (part == "sphere" || part == "all")
        for (double s : sigmas) inputs.push_back({"sphere", icosphere(sphereLevel), s, true});
    if (part == "bunny" || part == "all")
        for (double s : sigmaGiven ? sigmas : std::vector<double>{0.5})
            inputs.push_back({"bunny", *readInput(data + "/bunny.obj").soup, s, false});
    report["machine"] = "2-core x86-64 (project machine), all threads";
    report["note"] =
        "h = (h/w_mu) w_mu, not capped at h*; eta 0.01 unless stated; energy on a second band at eta 1e-6; "
        "vs_finest: relative to the finest run of the same input and sigma";
    if (!report.contains("runs")) report["runs"] = nlohmann::json::array();
    if (part == "pictures" || part == "all") {
        report["pictures"] = runPictures(data, sigmaGiven ? sigmas.front() : 0.5,
                                         ratiosGiven ? ratios : std::vector<double>{0.5, 1, 1.25, 1.5, 2, 3}, picture, vdbDir);
        std::ofstream(out) << report.dump(2) << "\n";
    }
    for (const Input& in : inputs) {
        nlohmann::json kept = nlohmann::json::array();
        for (const auto& r : report["runs"])
            if (!(r["input"] == in.name && std::abs(r["sigma_rel"].get<double>() - in.sigma) < 1e-12)) kept.push_back(r);
        for (const auto& r : runInput(in, ratios, maxVoxels, maxSpectrumVoxels, valueMode)) kept.push_back(r);
        report["runs"] = kept;
        std::ofstream(out) << report.dump(2) << "\n";
    }
    std::cout << "wrote " << out << "\n";
}
