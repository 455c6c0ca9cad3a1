// End-to-end tests of the gpisvdb program: exit codes, one-line errors, no partial outputs.
#include <sys/wait.h>

#include <array>
#include <catch2/catch.hpp>
#include <Eigen/Eigenvalues>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <random>
#include <sstream>

#include <nanovdb/util/IO.h>
#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>
#include <vtkDataArray.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include "cli_run.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/kacrice/kac_rice.h"
#include "gpisvdb/model/direct_gpis.h"
#include "gpisvdb/output/mean_surface.h"
#include "helpers.h"
#include "png_stats.h"

namespace fs = std::filesystem;

using namespace gpisvdb::test::cli;
using gpisvdb::Mat3d;
using gpisvdb::Mat4d;
using gpisvdb::Vec3d;

TEST_CASE("cli: info describes the bunny", "[cli]") {
    const Run r = run("info " + gpisvdb::test::dataPath("bunny.obj") + " --no-forecast");  // (the forecast: below)
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("samples:      3674"));
    CHECK_THAT(r.out, Catch::Contains("length scale"));
    CHECK_THAT(r.out, Catch::Contains("sigma:        0.5 x l = "));
    CHECK_THAT(r.out, Catch::Contains("smoothing:    0.4 x l = "));
}

TEST_CASE("cli: info says a scan's own sigma and the smoothing it sets, as the model takes them", "[cli]") {
    // 1 000 unit-sphere points with σ = 0.05 each: ℓ ≈ 0.11, so s = 1.2 σ = 0.06 is above 0.4 ℓ (docs/math.md#smoothing)
    std::mt19937 rng(3);
    std::normal_distribution<double> g;
    std::ostringstream cloud;
    for (int i = 0; i < 1000; ++i) {
        const Eigen::Vector3d p = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
        cloud << p.x() << " " << p.y() << " " << p.z() << " " << p.x() << " " << p.y() << " " << p.z() << " 0.05\n";
    }
    const std::string path = temp("own_sigma.xyz", cloud.str());
    const Run r = run("info " + path + " --no-forecast");
    REQUIRE(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("sigma:        each point's own (the file's), median 0.05 (world units)"));
    CHECK_THAT(r.out, Catch::Contains("smoothing:    1.2 x median sigma = 0.06 (set by the noise, above 0.4 x l = "));
    // --noise-smoothing 0 leaves s = 0.4 ℓ, as the model would
    const Run off = run("info " + path + " --no-forecast --noise-smoothing 0");
    REQUIRE(off.code == 0);
    CHECK_THAT(off.out, Catch::Contains("smoothing:    0.4 x l = "));
}

TEST_CASE("cli: evaluate writes one row per query point with the documented header", "[cli]") {
    const std::string pts = temp("pts.xyz", "0 0 0\n0.5,0.5,0.5\n# comment\n30 30 30\n");
    const std::string out = temp("values.csv");
    fs::remove(out);
    const Run r = run("evaluate " + gpisvdb::test::dataPath("bunny.obj") + " --at " + pts + " -o " + out + " --quiet");
    REQUIRE(r.code == 0);
    std::ifstream in(out);
    std::string header;
    std::getline(in, header);
    CHECK(header == "x,y,z,gamma,gx,gy,gz,c00,c01,c02,c03,c11,c12,c13,c22,c23,c33,mu,Txx,Txy,Txz,Tyy,Tyz,Tzz,p_inside");
    std::vector<std::vector<double>> rows;
    for (std::string row; std::getline(in, row);) {
        CHECK(std::count(row.begin(), row.end(), ',') == 24);
        std::vector<double> values;
        std::stringstream s(row);
        for (std::string cell; std::getline(s, cell, ',');) values.push_back(std::strtod(cell.c_str(), nullptr));
        rows.push_back(values);
    }
    REQUIRE(rows.size() == 3);
    for (const auto& v : rows) {  // p_inside = P(φ > 1/2) for φ ~ N(gamma, c00)
        INFO("gamma " << v[3] << " c00 " << v[7] << " p_inside " << v[24]);
        CHECK(v[24] == Approx(0.5 * std::erfc(-(v[3] - 0.5) / std::sqrt(2 * v[7]))).margin(1e-15));
        CHECK(v[24] >= 0.0);
        CHECK(v[24] <= 1.0);
    }
    CHECK(rows[2][24] < 1e-6);  // (30, 30, 30): three bunny sizes away
}

namespace {
/// The numeric rows of a CSV file (header skipped).
std::vector<std::vector<double>> readCsvRows(const std::string& path) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    std::vector<std::vector<double>> rows;
    while (std::getline(in, line)) {
        std::stringstream s(line);
        std::vector<double> row;
        for (std::string cell; std::getline(s, cell, ',');) row.push_back(std::strtod(cell.c_str(), nullptr));  // stod throws on subnormals
        rows.push_back(row);
    }
    return rows;
}

/// μ and T at u by plain Monte Carlo from the Gaussian (φ, ∇φ) of one CSV row (columns 3..16), following the
/// Kac–Rice formulas of docs/model.md / kac_rice.h but with pseudo-random draws instead of the library's QMC rule.
std::pair<double, Mat3d> monteCarloKacRice(const std::vector<double>& row, double u, std::mt19937_64& rng, int draws) {
    const double gamma = row[3];
    const Vec3d grad(row[4], row[5], row[6]);
    Mat4d C;
    for (int r = 0, k = 7; r < 4; ++r)
        for (int c = r; c < 4; ++c, ++k) C(r, c) = C(c, r) = row[k];
    const double c00 = C(0, 0);
    const Vec3d cg0 = C.block<3, 1>(1, 0);
    const Vec3d m = grad + cg0 * (u - gamma) / c00;
    const Mat3d S = C.block<3, 3>(1, 1) - cg0 * cg0.transpose() / c00;
    Eigen::SelfAdjointEigenSolver<Mat3d> eig(S);
    const Mat3d L = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
    const double p = std::exp(-0.5 * (u - gamma) * (u - gamma) / c00) / std::sqrt(2 * M_PI * c00);
    std::normal_distribution<double> n;
    double norm = 0;
    Mat3d T = Mat3d::Zero();
    for (int k = 0; k < draws; ++k) {
        const Vec3d x = m + L * Vec3d(n(rng), n(rng), n(rng));
        const double len = x.norm();
        norm += len;
        T += len * Mat3d::Identity() - x * x.transpose() / len;
    }
    return {p * norm / draws, p * T / draws};
}
}  // namespace

TEST_CASE("cli: exact and Barnes-Hut evaluate agree with the direct sum to the stated accuracy in every column", "[cli]") {
    // The model the CLI builds from these flags, built here by the library's reference direct sum.
    const std::string in = gpisvdb::test::dataPath("bunny.obj");
    const double sigmaRel = 0.5, smoothingRel = 0.4, iso = 0.5;  // iso: the winding model's level (evaluate --help)
    const gpisvdb::Samples s = gpisvdb::makeSamples(gpisvdb::readInput(in), {sigmaRel}).samples;
    const gpisvdb::DirectGpis direct(s, smoothingRel * s.lengthScale);

    // 128 query points: 80 samples moved off the surface by up to 1.5 σ (where μ is large), 48 anywhere in the box.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> unit(0, 1);
    std::vector<Vec3d> xs;
    Vec3d lo = s.position[0], hi = s.position[0];
    for (const Vec3d& p : s.position) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    for (std::size_t i = 0; xs.size() < 80; i += s.size() / 80)
        xs.push_back(s.position[i] + 1.5 * sigmaRel * s.lengthScale * unit(rng) * gpisvdb::test::randomUnit(rng));
    while (xs.size() < 128) {
        const Vec3d t(unit(rng), unit(rng), unit(rng));
        xs.push_back(lo - 0.1 * (hi - lo) + 1.2 * (hi - lo).cwiseProduct(t));
    }
    std::ostringstream text;
    text << std::setprecision(17);
    for (const Vec3d& x : xs) text << x.x() << ' ' << x.y() << ' ' << x.z() << '\n';
    const std::string pts = temp("pts2.xyz", text.str());
    const std::string a = temp("bh.csv"), b = temp("exact.csv");
    const std::string flags = " --sigma 0.5 --smoothing 0.4 --quiet";
    REQUIRE(run("evaluate " + in + " --at " + pts + " -o " + a + flags).code == 0);
    REQUIRE(run("evaluate " + in + " --at " + pts + " -o " + b + flags + " --exact --threads 1").code == 0);
    const auto bh = readCsvRows(a), exact = readCsvRows(b);
    REQUIRE(bh.size() == xs.size());
    REQUIRE(exact.size() == xs.size());
    const std::vector<gpisvdb::ValueGradient> ref = direct.evaluate(xs);

    // Scales of docs/model.md ("Error norm"), from the direct sum over these points.
    double gradScale = 0;
    for (const auto& v : ref) gradScale = std::max(gradScale, v.mean.tail<3>().norm());
    Mat4d covScale = Mat4d::Zero();
    for (const auto& v : ref)
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) covScale(r, c) = std::max(covScale(r, c), std::sqrt(v.cov(r, r) * v.cov(c, c)));
    REQUIRE(gradScale > 0);
    // Column k (3..16) of a row against the reference: |got − ref| / scale.
    auto relError = [&](const std::vector<double>& row, const gpisvdb::ValueGradient& v, int k) {
        if (k == 3) return std::abs(row[3] - v.mean[0]);
        if (k < 7) return std::abs(row[k] - v.mean[k - 3]) / gradScale;
        for (int r = 0, j = 7; r < 4; ++r)
            for (int c = r; c < 4; ++c, ++j)
                if (j == k) return std::abs(row[k] - v.cov(r, c)) / covScale(r, c);
        return 1e300;
    };
    std::array<double, 17> worstBh{}, worstExact{};
    double muMax = 0;
    for (std::size_t i = 0; i < xs.size(); ++i) {
        for (int d = 0; d < 3; ++d) {
            CHECK(bh[i][d] == Approx(xs[i][d]).margin(1e-12));
            CHECK(exact[i][d] == Approx(xs[i][d]).margin(1e-12));
        }
        for (int k = 3; k < 17; ++k) {
            worstBh[k] = std::max(worstBh[k], relError(bh[i], ref[i], k));
            worstExact[k] = std::max(worstExact[k], relError(exact[i], ref[i], k));
        }
        muMax = std::max(muMax, exact[i][17]);
    }
    for (int k = 3; k < 17; ++k) {
        INFO("column " << k << ": Barnes-Hut " << worstBh[k] << ", --exact " << worstExact[k]);
        CHECK(worstBh[k] <= 1e-3);      // the documented accuracy of the default beta
        CHECK(worstExact[k] <= 1e-12);  // --exact is the direct sum, printed to 17 digits
    }

    // μ and T (columns 17..23) of each file against an independent Monte Carlo estimate from that row's own
    // Gaussian, and --exact's against the direct sum's; tr T = 2μ and T ⪰ 0 (kac_rice.h).
    REQUIRE(muMax > 1);  // points near the surface: μ of order 1/σ
    std::mt19937_64 mc(11);
    const gpisvdb::QmcRule rule(512);
    int nonzero = 0;
    for (std::size_t i = 0; i < xs.size(); ++i) {
        const gpisvdb::SurfaceDensity d = gpisvdb::kacRice(ref[i], iso, rule);
        CHECK(exact[i][17] == Approx(d.mu).epsilon(1e-9).margin(1e-12 * muMax));
        for (const auto* row : {&bh[i], &exact[i]}) {
            const auto& r = *row;
            Mat3d T;
            for (int p = 0, k = 18; p < 3; ++p)
                for (int q = p; q < 3; ++q, ++k) T(p, q) = T(q, p) = r[k];
            INFO("point " << i << " mu " << r[17]);
            CHECK(T.trace() == Approx(2 * r[17]).epsilon(1e-9).margin(1e-12 * muMax));
            CHECK(Eigen::SelfAdjointEigenSolver<Mat3d>(T).eigenvalues().minCoeff() >= -1e-9 * muMax);
            if (r[17] < 1e-3 * muMax) continue;
            ++nonzero;
            const auto [mu, Tmc] = monteCarloKacRice(r, iso, mc, 20000);
            CHECK(r[17] == Approx(mu).epsilon(0.02));
            CHECK((T - Tmc).cwiseAbs().maxCoeff() <= 0.02 * r[17]);
        }
        if (exact[i][17] >= 1e-3 * muMax) {
            Mat3d T;
            for (int p = 0, k = 18; p < 3; ++p)
                for (int q = p; q < 3; ++q, ++k) T(p, q) = T(q, p) = exact[i][k];
            CHECK((T - d.T).cwiseAbs().maxCoeff() <= 1e-9 * muMax);
        }
    }
    CHECK(nonzero >= 100);  // both files, so at least 50 points with a sizeable μ
}

TEST_CASE("cli: bad input and parameters give one line on stderr naming the flag, a non-zero exit and no output", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string pts = temp("pts3.xyz", "0 0 0\n");
    const std::string out = temp("bad.csv");
    const std::string vdb = temp("bad.vdb");
    struct Case {
        std::string args, expect;
    };
    const std::vector<Case> cases = {
        {"evaluate /nonexistent.obj --at " + pts + " -o " + out, "no such file"},
        {"evaluate " + temp("m.xyzw", "1") + " --at " + pts + " -o " + out, "unknown extension"},
        {"evaluate " + temp("e.obj", " ") + " --at " + pts + " -o " + out, "empty"},
        {"evaluate " + temp("c.off", "0 0 0 0 0 1\n") + " --at " + pts + " -o " + out, "not an OFF"},
        {"evaluate " + temp("n.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n") + " --at " + pts + " -o " + out, "non-finite"},
        {"evaluate " + temp("r.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n") + " --at " + pts + " -o " + out, "out of range"},
        {"evaluate " + temp("z.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n") + " --at " + pts + " -o " + out, "non-zero area"},
        {"evaluate " + temp("nn.xyz", "0 0 0\n1 0 0\n") + " --at " + pts + " -o " + out, "no normals"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --sigma 0", "relative noise σ (--sigma) must be finite and > 0"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --sigma -1", "--sigma"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --smoothing 0", "--smoothing"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --beta 0.5", "criterion β (--beta) must be finite and > 1"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --threads -2", "--threads"},
        {"evaluate " + bunny + " --at " + temp("q.xyz", "0 0 x\n") + " -o " + out, "not a finite number"},
        {"evaluate " + bunny + " --at " + pts + " -o /nonexistent-dir/out.csv", "does not exist"},
        {"info " + temp("nan.xyz", "0 0 0 0 0 1\n1 nan 0 0 0 1\n"), "non-finite"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --qmc 0", "QMC point count S (--qmc) must be in [1, 16777216]"},
        {"band " + bunny + " -o " + vdb + " --eta 0", "--eta"},
        {"band " + bunny + " -o " + vdb + " --eta -1", "--eta"},
        {"band " + bunny + " -o " + vdb + " --qmc 0", "--qmc"},
        {"band " + bunny + " -o " + vdb + " --voxel-size 1e-5", "--voxel-size"},
        {"band " + bunny + " -o " + vdb + " --voxel-size 0.3 --max-memory 1M", "--voxel-size"},
        {"band " + bunny + " -o " + vdb + " --max-memory lots", "--max-memory"},
        {"band " + bunny + " -o " + vdb + " --sigma 0", "--sigma"},
        {"green " + bunny + " --source 0,nan,0 -o " + vdb + " --voxel-size 0.4 --sigma 2", "--source"},
        {"green " + bunny + " --source 0,6,0 -o " + vdb + " --tolerance 0", "--tolerance"},
        {"geodesic " + bunny + " --source 0,nan,0 -o " + vdb + " --voxel-size 0.4 --sigma 2", "--source"},
        {"geodesic " + bunny + " --source 0,6,0 --target 1,inf,0 -o " + vdb + " --voxel-size 0.4 --sigma 2", "--target"},
        {"geodesic " + bunny + " --source 0,6,0 -o " + vdb + " --paths " + temp("p.json"), "--paths needs"},
        {"geodesic " + bunny + " --source 0,6,0 -o " + vdb + " --stop-at-targets", "--stop-at-targets"},
        {"geodesic " + bunny + " --source 0,6,0 --target 1,6,0 -o " + vdb + " --paths " + temp("p.stl"), "path extension"},
        {"geodesic " + bunny + " --source 0,6,0,1 -o " + vdb, "X,Y,Z"},
        {"geodesic " + bunny + " --source 0,6,0 -o " + vdb + " --voxel-size 0.4 --sigma 2 --max-memory 20M",
         "the memory limit (--max-memory) allows: raise it"},
        {"green " + bunny + " --source 0,6,0 -o " + vdb + " --voxel-size 0.4 --sigma 2 --max-memory 20M",
         "the Green's function solve needs about"},
        {"hodge " + bunny + " --preset mixed -o " + vdb + " --voxel-size 0.4 --sigma 2 --max-memory 20M",
         "the Hodge decomposition needs about"},
        {"spectrum " + bunny + " -k 0 -o " + vdb, "-k"},
        {"spectrum " + bunny + " -k 100000 -o " + vdb + " --voxel-size 0.4 --sigma 2", "between 1 and"},
        // The assembled L is refused first (the eigen solver's own refusal: test_memory_stages.cpp)
        {"spectrum " + bunny + " -k 200 -o " + vdb + " --voxel-size 0.4 --sigma 2 --max-memory 20M",
         "the assembled Laplacian of the eigen solver needs about"},
        {"spectrum " + bunny + " -k 4 --eigen-tolerance 0 -o " + vdb + " --voxel-size 0.4 --sigma 2", "tolerance"},
        {"regress " + bunny + " --data /nonexistent.csv -o " + vdb, "no such file"},
        {"regress " + bunny + " --data " + temp("cols.csv", "x,y,z,v\n1,2,3\n") + " -o " + vdb, "4 or 5 columns"},
        {"regress " + bunny + " --data " + temp("nanv.csv", "1,2,3,nan\n") + " -o " + vdb, "non-finite"},
        {"regress " + bunny + " --data " + temp("negn.csv", "1,2,3,4,-1\n") + " -o " + vdb, "noise"},
        {"regress " + bunny + " --data " + temp("hdr.csv", "x,y,z,value\n") + " -o " + vdb, "no data rows"},
        {"regress " + bunny + " --data " + temp("ok.csv", "0,0,0,1\n") + " --nu abc -o " + vdb, "--nu"},
        {"regress " + bunny + " --data " + temp("ok.csv") + " --nu 0 -o " + vdb, "--nu"},
        {"regress " + bunny + " --data " + temp("ok.csv") + " --kappa -1 -o " + vdb, "--kappa"},
        {"regress " + bunny + " --data " + temp("far.csv", "100,0,0,1\n") + " -k 4 -o " + vdb + " --voxel-size 0.4 --sigma 2",
         "outside the band"},
        {"hodge " + bunny + " -o " + vdb, "exactly one of --field"},
        {"band " + bunny + " --model regression --label-noise -1 -o " + vdb, "--label-noise"},
        {"band " + bunny + " --model regression --training-points 0 -o " + vdb, "--training-points"},
        {"band " + bunny + " --model regression --labels /nonexistent.csv -o " + vdb, "no such file"},
        {"distance " + bunny + " --alpha 0 -o " + vdb, "--alpha"},
        {"distance " + bunny + " --alpha 1 --grid-voxel-size 1e-7 -o " + vdb + " --voxel-size 0.4 --sigma 2", "--grid-voxel-size"},
        {"distance " + bunny + " --alpha 1 --level 0.1 --mesh " + temp("m.stl") + " -o " + vdb, "extension"},
        {"hodge " + bunny + " --field /nonexistent.vdb -o " + vdb + " --voxel-size 0.4 --sigma 2", "no such file"},
        {"hodge " + bunny + " --field " + temp("notvdb.vdb", "hello") + " -o " + vdb + " --voxel-size 0.4 --sigma 2",
         "cannot be read as an OpenVDB file"},
        {"hodge " + bunny + " --preset mixed --tolerance -1 -o " + vdb, "the PCG tolerance (--tolerance) must be finite and > 0"},
        {"green " + bunny + " --source 0,6,0 --tolerance 0 -o " + vdb, "the PCG tolerance (--tolerance) must be finite and > 0"},
        {"green " + bunny + " --source 0,6,0 --tolerance 1e-13 -o " + vdb, "the PCG tolerance (--tolerance) must be >= 1e-12"},
        {"render " + vdb + " --grid mu -o " + temp("flag.png") + " --slice w=1", "slice plane (--slice): expected axis=value"},
        // Absurd requests, refused before any attempt (docs/guide.md#limits)
        {"evaluate " + temp("huge.off", "OFF\n1000000000 1 0\n0 0 0\n") + " --at " + pts + " -o " + out,
         "1000000000 vertices declared, more than the 1e+08 samples an input may hold"},
        {"band " +
             temp("huge.ply",
                  "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                  "element face 200000000\nproperty list uchar int vertex_indices\nend_header\n") +
             " -o " + vdb,
         "200000000 face elements declared, more than the 1e+08 samples"},
        {"band " + bunny + " -o " + vdb + " --voxel-size 0.006 --sigma 2 --max-memory 1000000G",
         "a band can hold: use a voxel size (--voxel-size) of"},
    };
    for (const Case& c : cases) {
        fs::remove(out);
        const Run r = run(c.args);
        INFO(c.args << "\nstderr: " << r.err);
        CHECK(r.code == 1);
        CHECK(lines(r.err) == 1);
        CHECK_THAT(r.err, Catch::Contains(c.expect));
        // The engine names its Options fields; the command line shows the flags in their place.
        CHECK_THAT(r.err, !Catch::Contains("Options::") && !Catch::Contains("RenderPanel::"));
        CHECK_FALSE(leftovers(out));
        CHECK_FALSE(leftovers(vdb));
    }
}

TEST_CASE("cli: GPISVDB_PROGRESS=lines gives one line per whole percent of each stage on a piped stderr", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj"), vdb = temp("progress.vdb");
    const std::string args = " green " + bunny + " --source 0.5,6,1 --voxel-size 0.3 -o " + vdb;
    const Run plain = runShell(std::string(GPISVDB_EXE) + args);
    REQUIRE(plain.code == 0);
    CHECK(plain.err.find("gpisvdb-progress") == std::string::npos);  // piped stderr: no bar, no lines
    const Run quiet = runShell("GPISVDB_PROGRESS=lines " + std::string(GPISVDB_EXE) + args + " --quiet");
    REQUIRE(quiet.code == 0);
    CHECK(quiet.err.find("gpisvdb-progress") == std::string::npos);  // --quiet wins
    const Run r = runShell("GPISVDB_PROGRESS=lines " + std::string(GPISVDB_EXE) + args);
    INFO(r.err);
    REQUIRE(r.code == 0);
    std::map<std::string, std::vector<int>> percents;  // per stage, in order
    std::istringstream in(r.err);
    for (std::string line; std::getline(in, line);) {
        std::istringstream words(line);
        std::string tag, stage;
        int percent = -1;
        if (!(words >> tag >> stage >> percent) || tag != "gpisvdb-progress") continue;
        std::string rest;
        CHECK_FALSE(words >> rest);  // exactly three words
        CHECK((percent >= 0 && percent <= 100));
        auto& seen = percents[stage];
        CHECK((seen.empty() || seen.back() != percent));  // one line per change, not per report
        seen.push_back(percent);
    }
    CHECK(percents.count("band") == 1);
    CHECK(percents.count("solve") == 1);  // the Green's function's PCG
    for (const auto& [stage, seen] : percents) {
        INFO(stage);
        CHECK(seen.back() == 100);
    }
}

TEST_CASE("cli: usage errors exit 2, --help and --version exit 0", "[cli]") {
    CHECK(run("").code == 2);
    CHECK(run("evaluate").code == 2);
    CHECK(run("evaluate x.obj --at p.xyz -o o.csv --no-such-flag").code == 2);
    CHECK(run("--help").code == 0);
    CHECK(run("evaluate --help").code == 0);
    CHECK(run("geodesic --help").code == 0);
    CHECK(run("geodesic x.obj -o o.vdb").code == 2);  // --source is required
    CHECK(run("band x.obj -o o.vdb --model nosuch").code == 2);
    CHECK(run("distance x.obj -o o.vdb --mesh m.ply --alpha 1").code == 2);  // --mesh needs --level
    for (const char* cmd : {"hodge", "distance"}) CHECK(run(std::string(cmd) + " --help").code == 0);
    CHECK(run("--version").out.find("gpisvdb") != std::string::npos);
}

namespace {
openvdb::FloatGrid::Ptr readFloatGrid(const std::string& vdb, const std::string& name) {
    openvdb::initialize();
    openvdb::io::File file(vdb);
    file.open();
    const auto grid = file.hasGrid(name) ? openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid(name)) : nullptr;
    file.close();
    return grid;
}

/// Linear index (OpenVDB leaf order, docs/band.md) and coordinate of the active voxel of `mu` nearest a world point.
std::pair<std::size_t, openvdb::Coord> nearestActiveVoxel(const openvdb::FloatGrid& mu, const openvdb::Vec3d& world) {
    std::size_t index = 0, bestIndex = 0;
    openvdb::Coord best;
    double bestDist = 1e300;
    for (auto it = mu.cbeginValueOn(); it; ++it, ++index) {
        const double d = (mu.indexToWorld(it.getCoord()) - world).lengthSqr();
        if (d < bestDist) bestDist = d, best = it.getCoord(), bestIndex = index;
    }
    return {bestIndex, best};
}

/// The `band` and `parameters` parts of a report (docs/band.md) against the file's own "mu" grid (count, voxel
/// size from its transform, mass h³ Σ μ, bounding box, μ > η everywhere) and against the input read here (ℓ, σ).
void checkBandReport(const nlohmann::json& report, const std::string& vdb, const std::string& input, double sigmaRel, double voxelSize) {
    const auto mu = readFloatGrid(vdb, "mu");
    REQUIRE(mu);
    const auto& band = report["band"];
    const auto& par = report["parameters"];
    const double h = mu->voxelSize()[0];
    CHECK(h == Approx(voxelSize).epsilon(1e-12));
    CHECK(band["voxel_size"].get<double>() == Approx(h).epsilon(1e-12));
    CHECK(band["voxels"].get<openvdb::Index64>() == mu->activeVoxelCount());
    double sum = 0, lowest = 1e300;
    for (auto it = mu->cbeginValueOn(); it; ++it) sum += *it, lowest = std::min(lowest, double(*it));
    CHECK(band["mass"].get<double>() == Approx(h * h * h * sum).epsilon(1e-9));
    const openvdb::CoordBBox box = mu->evalActiveVoxelBoundingBox();
    for (int d = 0; d < 3; ++d) {
        CHECK(band["bbox_voxels"][d].get<int>() == box.dim()[d]);
        CHECK(band["bbox_min"][d].get<int>() == box.min()[d]);
    }
    const double eta = par["eta"].get<double>();
    CHECK(eta == Approx(par["eta_rel"].get<double>() * band["median_mu_at_samples"].get<double>()).epsilon(1e-12));
    CHECK(lowest >= eta * (1 - 1e-6));  // Ω = {μ > η}
    CHECK(lowest < 4 * eta);            // ... and its edge reaches down to η (26-neighbour BFS, h ≲ the μ width)
    const gpisvdb::Samples s = gpisvdb::makeSamples(gpisvdb::readInput(input), {sigmaRel}).samples;
    CHECK(report["input"]["samples"].get<std::size_t>() == s.size());
    CHECK(report["input"]["length_scale"].get<double>() == Approx(s.lengthScale).epsilon(1e-12));
    CHECK(par["sigma_rel"].get<double>() == sigmaRel);
    CHECK(par["voxel_size"].get<double>() == Approx(h).epsilon(1e-12));
    CHECK(par["sigma"].get<double>() == Approx(sigmaRel * s.lengthScale).epsilon(1e-12));
    CHECK(par["smoothing"].get<double>() == Approx(par["smoothing_rel"].get<double>() * s.lengthScale).epsilon(1e-12));
}
}  // namespace

TEST_CASE("cli: band writes a readable .vdb and a JSON report whose values match the grids", "[cli]") {
    const std::string vdb = temp("bunny.vdb"), json = temp("bunny.json");
    const Run r = run("band " + gpisvdb::test::dataPath("bunny.obj") + " -o " + vdb + " --report " + json +
                      " --sigma 2 --voxel-size 0.4 --quiet --threads 2");
    INFO(r.err);
    REQUIRE(r.code == 0);
    std::ifstream in(json);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string report = ss.str();
    for (const char* key : {"\"voxels\"", "\"voxel_size\"", "\"bbox_voxels\"", "\"mass\"", "\"max_stencil_l1\"", "\"sigma_rel\"",
                            "\"sigma\"", "\"model\"", "\"band\"", "\"total\"", "\"peak_rss_bytes\"", "\"band_bytes_per_voxel\""})
        CHECK_THAT(report, Catch::Contains(key));
    checkBandReport(nlohmann::json::parse(report), vdb, gpisvdb::test::dataPath("bunny.obj"), 2, 0.4);
    const int status = std::system(("vdb_print " + vdb + " > /dev/null 2>&1").c_str());
    CHECK(WEXITSTATUS(status) == 0);
    CHECK_FALSE(readFloatGrid(vdb, "selling_weight_0"));  // only with --stencils
}

TEST_CASE("cli: band flips an inside-out mesh's normals, says so, and builds the outward mesh's band", "[cli]") {
    // The bunny with every face's winding reversed: its normals point inward, and without the flip the default
    // surface gamma = 1/2 would not exist (docs/math.md#orientation).
    const std::string insideOut = temp("bunny_inside_out.obj");
    {
        std::ifstream in(gpisvdb::test::dataPath("bunny.obj"));
        std::ofstream out(insideOut);
        for (std::string line; std::getline(in, line);) {
            std::istringstream words(line);
            std::string tag, a, b, c;
            words >> tag;
            if (tag == "f" && (words >> a >> b >> c)) out << "f " << a << " " << c << " " << b << "\n";
            else out << line << "\n";
        }
    }
    std::map<std::string, nlohmann::json> reports;
    std::map<std::string, std::string> errs;
    for (const std::string& input : {gpisvdb::test::dataPath("bunny.obj"), insideOut}) {
        const std::string vdb = temp("orientation.vdb"), json = temp("orientation.json");
        const Run r = run("band " + input + " -o " + vdb + " --report " + json + " --sigma 2 --voxel-size 0.4 --threads 2");
        INFO(r.err);
        REQUIRE(r.code == 0);
        std::ifstream in(json);
        reports[input] = nlohmann::json::parse(in);
        errs[input] = r.err;
        openvdb::initialize();
        openvdb::io::File file(vdb);
        file.open();
        CHECK(file.getMetadata()->metaValue<bool>("normals_flipped") == (input == insideOut));
    }
    const nlohmann::json& outward = reports[gpisvdb::test::dataPath("bunny.obj")];
    const nlohmann::json& flipped = reports[insideOut];
    CHECK_FALSE(outward["input"]["normals_flipped"].get<bool>());
    CHECK(flipped["input"]["normals_flipped"].get<bool>());
    CHECK_THAT(errs[insideOut], Catch::Contains("normals point inward"));
    CHECK_THAT(errs[gpisvdb::test::dataPath("bunny.obj")], !Catch::Contains("normals point inward"));
    CHECK(flipped["band"]["voxels"] == outward["band"]["voxels"]);
    CHECK(flipped["band"]["mass"].get<double>() == Approx(outward["band"]["mass"].get<double>()).epsilon(1e-6));
}

TEST_CASE("cli: band writes the occupancy as a fog grid named by --fog-name, and NanoVDB for an .nvdb output", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj"), flags = " --sigma 2 --voxel-size 0.4 --quiet";
    const std::string vdb = temp("fog.vdb"), nvdb = temp("fog.nvdb"), named = temp("fog_named.vdb");
    Run r = run("band " + bunny + " -o " + vdb + flags);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const auto density = readFloatGrid(vdb, "density"), mean = readFloatGrid(vdb, "mean");
    REQUIRE(density);
    REQUIRE(mean);
    CHECK(density->getGridClass() == openvdb::GRID_FOG_VOLUME);
    CHECK(density->activeVoxelCount() > mean->activeVoxelCount());  // the band and the enclosed region
    r = run("band " + bunny + " -o " + named + flags + " --fog-name occupancy");
    REQUIRE(r.code == 0);
    CHECK(readFloatGrid(named, "occupancy"));
    CHECK_FALSE(readFloatGrid(named, "density"));
    r = run("band " + bunny + " -o " + named + flags + " --fog-name mean");
    CHECK(r.code == 2);
    CHECK_THAT(r.err, Catch::Contains("--fog-name"));
    r = run("band " + bunny + " -o " + nvdb + flags);
    REQUIRE(r.code == 0);
    const auto handles = nanovdb::io::readGrids(nvdb);
    REQUIRE(handles.size() == 8);
    CHECK(std::string(handles.back().gridMetaData()->shortGridName()) == "density");
    CHECK(handles.back().gridMetaData()->activeVoxelCount() == std::uint64_t(density->activeVoxelCount()));
}

TEST_CASE("cli: band --stencils writes Selling offsets whose widths are stencil_width and the report's maximum", "[cli]") {
    const std::string vdb = temp("stencils.vdb"), json = temp("stencils.json");
    const Run r = run("band " + gpisvdb::test::dataPath("bunny.obj") + " -o " + vdb + " --report " + json +
                      " --sigma 2 --voxel-size 0.4 --quiet --stencils");
    INFO(r.err);
    REQUIRE(r.code == 0);
    const auto width = readFloatGrid(vdb, "stencil_width");
    REQUIRE(width);
    openvdb::io::File file(vdb);
    file.open();
    std::vector<openvdb::Vec3SGrid::Ptr> offsets;
    std::vector<openvdb::FloatGrid::Ptr> weights;
    for (int k = 0; k < 6; ++k) {
        offsets.push_back(openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid("selling_offset_" + std::to_string(k))));
        weights.push_back(openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("selling_weight_" + std::to_string(k))));
        REQUIRE(offsets.back());
        REQUIRE(weights.back());
    }
    file.close();
    float widest = 0;
    for (auto it = width->cbeginValueOn(); it; ++it) {
        float w = 0;
        for (int k = 0; k < 6; ++k) {
            const openvdb::Vec3s e = offsets[std::size_t(k)]->tree().getValue(it.getCoord());
            CHECK(weights[std::size_t(k)]->tree().getValue(it.getCoord()) >= 0);
            w = std::max(w, std::abs(e[0]) + std::abs(e[1]) + std::abs(e[2]));
        }
        CHECK(w == *it);
        widest = std::max(widest, w);
    }
    std::ifstream in(json);
    CHECK(nlohmann::json::parse(in)["band"]["max_stencil_l1"].get<double>() == widest);
}

TEST_CASE("cli: green writes 'green': positive, largest at the nearest voxel to the source, symmetric, as the report says", "[cli]") {
    const std::string vdb = temp("green.vdb"), json = temp("green.json");
    const Run r = run("green " + gpisvdb::test::dataPath("bunny.obj") + " --source 0.5,6,1 -o " + vdb + " --report " + json +
                      " --sigma 2 --voxel-size 0.4 --tolerance 1e-6 --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    checkBandReport(report, vdb, gpisvdb::test::dataPath("bunny.obj"), 2, 0.4);
    CHECK(report["timings_s"].contains("operators"));
    CHECK(report["solver"]["tolerance"].get<double>() == 1e-6);
    CHECK(report["solver"]["iterations"].get<int>() >= 1);
    CHECK(report["solver"]["relative_residual"].get<double>() <= 1e-6);
    // The source snaps to the band voxel nearest (0.5, 6, 1), found here from the grid and its transform.
    const auto mu = readFloatGrid(vdb, "mu");
    const auto G = readFloatGrid(vdb, "green");
    REQUIRE((mu && G));
    const auto [yIndex, y] = nearestActiveVoxel(*mu, {0.5, 6, 1});
    CHECK(report["green"]["source_index"].get<std::size_t>() == yIndex);
    for (int d = 0; d < 3; ++d) CHECK(report["green"]["source_voxel"][d].get<int>() == y[d]);
    // L f = M δ_y with an M-matrix L: f > 0 on the band, largest at y.
    CHECK(G->activeVoxelCount() == mu->activeVoxelCount());
    const float atY = G->tree().getValue(y);
    float lowest = atY, highest = atY;
    for (auto it = G->cbeginValueOn(); it; ++it) lowest = std::min(lowest, *it), highest = std::max(highest, *it);
    CHECK(lowest > 0);
    CHECK(highest == atY);
    // Symmetry G(x, y) = G(y, x): a second run from a voxel x elsewhere on the bunny (its centre, from the transform).
    const openvdb::Coord x = nearestActiveVoxel(*mu, {3, 4, -2}).second;
    const openvdb::Vec3d xw = mu->indexToWorld(x);
    const std::string vdb2 = temp("green2.vdb");
    std::ostringstream src;
    src << std::setprecision(17) << xw[0] << ',' << xw[1] << ',' << xw[2];
    REQUIRE(run("green " + gpisvdb::test::dataPath("bunny.obj") + " --source " + src.str() + " -o " + vdb2 +
                " --sigma 2 --voxel-size 0.4 --preconditioner ic --quiet")
                .code == 0);
    const auto G2 = readFloatGrid(vdb2, "green");
    REQUIRE(G2);
    INFO("G(x,y) " << G->tree().getValue(x) << ", G(y,x) " << G2->tree().getValue(y));
    CHECK(G->tree().getValue(x) > 1e-3 * highest);
    CHECK(G->tree().getValue(x) == Approx(G2->tree().getValue(y)).epsilon(1e-4));
    // mesh: every grid the task wrote can be sampled on the mean surface; bad requests fail cleanly.
    const std::string ply = temp("green.ply");
    CHECK(run("mesh " + vdb + " --grid green --grid normal -o " + ply + " --quiet").code == 0);
    CHECK(std::ifstream(ply).good());
    const std::string bad = temp("bad.ply");
    fs::remove(bad);
    const Run noGrid = run("mesh " + vdb + " --grid nosuch -o " + bad);
    CHECK(noGrid.code == 1);
    CHECK_THAT(noGrid.err, Catch::Contains("no grid 'nosuch'"));
    CHECK(run("mesh " + vdb + " --grid mu -o " + temp("bad.stl")).code == 1);
    CHECK(run("mesh " + ply + " --grid mu -o " + bad).code == 1);  // not a VDB file
    CHECK_FALSE(leftovers(bad));
    const int status = std::system(("vdb_print -l " + vdb + " > " + vdb + ".txt 2>&1").c_str());
    CHECK(WEXITSTATUS(status) == 0);
    std::ifstream t(vdb + ".txt");
    std::stringstream ts;
    ts << t.rdbuf();
    CHECK_THAT(ts.str(), Catch::Contains("Name: green"));
}

TEST_CASE("cli: green --spill writes the same grids, and auto spills only when the solve would not fit", "[cli]") {
    // The band's own grids written ahead and their channels freed for the solve (docs/memory.md#spill): the file
    // must not change. The aggregation multigrid is asked for on this small band (auto picks it from 1e5 voxels).
    const std::string input = gpisvdb::test::dataPath("bunny.obj");
    const std::string common = " --source 0.5,6,1 --sigma 2 --voxel-size 0.4 --preconditioner aggregation --quiet";
    std::map<std::string, nlohmann::json> reports;
    for (const std::string mode : {"always", "never", "auto"}) {
        const std::string vdb = temp("spill_" + mode + ".vdb"), json = temp("spill_" + mode + ".json");
        const Run r = run("green " + input + common + " --spill " + mode + " -o " + vdb + " --report " + json);
        INFO(mode << ": " << r.err);
        REQUIRE(r.code == 0);
        reports[mode] = nlohmann::json::parse(std::ifstream(json));
        CHECK(reports[mode]["solver"]["preconditioner"].get<std::string>() == "aggregation");
        CHECK(reports[mode]["solver"]["multigrid"]["levels"].get<int>() >= 2);
        for (const auto& e : fs::directory_iterator(fs::path(vdb).parent_path()))  // no side file left behind
            CHECK(e.path().filename().string().find(".grids") == std::string::npos);
    }
    CHECK(reports["always"]["green"]["spilled_band_grids"].get<bool>());
    CHECK_FALSE(reports["never"]["green"]["spilled_band_grids"].get<bool>());
    CHECK_FALSE(reports["auto"]["green"]["spilled_band_grids"].get<bool>());  // half the RAM is plenty here
    // The band's bytes per voxel are those of the band as built, not after its channels were freed.
    CHECK(reports["always"]["memory"]["band_bytes_per_voxel"].get<double>() > 60);
    CHECK(reports["always"]["memory"]["band_bytes_per_voxel"] == reports["never"]["memory"]["band_bytes_per_voxel"]);
    for (const std::string grid : {"mu", "mean", "stddev", "stencil_width", "green"}) {
        INFO(grid);
        const auto a = readFloatGrid(temp("spill_always.vdb"), grid);
        const auto b = readFloatGrid(temp("spill_never.vdb"), grid);
        REQUIRE((a && b));
        CHECK(a->activeVoxelCount() == b->activeVoxelCount());
        auto acc = b->getConstAccessor();
        for (auto it = a->cbeginValueOn(); it; ++it) REQUIRE(*it == acc.getValue(it.getCoord()));
    }
}

TEST_CASE("cli: hodge succeeds at its default tolerance where the float PCG alone stalls", "[cli]") {
    // The float PCG alone stalls at 1.6e-6 here (above the default 1e-6; the command failed before iterative
    // refinement, issue 18): the solve now continues in double and meets it. About 5 s.
    const std::string sphere = gpisvdb::test::dataPath("sphere_20k_normal.xyz");
    const std::string vdb = temp("hodge_stall.vdb"), json = temp("hodge_stall.json");
    const Run r = run("hodge " + sphere + " --preset mixed --sigma 0.25 --voxel-size 0.03 -o " + vdb + " --report " + json + " --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    const nlohmann::json& s = report["solver"];
    INFO(s.dump());
    CHECK(s["tolerance"].get<double>() == 1e-6);
    CHECK(s["relative_residual"].get<double>() <= 1e-6);
    CHECK(s["refinements"].get<int>() >= 1);
    // The float PCG ran first (the default is within its reach) and refinement took over from its stall.
    CHECK(s["iterations"].get<int>() > s["inner_iterations"].get<int>());
    CHECK(s["float_residual"].get<double>() > 1e-6);
    CHECK(s["method"].get<std::string>() == "PCG, Jacobi, refined in double");
    // The stored float parts: divergence-free to well below the tolerance's 1e-6 (measured 4.9e-7).
    CHECK(report["hodge"]["divergence_residual"].get<double>() < 1e-6);
}

TEST_CASE("cli: green reaches --tolerance 1e-10 by refinement and reports the float grid's own residual", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj"), green = temp("green_tight.json");
    const std::string vdb = temp("green_tight.vdb");
    const Run g = run("green " + bunny + " --source 0.5,6,1 --sigma 2 --voxel-size 0.4 --tolerance 1e-10 -o " + vdb + " --report " + green +
                      " --quiet");
    INFO(g.err);
    REQUIRE(g.code == 0);
    const nlohmann::json gs = nlohmann::json::parse(std::ifstream(green))["solver"];
    INFO(gs.dump());
    CHECK(gs["relative_residual"].get<double>() <= 1e-10);
    CHECK(gs["refinements"].get<int>() >= 2);
    CHECK(gs["float_residual"].get<double>() > gs["relative_residual"].get<double>());
    CHECK(gs["float_residual"].get<double>() < 1e-5);
}

TEST_CASE("cli: hodge writes vec3 parts that sum to the input with the reported S-norms, and reads a field back from a .vdb", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string vdb = temp("hodge.vdb"), json = temp("hodge.json"), again = temp("hodge2.vdb");
    const std::string common = " --sigma 2 --voxel-size 0.4 --quiet";
    const Run r = run("hodge " + bunny + " --preset mixed -o " + vdb + " --report " + json + common);
    INFO(r.err);
    REQUIRE(r.code == 0);
    std::ifstream in(json);
    const nlohmann::json report = nlohmann::json::parse(in);
    CHECK(report["hodge"]["divergence_residual"].get<double>() < 1e-4);
    CHECK(std::abs(report["hodge"]["s_inner_product"].get<double>()) < 1e-3);
    openvdb::initialize();
    openvdb::io::File file(vdb);
    file.open();
    auto grid = [&](const std::string& name) { return openvdb::gridPtrCast<openvdb::Vec3SGrid>(file.readGrid(name)); };
    const auto V = grid("hodge_input"), Vg = grid("hodge_gradient"), Vf = grid("hodge_free");
    REQUIRE((V && Vg && Vf));
    CHECK(Vg->getVectorType() == openvdb::VEC_CONTRAVARIANT_RELATIVE);
    CHECK(V->activeVoxelCount() == Vf->activeVoxelCount());
    auto g = Vg->getConstAccessor();
    auto f = Vf->getConstAccessor();
    for (auto it = V->cbeginValueOn(); it; ++it)
        CHECK((*it - g.getValue(it.getCoord()) - f.getValue(it.getCoord())).length() < 1e-5 * (1 + it->length()));
    // The report's S-norms and normalised S-inner product, from the grids: S = μ² T⁻¹, T's spectrum floored at
    // 1e-6 λmax (tasks/hodge.h), summed with h³.
    const auto Td = grid("T_diag"), To = grid("T_offdiag");
    REQUIRE((Td && To));
    file.close();
    checkBandReport(report, vdb, bunny, 2, 0.4);
    const auto mu = readFloatGrid(vdb, "mu");
    const double h3 = std::pow(mu->voxelSize()[0], 3);
    auto td = Td->getConstAccessor();
    auto to = To->getConstAccessor();
    double vv = 0, gg = 0, ff = 0, gf = 0;
    for (auto it = mu->cbeginValueOn(); it; ++it) {
        const openvdb::Coord c = it.getCoord();
        const openvdb::Vec3f d = td.getValue(c), o = to.getValue(c);
        Mat3d T;
        T << d[0], o[0], o[1], o[0], d[1], o[2], o[1], o[2], d[2];
        Eigen::SelfAdjointEigenSolver<Mat3d> eig(T);
        const Vec3d lambda = eig.eigenvalues().cwiseMax(1e-6 * eig.eigenvalues().maxCoeff());
        const Mat3d S =
            double(*it) * double(*it) * eig.eigenvectors() * lambda.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
        auto vec = [&](const openvdb::Vec3SGrid::ConstAccessor& acc) {
            const openvdb::Vec3f v = acc.getValue(c);
            return Vec3d(v[0], v[1], v[2]);
        };
        const Vec3d a = vec(V->getConstAccessor()), b = vec(g), e = vec(f);
        vv += h3 * a.dot(S * a), gg += h3 * b.dot(S * b), ff += h3 * e.dot(S * e), gf += h3 * b.dot(S * e);
    }
    const auto& hr = report["hodge"];
    CHECK(hr["s_norm_input"].get<double>() == Approx(std::sqrt(vv)).epsilon(1e-4));
    CHECK(hr["s_norm_gradient"].get<double>() == Approx(std::sqrt(gg)).epsilon(1e-4));
    CHECK(hr["s_norm_free"].get<double>() == Approx(std::sqrt(ff)).epsilon(1e-4));
    CHECK(hr["s_inner_product"].get<double>() == Approx(gf / std::sqrt(gg * ff)).margin(1e-4));
    CHECK(gg > 1e-3 * vv);  // the mixed preset has both parts
    CHECK(ff > 1e-3 * vv);
    CHECK(report["solver"]["relative_residual"].get<double>() <= report["solver"]["tolerance"].get<double>());
    // The written input read back as --field (one file, several vector grids: named) gives the same split.
    CHECK(run("hodge " + bunny + " --field " + vdb + " -o " + again + common).code == 1);
    const Run back = run("hodge " + bunny + " --field " + vdb + ":hodge_input -o " + again + common);
    INFO(back.err);
    REQUIRE(back.code == 0);
    openvdb::io::File file2(again);
    file2.open();
    const auto Vf2 = openvdb::gridPtrCast<openvdb::Vec3SGrid>(file2.readGrid("hodge_free"));
    double diff = 0, scale = 0;
    for (auto it = Vf->cbeginValueOn(); it; ++it) {
        diff = std::max(diff, double((*it - Vf2->tree().getValue(it.getCoord())).length()));
        scale = std::max(scale, double(it->length()));
    }
    CHECK(diff < 1e-4 * scale);
    const Run noGrid = run("hodge " + bunny + " --field " + vdb + ":nosuch -o " + again + common);
    CHECK(noGrid.code == 1);
    CHECK_THAT(noGrid.err, Catch::Contains("no vector grid named 'nosuch'"));
}

TEST_CASE("cli: distance writes a dense smoothed_distance grid, a level set and its mesh, as the report says", "[cli]") {
    const std::string vdb = temp("distance.vdb"), json = temp("distance.json"), ply = temp("offset.ply");
    const Run r = run("distance " + gpisvdb::test::dataPath("bunny.obj") + " --alpha 5 --grid-voxel-size 0.5 --level 0.3 --mesh " + ply +
                      " -o " + vdb + " --report " + json + " --sigma 2 --voxel-size 0.4 --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    std::ifstream in(json);
    const nlohmann::json report = nlohmann::json::parse(in);
    CHECK(report["distance"]["points"].get<double>() > 1000);
    CHECK(report["distance"]["mesh_triangles"].get<double>() > 100);
    openvdb::initialize();
    openvdb::io::File file(vdb);
    file.open();
    const auto d = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("smoothed_distance"));
    const auto level = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("smoothed_distance_level"));
    REQUIRE((d && level));
    CHECK(level->getGridClass() == openvdb::GRID_LEVEL_SET);
    CHECK(d->activeVoxelCount() == report["distance"]["points"].get<openvdb::Index64>());
    for (auto it = d->cbeginValueOn(); it; ++it) CHECK(std::isfinite(*it));
    // Report values from the grids: voxel size from the transform, dimensions of the active box, the level set
    // d − level voxel by voxel, and the mesh's face count from the PLY header.
    const auto& rd = report["distance"];
    CHECK(rd["voxel_size"].get<double>() == Approx(d->voxelSize()[0]).epsilon(1e-12));
    CHECK(d->voxelSize()[0] == Approx(0.5).epsilon(1e-12));
    const openvdb::CoordBBox box = d->evalActiveVoxelBoundingBox();
    for (int k = 0; k < 3; ++k) CHECK(rd["grid_dims"][k].get<int>() == box.dim()[k]);
    CHECK(box.volume() == d->activeVoxelCount());  // dense
    CHECK(rd["level"].get<double>() == 0.3);
    CHECK(level->activeVoxelCount() == d->activeVoxelCount());
    auto la = level->getConstAccessor();
    float worst = 0;
    for (auto it = d->cbeginValueOn(); it; ++it) worst = std::max(worst, std::abs(la.getValue(it.getCoord()) - (*it - 0.3f)));
    CHECK(worst <= 1e-6f);
    std::ifstream plyIn(ply, std::ios::binary);
    REQUIRE(plyIn.good());
    long faces = -1;
    for (std::string line; std::getline(plyIn, line) && line.rfind("end_header", 0) != 0;)
        if (line.rfind("element face ", 0) == 0) faces = std::stol(line.substr(13));
    CHECK(faces == rd["mesh_triangles"].get<long>());
}

TEST_CASE("cli: --model regression runs the band and green commands, from generated or read labels", "[cli]") {
    const std::string cloud = gpisvdb::test::dataPath("sphere_20k_normal.xyz");
    const std::string vdb = temp("regression.vdb"), json = temp("regression.json");
    const Run r = run("green " + cloud + " --model regression --training-points 100 --source 0,0,1 --voxel-size 0.08 -o " + vdb +
                      " --report " + json + " --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    std::ifstream in(json);
    const nlohmann::json report = nlohmann::json::parse(in);
    CHECK(report["parameters"]["model"] == "regression");
    CHECK(report["parameters"]["training_labels"] == 300);
    CHECK(report["parameters"]["iso"] == 0.0);
    // mesh takes the level from the file: the regression surface φ = 0 is the unit sphere (φ = 0.5 lies inside it).
    const std::string vtp = temp("regression.vtp");
    REQUIRE(run("mesh " + vdb + " --grid mu -o " + vtp + " --quiet").code == 0);
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    reader->SetFileName(vtp.c_str());
    reader->Update();
    vtkPolyData* poly = reader->GetOutput();
    REQUIRE(poly->GetNumberOfPoints() > 100);
    double radius = 0;
    for (vtkIdType i = 0; i < poly->GetNumberOfPoints(); ++i) {
        double p[3];
        poly->GetPoint(i, p);
        radius += std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    }
    CHECK(radius / double(poly->GetNumberOfPoints()) == Approx(1.0).epsilon(0.04));  // 1.03 measured; u = 0.5 gives ≈ 0.94
    std::string labels = "x,y,z,label\n";
    for (int i = 0; i < 40; ++i) {
        const double t = 2 * M_PI * i / 40;
        for (double z : {-0.6, 0.0, 0.6}) {
            const double r0 = std::sqrt(1 - z * z);
            for (auto [scale, label] : {std::pair{0.8, 1}, std::pair{1.0, 0}, std::pair{1.2, -1}})
                labels += std::to_string(scale * r0 * std::cos(t)) + "," + std::to_string(scale * r0 * std::sin(t)) + "," +
                          std::to_string(scale * z) + "," + std::to_string(label) + "\n";
        }
    }
    const Run fromFile =
        run("band " + cloud + " --model regression --labels " + temp("labels.csv", labels) + " --voxel-size 0.08 -o " + vdb + " --quiet");
    INFO(fromFile.err);
    CHECK(fromFile.code == 0);
}

TEST_CASE("cli: spectrum writes k M-orthonormal eigen_000 ... grids, their ascending eigenvalues and small residuals in the report",
          "[cli]") {
    const std::string vdb = temp("spectrum.vdb"), json = temp("spectrum.json");
    const Run r = run("spectrum " + gpisvdb::test::dataPath("bunny.obj") + " -k 6 -o " + vdb + " --report " + json +
                      " --sigma 2 --voxel-size 0.4 --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    const auto& values = report["spectrum"]["eigenvalues"];
    REQUIRE(values.size() == 6);
    CHECK(values[0].get<double>() > 0);
    for (std::size_t i = 1; i < values.size(); ++i) CHECK(values[i].get<double>() >= values[i - 1].get<double>());
    for (const auto& res : report["spectrum"]["residuals"]) CHECK(res.get<double>() <= 1e-6);
    CHECK(report["spectrum"]["orthonormality_error"].get<double>() <= 1e-8);
    openvdb::initialize();
    openvdb::io::File file(vdb);
    file.open();
    for (const char* name : {"eigen_000", "eigen_005", "mu"}) CHECK(file.hasGrid(name));
    CHECK_FALSE(file.hasGrid("eigen_006"));
    const auto meta = file.getMetadata();
    CHECK((*meta)["eigen_001_eigenvalue"]);
    CHECK(meta->metaValue<double>("eigen_001_eigenvalue") == Approx(values[1].get<double>()));
    for (std::size_t i = 0; i < values.size(); ++i) {
        char name[64];
        std::snprintf(name, sizeof name, "eigen_%03zu_eigenvalue", i);
        CHECK(meta->metaValue<double>(name) == Approx(values[i].get<double>()).epsilon(1e-12));
    }
    file.close();
    checkBandReport(report, vdb, gpisvdb::test::dataPath("bunny.obj"), 2, 0.4);
    // From the grids: M-orthonormal, Σ u_i u_j μ h³ = δ_ij (float storage), each sign fixed so its largest entry
    // is positive, the ground mode one-signed (docs/spectrum.md).
    const auto mu = readFloatGrid(vdb, "mu");
    std::vector<openvdb::FloatGrid::Ptr> u;
    for (std::size_t i = 0; i < values.size(); ++i) {
        char name[64];
        std::snprintf(name, sizeof name, "eigen_%03zu", i);
        u.push_back(readFloatGrid(vdb, name));
        REQUIRE(u.back());
        CHECK(u.back()->activeVoxelCount() == mu->activeVoxelCount());
    }
    const double h = mu->voxelSize()[0];
    double gramError = 0;
    for (std::size_t i = 0; i < u.size(); ++i)
        for (std::size_t j = i; j < u.size(); ++j) {
            double g = 0;
            auto ai = u[i]->getConstAccessor();
            auto aj = u[j]->getConstAccessor();
            for (auto it = mu->cbeginValueOn(); it; ++it)
                g += double(ai.getValue(it.getCoord())) * aj.getValue(it.getCoord()) * *it * h * h * h;
            gramError = std::max(gramError, std::abs(g - (i == j ? 1.0 : 0.0)));
        }
    CHECK(gramError < 1e-4);
    for (const auto& e : u) {
        float lo = 0, hi = 0;
        e->evalMinMax(lo, hi);
        CHECK(hi >= -lo);
    }
    float lo0 = 0, hi0 = 0;
    u[0]->evalMinMax(lo0, hi0);
    CHECK(lo0 >= -1e-4f * hi0);
}

TEST_CASE("cli: regress interpolates exact data and writes regression_mean and regression_variance", "[cli]") {
    // Data at five of the bunny's own vertices: on the shape, so in the band.
    std::ifstream obj(gpisvdb::test::dataPath("bunny.obj"));
    std::string line, csv = "x,y,z,value\n";
    int count = 0;
    std::vector<double> values;
    for (int row = 0; std::getline(obj, line) && count < 5; ++row) {
        if (line.rfind("v ", 0) != 0 || row % 97 != 0) continue;
        std::istringstream in(line.substr(2));
        double x, y, z;
        in >> x >> y >> z;
        values.push_back(count * 1.5 - 2);
        csv += std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(z) + "," + std::to_string(values.back()) + "\n";
        ++count;
    }
    REQUIRE(count == 5);
    const std::string vdb = temp("regress.vdb"), json = temp("regress.json");
    const Run r = run("regress " + gpisvdb::test::dataPath("bunny.obj") + " --data " + temp("regress.csv", csv) + " -k 30 --nu 2.5 -o " +
                      vdb + " --report " + json + " --sigma 2 --voxel-size 0.4 --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    const auto& g = report["regression"];
    CHECK(g["points"] == 5);
    CHECK(g["nu"].get<double>() == 2.5);
    for (std::size_t j = 0; j < values.size(); ++j) {
        CHECK(g["mean_at_data"][j].get<double>() == Approx(values[j]).margin(1e-5));
        CHECK(g["variance_at_data"][j].get<double>() <= 1e-5 * g["amplitude"].get<double>());
    }
    CHECK(report["spectrum"]["eigenvalues"].size() == 30);  // -k 30
    checkBandReport(report, vdb, gpisvdb::test::dataPath("bunny.obj"), 2, 0.4);
    openvdb::initialize();
    openvdb::io::File file(vdb);
    file.open();
    CHECK(file.hasGrid("regression_mean"));
    CHECK(file.hasGrid("regression_variance"));
    const auto var = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("regression_variance"));
    float lo = 0, hi = 0;
    var->evalMinMax(lo, hi);
    CHECK(lo >= 0);
    CHECK(hi > 0);
    file.close();
}

TEST_CASE(
    "cli: geodesic writes 'geodesic', 0 at the source and as reported at the targets, and bunny paths that keep near the mean surface",
    "[cli]") {
    const std::string vdb = temp("geo.vdb"), json = temp("geo.json"), paths = temp("geo_paths.json"), obj = temp("geo_paths.obj"),
                      vtp = temp("geo_paths.vtp");
    const std::string common = "geodesic " + gpisvdb::test::dataPath("bunny.obj") +
                               " --source 0.5,6,1 --target -2,9,0 --target 3,4,-2 --sigma 0.5 --voxel-size 0.15 --quiet";
    const Run r = run(common + " -o " + vdb + " --report " + json + " --paths " + paths);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    checkBandReport(report, vdb, gpisvdb::test::dataPath("bunny.obj"), 0.5, 0.15);
    const auto mu = readFloatGrid(vdb, "mu");
    REQUIRE(mu);
    CHECK(report["geodesic"]["unreached"] == 0);
    CHECK(report["geodesic"]["reached"].get<openvdb::Index64>() == mu->activeVoxelCount());
    CHECK(report["timings_s"].contains("solve"));
    REQUIRE(report["geodesic"]["paths"].size() == 2);

    // === The paths: from the target voxel to the source voxel, U decreasing, no shorter than the chord
    openvdb::initialize();
    openvdb::io::File file(vdb);
    file.open();
    const auto mean = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("mean"));
    const auto geodesic = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("geodesic"));
    file.close();
    const double h = mean->voxelSize()[0];
    const gpisvdb::SurfaceMesh surface = gpisvdb::meanSurface(*mean, 0.5);
    const nlohmann::json p = nlohmann::json::parse(std::ifstream(paths));
    REQUIRE(p["paths"].size() == 2);
    for (const auto& path : p["paths"]) {
        CHECK(path["reached_source"] == true);
        const auto& points = path["points"];
        const auto& u = path["geodesic"];
        REQUIRE(points.size() > 10);
        for (std::size_t i = 1; i < u.size(); ++i) CHECK(u[i].get<double>() < u[i - 1].get<double>());
        const openvdb::Vec3d a(points.front()[0], points.front()[1], points.front()[2]),
            b(points.back()[0], points.back()[1], points.back()[2]);
        CHECK(path["length"].get<double>() >= (a - b).length());
        // every point within two voxels of the mean surface (distance to its nearest vertex), most within one
        std::size_t within = 0;
        for (const auto& x : points) {
            const openvdb::Vec3s q(x[0].get<float>(), x[1].get<float>(), x[2].get<float>());
            double best = 1e300;
            for (const auto& v : surface.vertices) best = std::min(best, double((v - q).lengthSqr()));
            CHECK(std::sqrt(best) < 2 * h);
            if (std::sqrt(best) < h) ++within;
        }
        CHECK(double(within) > 0.9 * double(points.size()));
    }
    // U is 0 at the source voxel (the band voxel nearest the source point, found here); every band voxel was
    // reached, so every one is active; the report's distances are U at the targets' nearest voxels and its max.
    const auto [sIndex, sVoxel] = nearestActiveVoxel(*mu, {0.5, 6, 1});
    const auto& s = report["geodesic"]["sources"][0]["voxel"];
    CHECK(report["geodesic"]["sources"][0]["index"].get<std::size_t>() == sIndex);
    CHECK(openvdb::Coord(s[0].get<int>(), s[1].get<int>(), s[2].get<int>()) == sVoxel);
    CHECK(geodesic->tree().getValue(sVoxel) == 0);
    CHECK(geodesic->activeVoxelCount() == mu->activeVoxelCount());
    float lowest = 0, farthest = 0;
    geodesic->evalMinMax(lowest, farthest);
    CHECK(lowest == 0);
    CHECK(report["geodesic"]["max_distance"].get<double>() == Approx(farthest).epsilon(1e-6));
    const openvdb::Vec3d targets[2] = {{-2, 9, 0}, {3, 4, -2}};
    for (int k = 0; k < 2; ++k) {
        const auto& rp = report["geodesic"]["paths"][k];
        const auto [tIndex, tVoxel] = nearestActiveVoxel(*mu, targets[k]);
        CHECK(rp["target_index"].get<std::size_t>() == tIndex);
        CHECK(rp["distance"].get<double>() == Approx(geodesic->tree().getValue(tVoxel)).epsilon(1e-6));
        CHECK(rp["points"].get<std::size_t>() == p["paths"][k]["points"].size());
        CHECK(rp["length"].get<double>() == Approx(p["paths"][k]["length"].get<double>()).epsilon(1e-9));
        // the length is the sum of the written segments
        double length = 0;
        const auto& pts = p["paths"][k]["points"];
        for (std::size_t i = 1; i < pts.size(); ++i)
            length +=
                (openvdb::Vec3d(pts[i][0], pts[i][1], pts[i][2]) - openvdb::Vec3d(pts[i - 1][0], pts[i - 1][1], pts[i - 1][2])).length();
        CHECK(rp["length"].get<double>() == Approx(length).epsilon(1e-5));
    }

    // === The same paths as OBJ and VTP
    REQUIRE(run(common + " -o " + vdb + " --paths " + obj).code == 0);
    std::ifstream o(obj);
    std::stringstream os;
    os << o.rdbuf();
    const std::string objText = os.str();
    CHECK(std::count(objText.begin(), objText.end(), '\n') > 20);
    CHECK_THAT(objText, Catch::Contains("\nl "));
    REQUIRE(run(common + " -o " + vdb + " --paths " + vtp).code == 0);
    std::ifstream v(vtp);
    std::stringstream vs;
    vs << v.rdbuf();
    CHECK_THAT(vs.str(), Catch::Contains("<Lines>"));
    CHECK_THAT(vs.str(), Catch::Contains("Name=\"geodesic\""));
}

TEST_CASE("cli: every subcommand has --help with an example, and refuses unknown flags and missing arguments", "[cli]") {
    const std::vector<std::string> commands = {"info",  "evaluate", "demo", "band",   "green",  "spectrum", "regress", "geodesic",
                                               "hodge", "distance", "mesh", "render", "sample", "surfaces", "query"};
    const Run top = run("--help");
    CHECK(top.code == 0);
    CHECK_THAT(top.out, Catch::Contains("Exit codes"));
    for (const std::string& c : commands) {
        INFO(c);
        const Run help = run(c + " --help");
        CHECK(help.code == 0);
        CHECK_THAT(help.out, Catch::Contains("Example"));
        if (c != "info") CHECK_THAT(help.out, Catch::Contains("--threads"));
        CHECK(run(c + " --no-such-flag").code == 2);
        if (c != "demo") CHECK(run(c).code == 2);  // every other command needs an input
    }
    CHECK(run("nosuchcommand").code == 2);
    const Run version = run("--version");
    CHECK(version.code == 0);
    CHECK_THAT(version.out, Catch::Contains(GPISVDB_VERSION));
}

TEST_CASE("cli: an interrupted run exits 130 and leaves no file at the output path", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string vdb = temp("interrupted.vdb"), json = temp("interrupted.json");
    // At the default voxel size the bunny's band (σ_rel 0.5, h = 1.25 w_μ) has ~320 k voxels: seconds of work,
    // interrupted at its first progress line.
    const std::vector<std::pair<std::string, std::string>> commands = {{"band", ""},
                                                                       {"green", "--source 0.5,6,1"},
                                                                       {"geodesic", "--source 0.5,6,1"},
                                                                       {"spectrum", "-k 4"},
                                                                       {"hodge", "--preset mixed"},
                                                                       {"distance", "--alpha 20"},
                                                                       {"regress", "--data " + temp("int.csv", "0,6,0,1\n")}};
    for (const auto& [command, flags] : commands) {
        INFO(command);
        fs::remove(vdb);
        const Run r = runInterrupted(command + " " + bunny + " " + flags + " -o " + vdb + " --report " + json);
        INFO(r.err);
        CHECK(r.code == 130);
        CHECK(lines(r.err) == 1);
        CHECK_FALSE(leftovers(vdb));
        CHECK_FALSE(leftovers(json));
    }
}

namespace {
/// A small band of the bunny with a Green's function and a geodesic path, shared by the render and sample tests.
struct SmallResult {
    std::string vdb, paths;
};
const SmallResult& smallResult() {
    static const SmallResult r = [] {
        SmallResult s{temp("small_geo.vdb"), temp("small_geo_path.vtp")};
        const Run g = run("geodesic " + gpisvdb::test::dataPath("bunny.obj") + " --source 0.5,6,1 --target -2,9,0 -o " + s.vdb +
                          " --paths " + s.paths + " --sigma 2 --voxel-size 0.4 --quiet");
        REQUIRE(g.code == 0);
        return s;
    }();
    return r;
}
}  // namespace

TEST_CASE("cli: render writes a picture that is not blank, with a slice panel beside the surface", "[cli][render]") {
    const SmallResult& s = smallResult();
    const std::string png = temp("render.png");
    fs::remove(png);
    const int width = 300, height = 240;  // --size, per panel
    const std::string size = " --size " + std::to_string(width) + "," + std::to_string(height);
    const Run r = run("render " + s.vdb + " --grid geodesic --paths " + s.paths + size + " -o " + png + " --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    gpisvdb::test::PngStats st = gpisvdb::test::pngStats(png);
    REQUIRE(st.readable);
    CHECK(st.width == width);
    CHECK(st.height == height);
    CHECK(st.colours > 100);
    CHECK(st.nonWhite > 0.1);
    const Run sliced = run("render " + s.vdb + " --grid mu --log --colormap magma --slice z=0.5" + size + " -o " + png + " --quiet");
    INFO(sliced.err);
    REQUIRE(sliced.code == 0);
    st = gpisvdb::test::pngStats(png);
    CHECK(st.width == 2 * width);  // surface and slice panels side by side
    CHECK(st.height == height);
    CHECK(st.colours > 100);
}

TEST_CASE("cli: sample writes one value per input vertex or point, for every grid by default", "[cli]") {
    const SmallResult& s = smallResult();
    const std::string vtp = temp("sampled.vtp");
    const Run r = run("sample " + s.vdb + " --at " + gpisvdb::test::dataPath("bunny.obj") + " -o " + vtp + " --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
    reader->SetFileName(vtp.c_str());
    reader->Update();
    vtkPolyData* pd = reader->GetOutput();
    const gpisvdb::InputData bunny = gpisvdb::readInput(gpisvdb::test::dataPath("bunny.obj"));
    CHECK(pd->GetNumberOfPoints() == vtkIdType(bunny.soup->vertices.size()));
    CHECK(pd->GetNumberOfPolys() == vtkIdType(bunny.soup->triangles.size()));
    for (const char* a : {"mu", "mean", "stddev", "geodesic", "normal", "T_diag"}) {
        INFO(a);
        REQUIRE(pd->GetPointData()->GetArray(a));
        CHECK(pd->GetPointData()->GetArray(a)->GetNumberOfTuples() == pd->GetNumberOfPoints());
    }
    CHECK(pd->GetPointData()->GetArray("normal")->GetNumberOfComponents() == 3);
    // The mean field at the input's own vertices is near the iso-value 0.5 (the data lie on the surface).
    vtkDataArray* mean = pd->GetPointData()->GetArray("mean");
    double sum = 0;
    for (vtkIdType i = 0; i < mean->GetNumberOfTuples(); ++i) sum += mean->GetTuple1(i);
    CHECK(std::abs(sum / double(mean->GetNumberOfTuples()) - 0.5) < 0.1);

    // A point cloud: one value per point, the points as vertex cells; a chosen grid only.
    const std::string xyz = temp("sample_points.xyz", "0.5 6 1 0 0 1\n-2 9 0 0 1 0\n0 7 0 1 0 0\n");
    const std::string ply = temp("sampled_points.ply");
    REQUIRE(run("sample " + s.vdb + " --at " + xyz + " --grid mu -o " + ply + " --quiet").code == 0);
    std::ifstream in(ply, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    CHECK_THAT(ss.str(), Catch::Contains("element vertex 3\n"));
    CHECK_THAT(ss.str(), Catch::Contains("property float mu\n"));
    CHECK_THAT(ss.str(), !Catch::Contains("property float stddev"));
}

TEST_CASE("cli: --half stores 16-bit grids that vdb_print and pyopenvdb read, values within half precision", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string full = temp("full.vdb"), half = temp("half.vdb");
    const std::string common = "band " + bunny + " --sigma 2 --voxel-size 0.4 --quiet -o ";
    REQUIRE(run(common + full).code == 0);
    REQUIRE(run(common + half + " --half").code == 0);
    CHECK(fs::file_size(half) < 0.9 * double(fs::file_size(full)));  // Blosc already packs the floats: ~16 % smaller
    CHECK(runShell("vdb_print -l " + half).code == 0);
    const std::string script = temp("half.py");
    std::ofstream(script) << "import sys, pyopenvdb as vdb\n"
                             "f, _ = vdb.readAll(sys.argv[1]); h, meta = vdb.readAll(sys.argv[2])\n"
                             "F = {g.name: g for g in f}; H = {g.name: g for g in h}\n"
                             "print('half_float', meta['half_float'])\n"
                             "worst = 0\n"
                             "for name in ('mu', 'mean', 'stddev'):\n"
                             "    acc = H[name].getConstAccessor()\n"
                             "    for item in F[name].citerOnValues():\n"
                             "        v = item.value; w = acc.getValue(item.min)\n"
                             "        worst = max(worst, abs(v - w) / max(abs(v), 1e-3))\n"
                             "print('worst', worst)\n";
    const Run py = runShell("/usr/bin/python3 " + script + " " + full + " " + half);
    INFO(py.out << py.err);
    REQUIRE(py.code == 0);
    CHECK_THAT(py.out, Catch::Contains("half_float True"));
    const auto at = py.out.find("worst ");
    REQUIRE(at != std::string::npos);
    const double worst = std::stod(py.out.substr(at + 6));
    CHECK(worst > 0);     // the values were rounded ...
    CHECK(worst < 2e-3);  // ... to half precision (2^-11 relative)
}

TEST_CASE("cli: progress bars on a terminal only, never when stderr is piped or with --quiet", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string vdb = temp("progress.vdb");
    const std::string band = std::string(GPISVDB_EXE) + " band " + bunny + " --sigma 2 --voxel-size 0.4 -o " + vdb;
    const Run piped = runShell(band);
    REQUIRE(piped.code == 0);
    CHECK(piped.err.find('\r') == std::string::npos);
    CHECK(piped.err.find("[#") == std::string::npos);
    // `script` runs the command on a pseudo-terminal: there the bar is drawn (and --quiet still silences it).
    const Run tty = runShell("script -qec '" + band + "' /dev/null");
    REQUIRE(tty.code == 0);
    CHECK(tty.out.find("[#") != std::string::npos);
    const Run quiet = runShell("script -qec '" + band + " --quiet' /dev/null");
    REQUIRE(quiet.code == 0);
    CHECK(quiet.out.find("[#") == std::string::npos);
}

TEST_CASE("cli: render and sample refuse bad input and parameters with one line and no output", "[cli][render]") {
    const SmallResult& s = smallResult();
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string png = temp("bad_render.png"), mesh = temp("bad_sample.vtp");
    const std::string notVdb = temp("not_a.vdb", "hello");
    struct Case {
        std::string args, expect;
    };
    const std::vector<Case> cases = {
        {"render /nonexistent.vdb --grid mu -o " + png, "no such file"},
        {"render " + notVdb + " --grid mu -o " + png, "cannot be read as an OpenVDB file"},
        {"render " + s.vdb + " --grid nosuch -o " + png, "no grid 'nosuch'"},
        {"render " + s.vdb + " --grid normal -o " + png, "not a float grid"},
        {"render " + s.vdb + " --grid mu --slice q=1 -o " + png, "--slice"},
        {"render " + s.vdb + " --grid mu --slice z=1000 -o " + png, "misses the grid"},
        {"render " + s.vdb + " --grid mu --colormap jet -o " + png, "colour map"},
        {"render " + s.vdb + " --grid mu --range 2,1 -o " + png, "--range"},
        {"render " + s.vdb + " --grid mu --log --range 0,1 -o " + png, "--range"},
        {"render " + s.vdb + " --grid mu --size 10,10 -o " + png, "pixels"},
        {"render " + s.vdb + " --grid mu --size 1e6,1e6 -o " + png, "--size: picture panels must be whole numbers of 64 to 8192"},
        {"render " + s.vdb + " --grid mu --size 1e300,100 -o " + png, "--size"},
        {"render " + s.vdb + " --grid mu --paths /nonexistent.vtp -o " + png, "no such file"},
        {"render " + s.vdb + " --grid mu -o " + temp("bad_render.jpg"), ".png"},
        {"sample " + s.vdb + " --at /nonexistent.obj -o " + mesh, "no such file"},
        {"sample " + s.vdb + " --at " + bunny + " --grid nosuch -o " + mesh, "no grid 'nosuch'"},
        {"sample " + s.vdb + " --at " + bunny + " -o " + temp("bad_sample.stl"), "extension"},
        {"sample " + notVdb + " --at " + bunny + " -o " + mesh, "cannot be read as an OpenVDB file"},
    };
    for (const Case& c : cases) {
        const Run r = run(c.args);
        INFO(c.args << "\nstderr: " << r.err);
        CHECK(r.code == 1);
        CHECK(lines(r.err) == 1);
        CHECK_THAT(r.err, Catch::Contains(c.expect));
        CHECK_FALSE(leftovers(png));
        CHECK_FALSE(leftovers(mesh));
    }
}

namespace {

/// Active values of every float and vec3 grid in a .vdb that are not finite: "NAME: count" per offending grid.
std::string nonFiniteActiveValues(const std::string& path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    std::string bad;
    const openvdb::GridPtrVecPtr grids = file.getGrids();
    for (const auto& g : *grids) {
        std::size_t count = 0;
        if (auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(g)) {
            for (auto it = f->cbeginValueOn(); it; ++it) count += std::isfinite(*it) ? 0 : 1;
            count += std::isfinite(f->background()) ? 0 : 1;
        } else if (auto v = openvdb::gridPtrCast<openvdb::Vec3SGrid>(g)) {
            for (auto it = v->cbeginValueOn(); it; ++it)
                count += std::isfinite((*it)[0]) && std::isfinite((*it)[1]) && std::isfinite((*it)[2]) ? 0 : 1;
        } else {
            bad += g->getName() + ": not a float or vec3 grid; ";
        }
        if (count) bad += g->getName() + ": " + std::to_string(count) + " non-finite; ";
    }
    file.close();
    return bad;
}

}  // namespace

TEST_CASE("cli: no command writes an active inf or NaN into any grid of any .vdb", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string small = " --sigma 2 --voxel-size 0.4 --quiet";
    std::string csv;  // regress: a few data points on the bunny
    {
        std::ifstream obj(bunny);
        int count = 0;
        for (std::string line; std::getline(obj, line) && count < 4;)
            if (line.rfind("v ", 0) == 0 && (++count, true)) csv += line.substr(2) + " " + std::to_string(count) + "\n";
        for (char& c : csv)
            if (c == ' ') c = ',';
    }
    const std::string data = temp("finite_regress.csv", csv);
    struct Case {
        std::string name, args;
    };
    const std::vector<Case> cases = {
        {"band", "band " + bunny + small + " --stencils"},
        {"band-half", "band " + bunny + small + " --half"},
        {"green", "green " + bunny + " --source 0.5,6,1" + small},
        // A target beyond the march's reach (--stop-at-targets) leaves voxels at U = +inf: they must be inactive.
        {"geodesic", "geodesic " + bunny + " --source 0.5,6,1 --target 0.5,6.5,1 --stop-at-targets" + small},
        {"spectrum", "spectrum " + bunny + " -k 3" + small},
        {"hodge", "hodge " + bunny + " --preset mixed" + small},
        {"distance", "distance " + bunny + " --alpha 5 --grid-voxel-size 0.6 --level 0.3" + small},
        {"regress", "regress " + bunny + " --data " + data + " -k 10" + small},
    };
    for (const Case& c : cases) {
        const std::string vdb = temp("finite_" + c.name + ".vdb");
        fs::remove(vdb);
        const Run r = run(c.args + " -o " + vdb);
        INFO(c.args << "\nstderr: " << r.err);
        REQUIRE(r.code == 0);
        CHECK(nonFiniteActiveValues(vdb).empty());
    }
}

TEST_CASE("cli: the report warns when beta, the QMC count or the anisotropy cap exceed their documented error", "[cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj");
    const std::string vdb = temp("warn.vdb"), json = temp("warn.json");
    const std::string small = " --sigma 2 --voxel-size 0.4 -o " + vdb + " --report " + json;
    // Defaults: no warnings, and nothing on stderr with --quiet.
    Run r = run("band " + bunny + small + " --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(r.err.empty());
    nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    REQUIRE(report["warnings"].is_array());
    const std::size_t regularised = report["band"]["regularised_voxels"].get<std::size_t>();
    const std::size_t voxels = report["band"]["voxels"].get<std::size_t>();
    CHECK(report["warnings"].size() == (regularised > voxels / 100 ? 1u : 0u));
    // Each setting outside its documented range: one warning naming its flag, in the report and on stderr.
    struct Case {
        std::string flags, expect;
    };
    for (const Case& c : {Case{" --beta 3", "--beta 3 is below 6"}, Case{" --qmc 64", "--qmc 64 is below 512"},
                          Case{" --max-anisotropy 1", "regularised by the anisotropy cap --max-anisotropy 1"}}) {
        r = run("band " + bunny + small + c.flags);
        INFO(c.flags << "\nstderr: " << r.err);
        REQUIRE(r.code == 0);
        CHECK_THAT(r.err, Catch::Contains("warning: ") && Catch::Contains(c.expect));
        report = nlohmann::json::parse(std::ifstream(json));
        bool found = false;
        for (const auto& w : report["warnings"]) found |= w.get<std::string>().find(c.expect) != std::string::npos;
        CHECK(found);
        // --quiet keeps stderr clean; the report still holds the warning.
        const Run quiet = run("band " + bunny + small + c.flags + " --quiet");
        CHECK(quiet.code == 0);
        CHECK(quiet.err.empty());
        CHECK(nlohmann::json::parse(std::ifstream(json))["warnings"].size() >= 1);
    }
    // The exact model and the regression model have no β: no β warning.
    r = run("band " + bunny + small + " --beta 3 --exact --quiet");
    REQUIRE(r.code == 0);
    const nlohmann::json exactReport = nlohmann::json::parse(std::ifstream(json));  // must outlive the loop
    for (const auto& w : exactReport["warnings"]) CHECK(w.get<std::string>().find("--beta") == std::string::npos);
}

namespace {
/// n random points on the unit sphere with radial normals and σ in the 7th column (a scan's own noise), fixed seed.
std::string sphereCloud(const std::string& name, int n, double sigma) {
    std::mt19937 rng(11);
    std::normal_distribution<double> g;
    std::ostringstream text;
    text << std::setprecision(9);
    for (int i = 0; i < n; ++i) {
        const Vec3d p = Vec3d(g(rng), g(rng), g(rng)).normalized();
        text << p.x() << ' ' << p.y() << ' ' << p.z() << ' ' << p.x() << ' ' << p.y() << ' ' << p.z() << ' ' << sigma << '\n';
    }
    return temp(name, text.str());
}
}  // namespace

TEST_CASE("cli: a cloud denser than the kernel is summed as merged dipoles (said in the report and by info) and --merge 0 sums every point",
          "[cli]") {
    // 20 000 points with σ = 0.05: s = 1.2 σ = 0.06 is above ℓ ≈ 0.025, so cells of s hold several points each.
    const std::string cloud = sphereCloud("merge_cloud.xyz", 20000, 0.05);
    const std::string vdb = temp("merge.vdb"), merged = temp("merge.json"), every = temp("merge_every.json");
    const std::string flags = " --max-voxels 30000 --quiet";
    Run r = run("band " + cloud + " -o " + vdb + " --report " + merged + flags);
    INFO(r.err);
    REQUIRE(r.code == 0);
    REQUIRE(run("band " + cloud + " -o " + vdb + " --report " + every + flags + " --merge 0").code == 0);
    const nlohmann::json a = nlohmann::json::parse(std::ifstream(merged)), b = nlohmann::json::parse(std::ifstream(every));
    CHECK(a["parameters"]["merge_rel"].get<double>() == 1);
    CHECK(a["input"]["samples"].get<std::size_t>() == 20000);
    CHECK(a["input"]["model_samples"].get<std::size_t>() < 20000 / 3);
    CHECK(b["input"]["model_samples"].get<std::size_t>() == 20000);
    // The same band within the model's error: the expected area within 0.5 % (docs/math.md#merging).
    INFO("mass merged " << a["band"]["mass"] << ", every point " << b["band"]["mass"]);
    CHECK(a["band"]["mass"].get<double>() == Approx(b["band"]["mass"].get<double>()).epsilon(0.005));
    r = run("info " + cloud + " --max-voxels 30000");
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("the samples merged into " + std::to_string(a["input"]["model_samples"].get<std::size_t>())));
    // A soup at the default s = 0.4 ℓ is never merged.
    r = run("band " + gpisvdb::test::dataPath("bunny.obj") + " -o " + vdb + " --report " + merged + " --quiet");
    REQUIRE(r.code == 0);
    const nlohmann::json c = nlohmann::json::parse(std::ifstream(merged));
    CHECK(c["input"]["model_samples"] == c["input"]["samples"]);
    r = run("band " + cloud + " -o " + vdb + " --merge -1");
    CHECK(r.code == 1);
    CHECK_THAT(r.err, Catch::Contains("--merge") && Catch::Contains(">= 0"));
}

TEST_CASE("cli: the band-voxel budget sets the default voxel size and says so, and --voxel-size still refuses what does not fit", "[cli]") {
    // A dense cloud (4000 points, σ = 0.02 in world units): its accuracy-driven band holds millions of voxels; a
    // budget of 20 000 coarsens h to fit it, and says so.
    const std::string cloud = sphereCloud("budget_cloud.xyz", 4000, 0.02);
    const std::string vdb = temp("budget.vdb"), json = temp("budget.json");
    Run r = run("band " + cloud + " -o " + vdb + " --report " + json + " --max-voxels 20000 --max-memory 40M");
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK_THAT(r.err, Catch::Contains("note: the band-voxel budget (--max-voxels 20000) set the voxel size"));
    CHECK_THAT(r.err, Catch::Contains("w_mu") && Catch::Contains("means along the voxels' axes (column values)"));
    nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    const auto& par = report["parameters"];
    CHECK(par["voxel_size_by_budget"].get<bool>());
    CHECK(par["max_band_voxels"].get<double>() == 20000);
    CHECK(par["accuracy_voxels"].get<double>() > 10 * 20000);
    CHECK(par["voxel_size"].get<double>() > par["accuracy_voxel_size"].get<double>());
    CHECK(par["voxel_size"].get<double>() > 2 * par["mu_width"].get<double>());  // so auto takes column values
    CHECK(par["voxel_values"].get<std::string>() == "column");
    CHECK(par["smoothing_set_by"].get<std::string>() == "noise");  // 1.2 × 0.02 above 0.4 ℓ
    CHECK(par["smoothing"].get<double>() == Approx(1.2 * 0.02).epsilon(1e-6));
    const double voxels = report["band"]["voxels"].get<double>();
    CHECK(voxels <= 1.3 * 20000);
    CHECK(voxels >= 0.5 * 20000);
    // The column values keep the expected area of a 10× larger budget's band (h at 2.3 w_μ) within 2 %: measured
    // +1.4 % at this h, 5 w_μ (the centres' values: +1.9 %; docs/benchmarks.md#column-values).
    const double coarseMass = report["band"]["mass"].get<double>();
    const std::string columnFiner = temp("budget_column_finer.json");
    REQUIRE(run("band " + cloud + " -o " + temp("budget_finer.vdb") + " --report " + columnFiner + " --max-voxels 200000 --quiet").code ==
            0);
    const nlohmann::json columnFine = nlohmann::json::parse(std::ifstream(columnFiner));
    INFO("column values: mass " << coarseMass << " at h " << par["voxel_size"] << ", " << columnFine["band"]["mass"] << " at h "
                                << columnFine["parameters"]["voxel_size"]);
    CHECK(coarseMass == Approx(columnFine["band"]["mass"].get<double>()).epsilon(0.02));
    // With voxel values s follows the analysis scale, 2h, and the expected area barely depends on the budget: a 10×
    // larger one (h 2.5× finer) gives it within 3 % (measured −2.5 % at h = R/26: s = 2h shrinks the sphere's mean
    // surface by ≈ 2 s²/R² ≈ 1.1 %, the rest is γ's linearisation across a voxel; docs/band.md#coarse-voxels).
    r = run("band " + cloud + " -o " + vdb + " --report " + json + " --max-voxels 20000 --voxel-values voxel");
    REQUIRE(r.code == 0);
    CHECK_THAT(r.err, Catch::Contains("own shares"));
    report = nlohmann::json::parse(std::ifstream(json));
    CHECK(report["parameters"]["voxel_values"].get<std::string>() == "voxel");
    CHECK(report["parameters"]["smoothing_set_by"].get<std::string>() == "voxel size");
    CHECK(report["parameters"]["smoothing"].get<double>() == Approx(2 * report["parameters"]["voxel_size"].get<double>()).epsilon(1e-12));
    const std::string finer = temp("budget_finer.json");
    const Run f = run("band " + cloud + " -o " + temp("budget_finer.vdb") + " --report " + finer +
                      " --max-voxels 200000 --voxel-values voxel --quiet");
    REQUIRE(f.code == 0);
    const nlohmann::json fine = nlohmann::json::parse(std::ifstream(finer));
    INFO("mass " << report["band"]["mass"] << " at h " << report["parameters"]["voxel_size"] << ", " << fine["band"]["mass"] << " at h "
                 << fine["parameters"]["voxel_size"]);
    CHECK(report["band"]["mass"].get<double>() == Approx(fine["band"]["mass"].get<double>()).epsilon(0.03));
    // Without the budget the default band does not fit the same limit; a given voxel size is refused as before.
    const std::string refused = temp("budget_refused.vdb");
    r = run("band " + cloud + " -o " + refused + " --max-voxels 0 --max-memory 40M --quiet");
    CHECK(r.code == 1);
    CHECK_THAT(r.err, Catch::Contains("more than the memory limit"));
    r = run("band " + cloud + " -o " + refused + " --voxel-size 0.002 --max-memory 40M --quiet");
    CHECK(r.code == 1);
    CHECK_THAT(r.err, Catch::Contains("use a voxel size (--voxel-size) of"));
    // Bad budgets: one line naming the flag.
    r = run("band " + cloud + " -o " + refused + " --max-voxels 10 --quiet");
    CHECK(r.code == 1);
    CHECK_THAT(r.err, Catch::Contains("--max-voxels"));
    CHECK_FALSE(fs::exists(refused));
}

TEST_CASE("cli: spectrum and regress default to the eigen solvers' band-voxel budget, and --max-voxels still wins", "[cli]") {
    // The same dense cloud as above: its accuracy-driven band holds ≈ 8e5 voxels, so the eigen solvers' budget
    // (kEigenMaxBandVoxels, 3e5) sets h. Lanczos' factor of a 3e5-voxel band needs ≈ 1 GB: under --max-memory 250M
    // the command stops there, after the band and its note (a quick check of the default, not a slow solve).
    const std::string cloud = sphereCloud("eigen_budget_cloud.xyz", 4000, 0.02);
    const std::string vdb = temp("eigen_budget.vdb"), json = temp("eigen_budget.json");
    Run r = run("spectrum " + cloud + " -k 4 --eigen-method lanczos --max-memory 250M -o " + vdb);
    INFO(r.err);
    CHECK(r.code == 1);
    CHECK_THAT(r.err, Catch::Contains("note: the band-voxel budget (--max-voxels 300000, the default of commands that solve "
                                      "for eigenpairs, docs/spectrum.md#budget) set the voxel size"));
    CHECK_FALSE(fs::exists(vdb));
    // A budget given is the budget used, named as given.
    r = run("spectrum " + cloud + " -k 4 --max-voxels 20000 -o " + vdb + " --report " + json);
    REQUIRE(r.code == 0);
    CHECK_THAT(r.err, Catch::Contains("note: the band-voxel budget (--max-voxels 20000) set the voxel size"));
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    CHECK(report["parameters"]["max_band_voxels"].get<double>() == 20000);
    CHECK(report["band"]["voxels"].get<double>() <= 1.3 * 20000);
    // info forecasts the band these commands build when asked --for them.
    const std::string forecast = temp("eigen_budget_info.json");
    r = run("info " + cloud + " --for spectrum --quiet --report " + forecast);
    REQUIRE(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("--max-voxels 300000"));
    CHECK(nlohmann::json::parse(std::ifstream(forecast))["forecast"]["max_band_voxels"].get<double>() == 3e5);
    // The defaults as --help shows them: the eigen solvers' commands 3e5, the others 4e6.
    for (const std::string command : {"spectrum", "regress"})
        CHECK_THAT(run(command + " --help").out, Catch::Contains("--max-voxels FLOAT=300000"));
    for (const std::string command : {"band", "green", "geodesic"})
        CHECK_THAT(run(command + " --help").out, Catch::Contains("--max-voxels FLOAT=4e+06"));
}

TEST_CASE("cli: info forecasts the default band, its voxel size exactly and its voxels within 25 %, or says it would be refused", "[cli]") {
    // (Its peak against the band's: the [memory] tests.)
    const std::string cloud = sphereCloud("forecast_cloud.xyz", 3000, 0.02);
    for (const std::string flags :
         {" --max-voxels 20000", " --max-voxels 20000 --voxel-values point", " --max-voxels 20000 --voxel-values voxel", " --sigma 1"}) {
        const std::string input = flags == " --sigma 1" ? gpisvdb::test::dataPath("bunny.obj") : cloud;
        INFO(input << flags);
        const std::string info = temp("forecast_info.json"), band = temp("forecast_band.json");
        const Run i = run("info " + input + flags + " --report " + info);
        INFO(i.err);
        REQUIRE(i.code == 0);
        CHECK_THAT(i.out, Catch::Contains("default band (what `gpisvdb band` with these flags would build"));
        CHECK_THAT(i.out, Catch::Contains("w_mu") && Catch::Contains("voxels:") && Catch::Contains("memory:") && Catch::Contains("time:"));
        REQUIRE(run("band " + input + flags + " -o " + temp("forecast.vdb") + " --report " + band + " --quiet").code == 0);
        const nlohmann::json f = nlohmann::json::parse(std::ifstream(info))["forecast"];
        const nlohmann::json b = nlohmann::json::parse(std::ifstream(band));
        CHECK(f["voxel_size"].get<double>() == b["parameters"]["voxel_size"].get<double>());
        CHECK(f["voxel_size_by_budget"].get<bool>() == b["parameters"]["voxel_size_by_budget"].get<bool>());
        CHECK(f["smoothing"].get<double>() == b["parameters"]["smoothing"].get<double>());
        CHECK(f["voxels"].get<double>() == Approx(b["band"]["voxels"].get<double>()).epsilon(0.25));
        CHECK(f["peak_bytes"].get<double>() > 0);
        CHECK(f["seconds"].get<double>() > f["band_seconds"].get<double>());
        CHECK(f["band_seconds"].get<double>() > 0);
    }
    // A band that would be refused is forecast as refused (info succeeds); --no-forecast builds no model.
    Run r = run("info " + cloud + " --voxel-size 0.0001");
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("default band: refused: the band would need about"));
    r = run("info " + cloud + " --no-forecast");
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("samples:      3000"));
    CHECK_THAT(r.out, !Catch::Contains("default band"));
}
