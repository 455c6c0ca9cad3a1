// Gaussian dipoles (.gdp): written samples read back as the same samples, the covariances the model carries and those
// it refuses, malformed files, and `gpisvdb convert`.
#include <catch2/catch.hpp>

#include <fstream>
#include <sstream>

#include "cli_run.h"
#include "gpisvdb/band/default_band.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/gdp.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/load_model.h"
#include "helpers.h"

using namespace gpisvdb;
using namespace gpisvdb::test::cli;

namespace {

/// Header "3 n" and the dipoles as given: position, vector area and a 6×6 covariance per dipole.
std::string gdpText(const std::vector<std::array<double, 42>>& dipoles) {
    std::ostringstream s;
    s.precision(17);
    s << "3 " << dipoles.size() << "\n";
    for (const auto& d : dipoles) {
        for (int k = 0; k < 42; ++k) s << d[std::size_t(k)] << (k == 2 || k == 5 || (k >= 6 && (k - 6) % 6 == 5) ? "\n" : " ");
    }
    return s.str();
}

/// A dipole at p with vector area w, position variance v, normal covariance N (xx, yy, zz) diagonal.
std::array<double, 42> dipole(Vec3d p, Vec3d w, double v, Vec3d N) {
    std::array<double, 42> d{};
    for (int k = 0; k < 3; ++k) d[std::size_t(k)] = p[k], d[std::size_t(3 + k)] = w[k];
    auto C = [&](int r, int c) -> double& { return d[std::size_t(6 + 6 * r + c)]; };
    for (int k = 0; k < 3; ++k) C(k, k) = v, C(3 + k, 3 + k) = N[k];
    return d;
}

std::string errorOf(const std::string& text) {
    const std::string path = temp("bad.gdp");
    std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
    try {
        readInput(path);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("gdp: written samples read back as the same samples (a soup at scales 1e-6, 1 and 1e6, and a cloud)", "[gdp]") {
    std::vector<InputData> inputs;
    for (const double scale : {1e-6, 1.0, 1e6}) {
        InputData mesh;
        mesh.soup = icosphere(2);
        for (Vec3d& v : mesh.soup->vertices) v *= scale;
        mesh.path = "icosphere";
        inputs.push_back(mesh);
    }
    inputs.push_back(readInput(gpisvdb::test::dataPath("kitten.xyz")));
    for (const InputData& input : inputs) {
        INFO(input.path);
        const InputSamples original = makeSamples(input, {0.5});
        const std::string path = temp("roundtrip.gdp");
        writeGdp(original.samples, path);
        const InputData read = readInput(path);
        REQUIRE(read.cloud);
        const InputSamples again = makeSamples(read, {0.5});
        REQUIRE(again.samples.size() == original.samples.size());
        CHECK(again.absoluteNoise);
        CHECK(again.lengthScaleGiven);
        const Samples &a = original.samples, &b = again.samples;
        // Every number printed in the shortest form that reads back as the same double
        CHECK(b.position == a.position);
        CHECK(b.normal == a.normal);
        CHECK(b.positionVariance == a.positionVariance);
        bool same = true;
        for (std::size_t i = 0; i < a.size(); ++i) same = same && b.normalCovariance[i].matrix() == a.normalCovariance[i].matrix();
        CHECK(same);
        CHECK(b.lengthScale == a.lengthScale);
        // Written again from what was read: the same file, byte for byte
        const std::string second = temp("roundtrip2.gdp");
        writeGdp(b, second);
        CHECK(fileText(second) == fileText(path));
    }
}

TEST_CASE("gdp: a soup written as .gdp and read back gives the same default band to the bit", "[gdp]") {
    // σ_rel 0.5: the soup's position std σ/√3 keeps the cloud's noise smoothing (1.2 σ_i) below 0.4 ℓ, so both
    // take s = 0.4 ℓ (docs/guide.md#gdp)
    InputData mesh;
    mesh.soup = icosphere(2);
    mesh.path = "icosphere";
    const LoadedModel fromSoup = loadModel(mesh);
    writeGdp(fromSoup.input.samples, temp("band.gdp"));
    const LoadedModel fromGdp = loadModel(readInput(temp("band.gdp")));
    REQUIRE(fromGdp.smoothing == fromSoup.smoothing);
    const Band a = buildDefaultBand(*fromSoup.model, fromSoup.input.samples).result.band;
    const Band b = buildDefaultBand(*fromGdp.model, fromGdp.input.samples).result.band;
    REQUIRE(a.size() > 1000);
    CHECK(b.voxelSize == a.voxelSize);
    CHECK(b.coord == a.coord);
    CHECK(b.mu == a.mu);
    CHECK(b.T == a.T);
    CHECK(b.mean == a.mean);
    CHECK(b.stddev == a.stddev);
}

TEST_CASE("gdp: the model's noise is read (position variance, area, normal covariance), and rounding-level cross terms pass", "[gdp]") {
    auto d0 = dipole({0.25, 0.125, 0.0625}, {0.001, 0.0011, 0.0004}, 3e-4, {1.8e-6, 1.9e-6, 1.3e-6});
    d0[6 + 6 * 0 + 4] = 9e-22, d0[6 + 6 * 4 + 0] = 9e-22;  // a writer's rounding in the cross block, and off-diagonal
    d0[6 + 6 * 3 + 4] = 6e-7, d0[6 + 6 * 4 + 3] = 6e-7;
    const auto d1 = dipole({1, 0, 0}, {0.002, 0, 0}, 2e-4, {0, 1e-6, 1e-6});
    const InputData data = readInput(temp("read.gdp", gdpText({d0, d1})));
    REQUIRE(data.cloud);
    const PointCloud& c = *data.cloud;
    REQUIRE(c.positions.size() == 2);
    REQUIRE(c.positionVariances.size() == 2);
    REQUIRE(c.normalCovariances.size() == 2);
    CHECK(c.sigmas.empty());
    CHECK(c.vectorAreas);
    CHECK(c.positionVariances[0] == 3e-4);
    CHECK(c.areas[1] == Approx(0.002));
    CHECK(c.normalCovariances[0].xy == Approx(6e-7));
    const InputSamples s = makeSamples(data, {0.5});
    CHECK(s.samples.normal[1].x() == Approx(0.002));
    CHECK(s.samples.positionVariance[0] == Approx(3e-4));
    CHECK(s.samples.normalCovariance[1].yy == Approx(1e-6));
    CHECK(s.samples.normalCovariance[1].xx == 0.0);
    // ℓ of a cloud: √(mean area), the areas |w| as given
    CHECK(s.samples.lengthScale == Approx(std::sqrt(0.5 * (Vec3d(0.001, 0.0011, 0.0004).norm() + 0.002))));
}

TEST_CASE("gdp: covariances the model does not carry are refused, naming what", "[gdp]") {
    const auto good = dipole({0, 0, 0}, {0, 0, 1}, 1e-4, {1e-6, 1e-6, 0});
    CHECK(errorOf(gdpText({good})).empty());
    auto anisotropic = good;
    anisotropic[6 + 6 * 1 + 1] = 2e-4;
    CHECK_THAT(errorOf(gdpText({good, anisotropic})), Catch::Contains("dipole 2: its position covariance is not isotropic"));
    auto cross = good;
    cross[6 + 6 * 0 + 3] = cross[6 + 6 * 3 + 0] = 1e-7;
    CHECK_THAT(errorOf(gdpText({cross})), Catch::Contains("cross-covariance is not 0"));
    auto asymmetric = good;
    asymmetric[6 + 6 * 3 + 4] = 5e-7;
    CHECK_THAT(errorOf(gdpText({asymmetric})), Catch::Contains("not symmetric (row 4, column 5"));
    auto indefinite = good;
    indefinite[6 + 6 * 3 + 4] = indefinite[6 + 6 * 4 + 3] = 5e-6;
    CHECK_THAT(errorOf(gdpText({indefinite})), Catch::Contains("not positive semi-definite"));
    auto noPosition = dipole({0, 0, 0}, {0, 0, 1}, 0, {1e-6, 1e-6, 0});
    CHECK_THAT(errorOf(gdpText({noPosition})), Catch::Contains("position variance"));
    auto zeroArea = dipole({0, 0, 0}, {0, 0, 0}, 1e-4, {1e-6, 1e-6, 0});
    CHECK_THAT(errorOf(gdpText({zeroArea})), Catch::Contains("vector area (the area-weighted normal) is 0"));
}

TEST_CASE("gdp: malformed files get one clear line: header, count, numbers, binary", "[gdp]") {
    const std::string one = gdpText({dipole({0, 0, 0}, {0, 0, 1}, 1e-4, {1e-6, 1e-6, 0})});
    const std::string body = one.substr(one.find('\n') + 1);
    CHECK_THAT(errorOf("2 1\n" + body), Catch::Contains("expected the dimension 3"));
    CHECK_THAT(errorOf("3 0\n"), Catch::Contains("a whole number >= 1"));
    CHECK_THAT(errorOf("3 1.5\n" + body), Catch::Contains("a whole number >= 1"));
    CHECK_THAT(errorOf("3 2\n" + body), Catch::Contains("ends early: it declares 2 dipoles"));
    CHECK_THAT(errorOf("3 1\n" + body + "7\n"), Catch::Contains("more numbers than the 1 dipoles"));
    CHECK_THAT(errorOf("3\n"), Catch::Contains("ends early: the header"));
    CHECK_THAT(errorOf("3 1\n0 0 nan\n"), Catch::Contains("non-finite a position"));
    CHECK_THAT(errorOf("3 1\n0 0 1e999\n"), Catch::Contains("non-finite"));
    CHECK_THAT(errorOf("3 1\n0 0 x\n"), Catch::Contains("expected a number for a position, got 'x'"));
    CHECK_THAT(errorOf("3 1\n0 0 0\n0 0 1\n1e-4 0 0 0 0 0\n0 1e-4 0 0 0 0\n"), Catch::Contains(":5: the file ends early"));
    CHECK_THAT(errorOf(std::string("3 1\n\0\x01", 7)), Catch::Contains("binary content"));
    CHECK_THAT(errorOf("3 1e30\n"), Catch::Contains("more than the"));
    CHECK_THAT(errorOf(""), Catch::Contains("empty"));
    // After the dipoles: comments only; "# length_scale L" gives ℓ
    CHECK_THAT(errorOf(one + "# length_scale -1\n"), Catch::Contains("must be a number > 0"));
    CHECK_THAT(errorOf(one + "# length_scale\n2\n"), Catch::Contains("on its comment's line"));
    CHECK(errorOf(one + "#\n# made by hand\n#length_scale 0.5\n").empty());
    InputData given = readInput(temp("bad.gdp"));
    CHECK(given.cloud->lengthScale == 0.5);
    // A leading '+' and any white space are numbers' business only
    CHECK(errorOf("3 +1 0 0 0\t0 0 1  1e-4 0 0 0 0 0 0 1e-4 0 0 0 0 0 0 1e-4 0 0 0 0 0 0 1e-6 0 0 0 0 0 0 1e-6 0 0 0 0 0 0 0").empty());
}

TEST_CASE("gdp: cloud sampling checks the normal covariances' count", "[gdp]") {
    PointCloud c;
    c.positions = {Vec3d(0, 0, 0), Vec3d(1, 0, 0)};
    c.normals = {Vec3d(0, 0, 1), Vec3d(0, 0, 1)};
    c.normalCovariances = {Sym3{}};
    CHECK_THROWS_AS(cloudSamples(c), InputError);
}

TEST_CASE("gdp: gpisvdb convert writes a .gdp that every command reads, and refuses other outputs", "[gdp][cli]") {
    const std::string gdp = temp("bunny.gdp");
    std::filesystem::remove(gdp);
    const Run r = run("convert " + gpisvdb::test::dataPath("bunny.obj") + " --sigma 0.25 -o " + gdp);
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK_THAT(r.err, Catch::Contains("dipoles from the triangle soup, sigma"));
    const InputData read = readInput(gdp);
    REQUIRE(read.cloud);
    CHECK(read.cloud->positions.size() == readInput(gpisvdb::test::dataPath("bunny.obj")).soup->triangles.size());
    const Run info = run("info " + gdp + " --no-forecast");
    CHECK(info.code == 0);
    CHECK_THAT(info.out, Catch::Contains("oriented point cloud"));
    const Run wrong = run("convert " + gpisvdb::test::dataPath("bunny.obj") + " -o " + temp("bunny.xyz"));
    CHECK(wrong.code == 1);
    CHECK_THAT(wrong.err, Catch::Contains("-o must name a .gdp file"));
    const Run badSigma = run("convert " + gpisvdb::test::dataPath("bunny.obj") + " --sigma 0 -o " + temp("zero.gdp"));
    CHECK(badSigma.code != 0);
    CHECK_THAT(badSigma.err, Catch::Contains("--sigma"));
    CHECK_FALSE(std::filesystem::exists(temp("zero.gdp")));
}
