// End-to-end tests of the gpisvdb program: exit codes, one-line errors, no partial outputs.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>
#include <vtkDataArray.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include "gpisvdb/output/mean_surface.h"
#include "cli_run.h"
#include "gpisvdb/input/read_input.h"
#include "png_stats.h"
#include "helpers.h"

namespace fs = std::filesystem;

using namespace gpisvdb::test::cli;

TEST_CASE("cli: info describes the bunny", "[cli]") {
    const Run r = run("info " + gpisvdb::test::dataPath("bunny.obj"));
    CHECK(r.code == 0);
    CHECK_THAT(r.out, Catch::Contains("samples:      3674"));
    CHECK_THAT(r.out, Catch::Contains("length scale"));
}

TEST_CASE("cli: evaluate writes one row per query point with the documented header", "[cli]") {
    const std::string pts = temp("pts.xyz", "0 0 0\n0.5,0.5,0.5\n# comment\n3 3 3\n");
    const std::string out = temp("values.csv");
    fs::remove(out);
    const Run r = run("evaluate " + gpisvdb::test::dataPath("bunny.obj") + " --at " + pts + " -o " + out + " --quiet");
    REQUIRE(r.code == 0);
    std::ifstream in(out);
    std::string header;
    std::getline(in, header);
    CHECK(header == "x,y,z,gamma,gx,gy,gz,c00,c01,c02,c03,c11,c12,c13,c22,c23,c33,mu,Txx,Txy,Txz,Tyy,Tyz,Tzz");
    std::string row;
    int rows = 0;
    while (std::getline(in, row)) {
        ++rows;
        CHECK(std::count(row.begin(), row.end(), ',') == 23);
    }
    CHECK(rows == 3);
}

TEST_CASE("cli: exact and Barnes-Hut evaluate agree to the stated accuracy", "[cli]") {
    const std::string pts = temp("pts2.xyz", "0 0 0\n-0.5 1 2.5\n");
    const std::string a = temp("bh.csv"), b = temp("exact.csv");
    const std::string in = gpisvdb::test::dataPath("bunny.obj");
    REQUIRE(run("evaluate " + in + " --at " + pts + " -o " + a).code == 0);
    REQUIRE(run("evaluate " + in + " --at " + pts + " -o " + b + " --exact --threads 1").code == 0);
    std::ifstream fa(a), fb(b);
    std::string la, lb;
    std::getline(fa, la), std::getline(fb, lb);
    while (std::getline(fa, la) && std::getline(fb, lb)) {
        std::stringstream sa(la), sb(lb);
        std::string ta, tb;
        for (int col = 0; std::getline(sa, ta, ',') && std::getline(sb, tb, ','); ++col)
            if (col == 3) CHECK(std::stod(ta) == Approx(std::stod(tb)).margin(1e-3));  // γ
    }
}

TEST_CASE("cli: bad input and parameters give one line on stderr, a non-zero exit and no output", "[cli]") {
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
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --sigma 0", "--sigma"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --sigma -1", "--sigma"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --smoothing 0", "--smoothing"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --beta 0.5", "--beta"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --threads -2", "--threads"},
        {"evaluate " + bunny + " --at " + temp("q.xyz", "0 0 x\n") + " -o " + out, "not a finite number"},
        {"evaluate " + bunny + " --at " + pts + " -o /nonexistent-dir/out.csv", "does not exist"},
        {"info " + temp("nan.xyz", "0 0 0 0 0 1\n1 nan 0 0 0 1\n"), "non-finite"},
        {"evaluate " + bunny + " --at " + pts + " -o " + out + " --qmc 0", "--qmc"},
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
        {"spectrum " + bunny + " -k 0 -o " + vdb, "-k"},
        {"spectrum " + bunny + " -k 100000 -o " + vdb + " --voxel-size 0.4 --sigma 2", "between 1 and"},
        {"spectrum " + bunny + " -k 200 -o " + vdb + " --voxel-size 0.4 --sigma 2 --max-memory 20M", "eigenpairs of a band"},
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
        {"hodge " + bunny + " --preset mixed --tolerance -1 -o " + vdb, "--tolerance"},
    };
    for (const Case& c : cases) {
        fs::remove(out);
        const Run r = run(c.args);
        INFO(c.args << "\nstderr: " << r.err);
        CHECK(r.code == 1);
        CHECK(lines(r.err) == 1);
        CHECK_THAT(r.err, Catch::Contains(c.expect));
        CHECK_FALSE(leftovers(out));
        CHECK_FALSE(leftovers(vdb));
    }
}

TEST_CASE("cli: usage errors exit 2; --help and --version exit 0", "[cli]") {
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

TEST_CASE("cli: band writes a readable .vdb and a JSON report with the documented fields", "[cli]") {
    const std::string vdb = temp("bunny.vdb"), json = temp("bunny.json");
    const Run r = run("band " + gpisvdb::test::dataPath("bunny.obj") + " -o " + vdb + " --report " + json +
                      " --sigma 2 --voxel-size 0.4 --quiet --threads 2");
    INFO(r.err);
    REQUIRE(r.code == 0);
    std::ifstream in(json);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string report = ss.str();
    for (const char* key : {"\"voxels\"", "\"voxel_size\"", "\"bbox_voxels\"", "\"mass\"", "\"max_stencil_l1\"",
                            "\"sigma_rel\"", "\"sigma\"", "\"model\"", "\"band\"", "\"total\"", "\"peak_rss_bytes\"",
                            "\"band_bytes_per_voxel\""})
        CHECK_THAT(report, Catch::Contains(key));
    const int status = std::system(("vdb_print " + vdb + " > /dev/null 2>&1").c_str());
    CHECK(WEXITSTATUS(status) == 0);
}

TEST_CASE("cli: green writes the band grids and 'green', with solver fields in the report", "[cli]") {
    const std::string vdb = temp("green.vdb"), json = temp("green.json");
    const Run r = run("green " + gpisvdb::test::dataPath("bunny.obj") + " --source 0.5,6,1 -o " + vdb + " --report " + json +
                      " --sigma 2 --voxel-size 0.4 --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    std::ifstream in(json);
    std::stringstream ss;
    ss << in.rdbuf();
    for (const char* key : {"\"iterations\"", "\"relative_residual\"", "\"operators\"", "\"solve\""})
        CHECK_THAT(ss.str(), Catch::Contains(key));
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

TEST_CASE("cli: hodge writes vec3 parts that sum to the input, and reads a field back from a .vdb", "[cli]") {
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
    file.close();
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

TEST_CASE("cli: distance writes a dense smoothed_distance grid, a level set and its mesh", "[cli]") {
    const std::string vdb = temp("distance.vdb"), json = temp("distance.json"), ply = temp("offset.ply");
    const Run r = run("distance " + gpisvdb::test::dataPath("bunny.obj") + " --alpha 5 --grid-voxel-size 0.5 --level 0.3 --mesh " +
                      ply + " -o " + vdb + " --report " + json + " --sigma 2 --voxel-size 0.4 --quiet");
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
    CHECK(std::ifstream(ply).good());
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
    const Run fromFile = run("band " + cloud + " --model regression --labels " + temp("labels.csv", labels) +
                             " --voxel-size 0.08 -o " + vdb + " --quiet");
    INFO(fromFile.err);
    CHECK(fromFile.code == 0);
}

TEST_CASE("cli: spectrum writes eigen_000 ... with ascending eigenvalues and small residuals in the report", "[cli]") {
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
    const auto e0 = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("eigen_000"));
    CHECK(e0->activeVoxelCount() == report["band"]["voxels"].get<openvdb::Index64>());
    file.close();
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
    const Run r = run("regress " + gpisvdb::test::dataPath("bunny.obj") + " --data " + temp("regress.csv", csv) +
                      " -k 30 --nu 2.5 -o " + vdb + " --report " + json + " --sigma 2 --voxel-size 0.4 --quiet");
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
    CHECK(report["spectrum"]["eigenvalues"].size() == 30);
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

TEST_CASE("cli: geodesic writes 'geodesic' and a bunny path between far points that keeps near the mean surface", "[cli]") {
    const std::string vdb = temp("geo.vdb"), json = temp("geo.json"), paths = temp("geo_paths.json"), obj = temp("geo_paths.obj"),
                      vtp = temp("geo_paths.vtp");
    const std::string common = "geodesic " + gpisvdb::test::dataPath("bunny.obj") +
                               " --source 0.5,6,1 --target -2,9,0 --target 3,4,-2 --sigma 0.5 --voxel-size 0.15 --quiet";
    const Run r = run(common + " -o " + vdb + " --report " + json + " --paths " + paths);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(json));
    CHECK(report["geodesic"]["unreached"] == 0);
    CHECK(report["geodesic"]["reached"] == report["band"]["voxels"]);
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
    // U is 0 at the source voxel; every band voxel was reached, so every one is active
    const auto& s = report["geodesic"]["sources"][0]["voxel"];
    CHECK(geodesic->tree().getValue(openvdb::Coord(s[0].get<int>(), s[1].get<int>(), s[2].get<int>())) == 0);
    CHECK(geodesic->activeVoxelCount() == report["band"]["voxels"].get<openvdb::Index64>());

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
    const std::vector<std::string> commands = {"info", "evaluate", "demo", "band", "green", "spectrum", "regress",
                                               "geodesic", "hodge", "distance", "mesh", "render", "sample"};
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
    // At the default voxel size the bunny's band has ~1.5 M voxels: minutes of work, interrupted after one second.
    const std::vector<std::pair<std::string, std::string>> commands = {
        {"band", ""}, {"green", "--source 0.5,6,1"}, {"geodesic", "--source 0.5,6,1"}, {"spectrum", "-k 4"},
        {"hodge", "--preset mixed"}, {"distance", "--alpha 20"}, {"regress", "--data " + temp("int.csv", "0,6,0,1\n")}};
    for (const auto& [command, flags] : commands) {
        INFO(command);
        fs::remove(vdb);
        const Run r = runInterrupted(command + " " + bunny + " " + flags + " -o " + vdb + " --report " + json + " --quiet", 1);
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
    const Run r = run("render " + s.vdb + " --grid geodesic --paths " + s.paths + " --size 300,240 -o " + png + " --quiet");
    INFO(r.err);
    REQUIRE(r.code == 0);
    gpisvdb::test::PngStats st = gpisvdb::test::pngStats(png);
    REQUIRE(st.readable);
    CHECK(st.width == 300);
    CHECK(st.height == 240);
    CHECK(st.colours > 100);
    CHECK(st.nonWhite > 0.1);
    const Run sliced = run("render " + s.vdb + " --grid mu --log --colormap magma --slice z=0.5 --size 300,240 -o " + png + " --quiet");
    INFO(sliced.err);
    REQUIRE(sliced.code == 0);
    st = gpisvdb::test::pngStats(png);
    CHECK(st.width == 600);
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
    CHECK(worst > 0);       // the values were rounded ...
    CHECK(worst < 2e-3);    // ... to half precision (2^-11 relative)
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
