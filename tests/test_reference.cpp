// Agreement with the paper's own implementation (GPGP) at test size (docs/reference.md#agreement): on a small .gdp
// of our own, GPGP's field, μ and T at a sample of its band's voxels, stored with the commands that made them
// (tests/data/README.md, bench/reference_testdata.py), against our model in reference mode (its s, QMC points and
// level), joined on position.
#include <catch2/catch.hpp>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "gpisvdb/input/read_input.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/kacrice/qmc_rule.h"
#include "gpisvdb/model/direct_gpis.h"
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
    // Measured 0.14 % and 0.15 % of the peak, 0.1 % in the sum (docs/reference.md#agreement): 13× our own QMC error at
    // 512 points, not traced further.
    CHECK(worstMu < 0.005);
    CHECK(worstT < 0.005);
    CHECK(std::abs(sumOurs / sumReference - 1) < 0.005);
}
