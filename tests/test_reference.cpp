// Agreement with the paper's own implementation (GPGP) at test size (docs/reference.md#agreement): on a small .gdp
// of our own, GPGP's field, μ and T at a sample of its band's voxels, stored with the commands that made them
// (tests/data/README.md, bench/reference_testdata.py), against our model in reference mode (its s, QMC points and
// level), joined on position; and the paper's own spot (data/), whose expected area its clip of μ loses.
#include <catch2/catch.hpp>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gpisvdb/band/build_band.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/model/load_model.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

/// GPGP clips μ at max_mu = 20 and T where its Frobenius norm exceeds 20 (StochasticCalculus::max_mu).
constexpr double kReferenceClip = 20;

struct ReferenceVoxel {
    Vec3d x;
    double mu;
    Mat3d T;
    double field;  ///< GPGP's field's mean (its own offset and scale)
};

std::vector<ReferenceVoxel> readVoxels(const std::string& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    REQUIRE(line == "x,y,z,mu,T00,T01,T02,T11,T12,T22,mean");
    std::vector<ReferenceVoxel> voxels;
    while (std::getline(in, line)) {
        std::replace(line.begin(), line.end(), ',', ' ');
        std::istringstream row(line);
        ReferenceVoxel v;
        double t[6];
        row >> v.x[0] >> v.x[1] >> v.x[2] >> v.mu >> t[0] >> t[1] >> t[2] >> t[3] >> t[4] >> t[5] >> v.field;
        REQUIRE(row);
        v.T << t[0], t[1], t[2], t[1], t[3], t[4], t[2], t[4], t[5];
        voxels.push_back(v);
    }
    return voxels;
}

struct Agreement {
    std::vector<ReferenceVoxel> reference;
    std::vector<SurfaceDensity> ours;
    std::vector<double> gamma;
};

/// Our μ, T and γ at the reference's voxels, in reference mode: the direct sum (the reference ran at β = 100, nearly
/// exact), its smoothing s and QMC points, the level the mean of γ at the dipoles (the reference's is the mean of its
/// field there).
Agreement evaluateAtReferenceVoxels() {
    const nlohmann::json p = nlohmann::json::parse(std::ifstream(test::testDataPath("icosphere_320_gpgp.json")));
    Agreement a;
    a.reference = readVoxels(test::testDataPath("icosphere_320_gpgp_voxels.csv"));
    REQUIRE(a.reference.size() == p["kept"].get<std::size_t>());
    const InputSamples in = makeSamples(readInput(test::testDataPath("icosphere_320.gdp")));
    const DirectGpis model(in.samples, p["smoothing"].get<double>());
    double iso = 0;
    for (const Vec3d& x : in.samples.position) iso += model.evaluate(x).mean[0];
    iso /= double(in.samples.size());
    const QmcRule rule(p["qmc"].get<int>());
    for (const ReferenceVoxel& v : a.reference) {
        const ValueGradient z = model.evaluate(v.x);
        a.gamma.push_back(z.mean[0]);
        a.ours.push_back(kacRice(z, iso, rule));
    }
    return a;
}

/// Clipped by the reference (within the 9 digits its values are stored with).
bool clipped(const ReferenceVoxel& v) { return v.mu >= kReferenceClip * (1 - 1e-6) || v.T.norm() >= kReferenceClip * (1 - 1e-6); }

}  // namespace

TEST_CASE("reference: the paper implementation's field is ours up to an offset and a scale", "[reference]") {
    const Agreement a = evaluateAtReferenceVoxels();
    // === Least squares field ≈ α γ + β
    const std::size_t n = a.reference.size();
    double mg = 0, mf = 0;
    for (std::size_t i = 0; i < n; ++i) mg += a.gamma[i], mf += a.reference[i].field;
    mg /= double(n), mf /= double(n);
    double sgf = 0, sgg = 0, lo = 1e300, hi = -1e300;
    for (std::size_t i = 0; i < n; ++i) {
        sgf += (a.gamma[i] - mg) * (a.reference[i].field - mf), sgg += (a.gamma[i] - mg) * (a.gamma[i] - mg);
        lo = std::min(lo, a.reference[i].field), hi = std::max(hi, a.reference[i].field);
    }
    const double alpha = sgf / sgg, beta = mf - alpha * mg;
    double worst = 0;
    for (std::size_t i = 0; i < n; ++i) worst = std::max(worst, std::abs(alpha * a.gamma[i] + beta - a.reference[i].field));
    INFO("field = " << alpha << " gamma + " << beta << ", worst residual " << worst << " over a range " << hi - lo);
    CHECK(worst < 1e-5 * (hi - lo));  // measured 1.1e-7 (the file keeps 9 digits)
}

TEST_CASE("reference: mu and T agree with the paper implementation's once its clip at 20 is applied to ours", "[reference]") {
    const Agreement a = evaluateAtReferenceVoxels();
    double peak = 0;
    std::size_t clippedVoxels = 0;
    for (const ReferenceVoxel& v : a.reference) peak = std::max(peak, v.mu), clippedVoxels += clipped(v);
    // === Its clip reproduced on ours: μ at most 20, T scaled to a Frobenius norm of at most 20
    double worstMu = 0, worstT = 0, sumOurs = 0, sumReference = 0;
    for (std::size_t i = 0; i < a.reference.size(); ++i) {
        const ReferenceVoxel& v = a.reference[i];
        const double mu = std::min(a.ours[i].mu, kReferenceClip);
        const Mat3d T = a.ours[i].T * std::min(1.0, kReferenceClip / a.ours[i].T.norm());
        worstMu = std::max(worstMu, std::abs(mu - v.mu) / peak);
        worstT = std::max(worstT, (T - v.T).norm() / peak);
        sumOurs += mu, sumReference += v.mu;
    }
    INFO(a.reference.size() << " voxels, " << clippedVoxels << " clipped by the reference, peak mu " << peak << ", worst |d mu| / peak "
                            << worstMu << ", worst |d T|_F / peak " << worstT << ", sum of ours / theirs " << sumOurs / sumReference);
    // The clip is what separates the two Ts on this input (without it ours exceed theirs by up to 20 % of the peak).
    CHECK(clippedVoxels > 0);
    // Measured 0.14 % and 0.15 % of the peak, 0.1 % in the sum (docs/reference.md#agreement): the reference's third
    // kernel derivative and its variance floor (with both corrected in its copy, 0.025 %: docs/reference.md#mu-trace).
    CHECK(worstMu < 0.005);
    CHECK(worstT < 0.005);
    CHECK(std::abs(sumOurs / sumReference - 1) < 0.005);
}

TEST_CASE("reference: on the paper's own spot, our expected area is its dipoles' area, where its clip at 20 loses 40 %", "[reference]") {
    // data/spot_low_variance.gdp is the paper implementation's own input (3 961 dipoles made from a triangle soup,
    // data/README.md). In reference mode (its s = 0.76 ℓ, β = 3, its level; docs/reference.md#the-parameters-mapped)
    // at a voxel size 1.7× its own, to stay small here: Σ μ h³ is the expected area of the surface, which for noise
    // this small lies just above the mean surface's, the dipoles' Σ|w| = 6.005. The reference clips μ at 20, which
    // on this input caps 42 % of the voxels and leaves 3.51 (it reports 3.56 at its own h; docs/reference.md).
    const InputData data = readInput(test::dataPath("spot_low_variance.gdp"));
    ModelOptions mo;
    mo.smoothingRel = 0.7601560949859921;
    mo.noiseSmoothing = 0;
    mo.barnesHut.beta = 3;
    const LoadedModel m = loadModel(data, mo);
    REQUIRE(m.input.samples.size() == 3961);
    double inputArea = 0;
    for (const Vec3d& w : m.input.samples.normal) inputArea += w.norm();
    CHECK(inputArea == Approx(6.00525).epsilon(1e-5));
    BandOptions bo;
    bo.voxelSize = 0.02;
    bo.iso = 0.4544329098646812;  // the mean of γ at the dipoles (bench/reference.py)
    const Band band = buildBand(*m.model, m.input.samples, bo).band;
    double area = 0, clippedArea = 0;
    std::size_t clippedVoxels = 0;
    for (const float mu : band.mu) area += mu, clippedArea += std::min(double(mu), kReferenceClip), clippedVoxels += mu > kReferenceClip;
    const double h3 = bo.voxelSize * bo.voxelSize * bo.voxelSize;
    area *= h3, clippedArea *= h3;
    INFO(band.size() << " voxels, expected area " << area << ", clipped at 20: " << clippedArea << " (" << clippedVoxels << " voxels)");
    CHECK(area > inputArea);  // measured 6.215: +3.5 %
    CHECK(area < 1.05 * inputArea);
    CHECK(clippedArea < 0.65 * inputArea);  // measured 3.51
    CHECK(double(clippedVoxels) > 0.3 * double(band.size()));
}
