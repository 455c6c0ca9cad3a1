#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <tbb/global_control.h>
#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkSTLWriter.h>
#include <vtkXMLPolyDataWriter.h>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"
#include "helpers.h"

using namespace gpisvdb;
namespace fs = std::filesystem;

namespace {

std::string tempFile(const std::string& name, const std::string& content) {
    const fs::path p = gpisvdb::test::scratchDir() / ("gpisvdb_test_" + name);
    std::ofstream(p, std::ios::binary) << content;
    return p.string();
}

std::string errorOf(const std::string& path) {
    try {
        readInput(path);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("input: the shared meshes and cloud read with the expected counts", "[input]") {
    const InputData bunny = readInput(test::dataPath("bunny.obj"));
    REQUIRE(bunny.soup);
    CHECK(bunny.soup->triangles.size() == 3674);
    const InputData elephant = readInput(test::dataPath("elephant.off"));
    REQUIRE(elephant.soup);
    CHECK(elephant.soup->vertices.size() == 2775);
    CHECK(elephant.soup->triangles.size() == 5558);
    const InputData cloud = readInput(test::dataPath("sphere_20k_normal.xyz"));
    REQUIRE(cloud.cloud);
    CHECK(cloud.cloud->positions.size() == cloud.cloud->normals.size());
    CHECK(cloud.cloud->positions.size() > 20000);
}

TEST_CASE("input: polygons are fan-triangulated and counted", "[input]") {
    const std::string obj = tempFile("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    const InputData d = readInput(obj);
    CHECK(d.soup->triangles.size() == 2);
    CHECK(d.polygonsTriangulated == 1);
    const std::string off = tempFile("pent.off", "OFF\n5 1 0\n0 0 0\n1 0 0\n1.5 1 0\n0.5 1.5 0\n-0.5 1 0\n5 0 1 2 3 4\n");
    CHECK(readInput(off).soup->triangles.size() == 3);
}

TEST_CASE("input: PLY ascii and binary, meshes and clouds with sigma, give the same data", "[input]") {
    const std::string ascii = tempFile("cloud.ply",
                                       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                       "property float nx\nproperty float ny\nproperty float nz\nproperty double sigma\nend_header\n"
                                       "0 0 0 0 0 1 0.1\n1 0 0 0 0 1 0.2\n0 1 0 0 0 2 0.3\n");
    const InputData a = readInput(ascii);
    REQUIRE(a.cloud);
    CHECK(a.cloud->sigmas == std::vector<double>{0.1, 0.2, 0.3});
    CHECK(a.cloud->normals[2] == Vec3d(0, 0, 2));

    std::string bin =
        "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
        "property double z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const double v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    bin.append(reinterpret_cast<const char*>(v), sizeof v);
    const unsigned char n = 3;
    const int f[3] = {0, 1, 2};
    bin.append(reinterpret_cast<const char*>(&n), 1).append(reinterpret_cast<const char*>(f), sizeof f);
    const InputData b = readInput(tempFile("tri.ply", bin));
    REQUIRE(b.soup);
    CHECK(b.soup->triangles.size() == 1);
    CHECK(b.soup->vertices[1] == Vec3d(1, 0, 0));
}

TEST_CASE("input: STL and VTP written by VTK read back", "[input]") {
    const TriangleSoup ico = icosphere(1);
    auto pd = vtkSmartPointer<vtkPolyData>::New();
    auto pts = vtkSmartPointer<vtkPoints>::New();
    for (const auto& p : ico.vertices) pts->InsertNextPoint(p.data());
    auto polys = vtkSmartPointer<vtkCellArray>::New();
    for (const auto& t : ico.triangles) {
        const vtkIdType ids[3] = {t[0], t[1], t[2]};
        polys->InsertNextCell(3, ids);
    }
    pd->SetPoints(pts);
    pd->SetPolys(polys);
    const std::string stl = (gpisvdb::test::scratchDir() / "gpisvdb_test_ico.stl").string();
    auto sw = vtkSmartPointer<vtkSTLWriter>::New();
    sw->SetFileName(stl.c_str());
    sw->SetInputData(pd);
    sw->SetFileTypeToBinary();
    sw->Write();
    CHECK(readInput(stl).soup->triangles.size() == ico.triangles.size());

    // A cloud: points with Normals and a sigma array.
    auto cloud = vtkSmartPointer<vtkPolyData>::New();
    cloud->SetPoints(pts);
    auto normals = vtkSmartPointer<vtkDoubleArray>::New();
    normals->SetNumberOfComponents(3);
    normals->SetName("Normals");
    auto sigma = vtkSmartPointer<vtkDoubleArray>::New();
    sigma->SetName("sigma");
    for (const auto& p : ico.vertices) normals->InsertNextTuple(p.data()), sigma->InsertNextValue(0.05);
    cloud->GetPointData()->SetNormals(normals);
    cloud->GetPointData()->AddArray(sigma);
    const std::string vtp = (gpisvdb::test::scratchDir() / "gpisvdb_test_cloud.vtp").string();
    auto xw = vtkSmartPointer<vtkXMLPolyDataWriter>::New();
    xw->SetFileName(vtp.c_str());
    xw->SetInputData(cloud);
    xw->Write();
    const InputData c = readInput(vtp);
    REQUIRE(c.cloud);
    CHECK(c.cloud->normals.size() == ico.vertices.size());
    CHECK(c.cloud->sigmas.size() == ico.vertices.size());
}

TEST_CASE("input: bad files give one clear InputError", "[input]") {
    CHECK_THAT(errorOf("/nonexistent/mesh.obj"), Catch::Contains("no such file"));
    CHECK_THAT(errorOf(tempFile("x.abc", "1 2 3")), Catch::Contains("unknown extension"));
    CHECK_THAT(errorOf(tempFile("empty.obj", "")), Catch::Contains("empty"));
    CHECK_THAT(errorOf(tempFile("binary.obj", std::string("\x89PNG\r\n\x1a\n\0\0", 10))), Catch::Contains("binary"));
    CHECK_THAT(errorOf(tempFile("cloud_as.obj", "0 0 0 0 0 1\n")), Catch::Contains("not an OBJ"));
    CHECK_THAT(errorOf(tempFile("mesh_as.off", "v 0 0 0\n")), Catch::Contains("not an OFF"));
    CHECK_THAT(errorOf(tempFile("text.ply", "hello\n")), Catch::Contains("not a PLY"));
    CHECK_THAT(errorOf(tempFile("text.stl", "solid x\nthis is not stl\n")), Catch::Contains("STL"));
    CHECK_THAT(errorOf(tempFile("text.vtp", "<VTKFile>")), Catch::Contains("VTP"));
    CHECK_THAT(errorOf(tempFile("nan.obj", "v 0 nan 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")), Catch::Contains("non-finite"));
    CHECK_THAT(errorOf(tempFile("inf.xyz", "0 0 inf 0 0 1\n1 0 0 0 0 1\n")), Catch::Contains("non-finite"));
    CHECK_THAT(errorOf(tempFile("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")), Catch::Contains("out of range"));
    CHECK_THAT(errorOf(tempFile("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n")), Catch::Contains("out of range"));
    CHECK_THAT(errorOf(tempFile("nonormals.xyz", "0 0 0\n1 0 0\n")), Catch::Contains("no normals"));
    CHECK_THAT(errorOf(tempFile("nonormals.ply",
                                "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                "property float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n")),
               Catch::Contains("no normals"));
    CHECK_THAT(errorOf(tempFile("nofaces.obj", "v 0 0 0\n")), Catch::Contains("no faces"));
    CHECK_THAT(errorOf(tempFile("short.off", "OFF\n3 1 0\n0 0 0\n")), Catch::Contains("ends early"));
}

TEST_CASE("input: zero-area triangles are skipped and counted", "[input]") {
    TriangleSoup s = icosphere(1);
    s.triangles.push_back({0, 0, 1});  // repeated vertex
    s.vertices.push_back({2, 0, 0});
    s.vertices.push_back({3, 0, 0});
    s.vertices.push_back({4, 0, 0});
    const int nv = int(s.vertices.size());
    s.triangles.push_back({nv - 3, nv - 2, nv - 1});  // collinear
    const SoupSamples ss = soupSamples(s, {0.5});
    CHECK(ss.degenerateSkipped == 2);
    CHECK(ss.samples.size() == icosphere(1).triangles.size());
    TriangleSoup flat;
    flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    flat.triangles = {{0, 1, 2}};
    CHECK_THROWS_AS(soupSamples(flat, {0.5}), InputError);
}

TEST_CASE("input: sigma <= 0 is refused for soups and clouds", "[input]") {
    CHECK_THROWS_AS(soupSamples(icosphere(1), {0.0}), ParameterError);
    CHECK_THROWS_AS(soupSamples(icosphere(1), {-1.0}), ParameterError);
    PointCloud c;
    c.positions = {{0, 0, 0}, {1, 0, 0}};
    c.normals = {{0, 0, 1}, {0, 0, 1}};
    CloudNoiseOptions o;
    o.sigmaRel = 0;
    CHECK_THROWS_AS(cloudSamples(c, o), ParameterError);
}

TEST_CASE("input: App. B covariances match Monte-Carlo of a perturbed triangle", "[input]") {
    TriangleSoup t;
    t.vertices = {{0.1, -0.2, 0.3}, {1.2, 0.1, -0.1}, {0.3, 0.9, 0.4}};
    t.triangles = {{0, 1, 2}};
    const double sigmaRel = 0.03;
    const SoupSamples ss = soupSamples(t, {sigmaRel});
    const double sigma = ss.sigma;
    std::mt19937_64 rng(42);
    std::normal_distribution<double> N(0, sigma);
    const int K = 200000;
    Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> mean = Eigen::Matrix<double, 6, 1>::Zero();
    std::vector<Eigen::Matrix<double, 6, 1>> draws(K);
    for (int k = 0; k < K; ++k) {
        Vec3d x[3];
        for (int v = 0; v < 3; ++v) x[v] = t.vertices[v] + Vec3d(N(rng), N(rng), N(rng));
        draws[k].head<3>() = (x[0] + x[1] + x[2]) / 3.0 - ss.samples.position[0];
        draws[k].tail<3>() = 0.5 * (x[1] - x[0]).cross(x[2] - x[0]) - ss.samples.normal[0];
        mean += draws[k] / K;
    }
    for (const auto& d : draws) cov += (d - mean) * (d - mean).transpose() / (K - 1);
    Eigen::Matrix<double, 6, 6> model = Eigen::Matrix<double, 6, 6>::Zero();
    model.topLeftCorner<3, 3>() = ss.samples.positionVariance[0] * Mat3d::Identity();
    model.bottomRightCorner<3, 3>() = ss.samples.normalCovariance[0].matrix();
    // The vector area is quadratic in the noise: its covariance gains a σ⁴ term the linear model leaves out
    // (relative size ~ σ²/area); Monte-Carlo error ~ 1/√K.
    const double scale = model.diagonal().maxCoeff();
    INFO("model\n" << model << "\nmonte carlo\n" << cov);
    CHECK((cov - model).cwiseAbs().maxCoeff() <= 0.01 * scale);
    CHECK(cov.topRightCorner<3, 3>().cwiseAbs().maxCoeff() <= 0.01 * scale);  // cross terms cancel
}

TEST_CASE("input: cloud samples carry area-weighted normals and per-point sigma", "[input]") {
    const InputData d = readInput(test::dataPath("sphere_20k_normal.xyz"));
    const CloudSamples cs = cloudSamples(*d.cloud);
    double area = 0;
    for (const auto& w : cs.samples.normal) area += w.norm();
    // The cloud samples the unit sphere: the estimated areas add up to about 4π.
    CHECK(area == Approx(4 * M_PI).epsilon(0.15));
    CHECK(cs.samples.lengthScale > 0);
    for (std::size_t i = 0; i < cs.samples.size(); i += 997) {
        const Vec3d n = cs.samples.normal[i].normalized();
        CHECK(std::abs(n.dot(cs.samples.normalCovariance[i].matrix() * n)) < 1e-12);  // tangential only
    }
}

TEST_CASE("input: a cloud's length scale is sqrt(area / points), on scan lines as on random and even samplings", "[input]") {
    // A scanner's lines put every near neighbour on the point's own line, so the mean nearest-neighbour distance
    // (ℓ before) is the spacing along the lines, 10× below the surface's spacing on the 10:1 scan.
    const double torusArea = 4 * M_PI * M_PI * 3.0;
    for (const double ratio : {1.0, 3.0, 10.0, 30.0}) {
        const double across = std::sqrt(torusArea / 20000 * ratio), along = across / ratio;
        const PointCloud c = scanLineTorus(along, across);
        const CloudSamples cs = cloudSamples(c);
        const double truth = std::sqrt(torusArea / double(c.positions.size()));
        double area = 0;
        for (const auto& w : cs.samples.normal) area += w.norm();
        INFO("across / along " << ratio << ": points " << c.positions.size() << ", area " << area);
        CHECK(cs.samples.lengthScale == Approx(truth).epsilon(0.2));
        CHECK(area == Approx(torusArea).epsilon(0.2));
    }
    std::mt19937_64 rng(3);
    std::normal_distribution<double> g;
    PointCloud random;
    for (int i = 0; i < 20000; ++i) {
        const Vec3d d = Vec3d(g(rng), g(rng), g(rng)).normalized();
        random.positions.push_back(d);
        random.normals.push_back(d);
    }
    CHECK(cloudSamples(random).samples.lengthScale == Approx(std::sqrt(4 * M_PI / 20000)).epsilon(0.1));
    PointCloud lattice;  // even: a Fibonacci lattice
    for (int i = 0; i < 20000; ++i) {
        const double z = 1 - (2 * i + 1) / 20000.0, r = std::sqrt(1 - z * z), a = M_PI * (3 - std::sqrt(5.0)) * i;
        lattice.positions.emplace_back(r * std::cos(a), r * std::sin(a), z);
        lattice.normals.push_back(lattice.positions.back());
    }
    CHECK(cloudSamples(lattice).samples.lengthScale == Approx(std::sqrt(4 * M_PI / 20000)).epsilon(0.05));
    // An outlier's area is that of the empty space around it; 1 % of them leave ℓ within 10 %.
    std::uniform_real_distribution<double> box(-2, 2);
    for (int i = 0; i < 200; ++i) {
        random.positions.emplace_back(box(rng), box(rng), box(rng));
        random.normals.emplace_back(0, 0, 1);
    }
    CHECK(cloudSamples(random).samples.lengthScale == Approx(std::sqrt(4 * M_PI / 20000)).epsilon(0.1));
}

TEST_CASE("input: the cylinder grows only across scan lines: a random cloud's areas are those of the fixed cylinder", "[input]") {
    const InputData d = readInput(test::dataPath("sphere_20k_normal.xyz"));
    CloudNoiseOptions fixed;
    fixed.areaDoublings = 0;
    const Samples a = cloudSamples(*d.cloud).samples, b = cloudSamples(*d.cloud, fixed).samples;
    std::size_t same = 0;
    for (std::size_t i = 0; i < a.size(); ++i) same += a.normal[i] == b.normal[i];
    CHECK(double(same) >= 0.99 * double(a.size()));
}

TEST_CASE("input: a cloud's areas and length scale are identical for 1 and 2 threads", "[input]") {
    const PointCloud c = scanLineTorus(0.02, 0.2);
    const auto with = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        return cloudSamples(c).samples;
    };
    const Samples one = with(1), two = with(2);
    CHECK(one.lengthScale == two.lengthScale);
    CHECK(one.normal == two.normal);
}

TEST_CASE("input: the cylinder's growth is bounded: points on one line end, and bad growth options are refused", "[input]") {
    PointCloud line;
    for (int i = 0; i < 200; ++i) {
        line.positions.emplace_back(0.01 * i, 0, 0);
        line.normals.emplace_back(0, 0, 1);
    }
    const CloudSamples cs = cloudSamples(line);  // never isotropic: stops after areaDoublings
    CHECK(std::isfinite(cs.samples.lengthScale));
    CHECK(cs.samples.lengthScale > 0);
    CloudNoiseOptions o;
    o.areaDoublings = -1;
    CHECK_THROWS_AS(cloudSamples(line, o), ParameterError);
    o = {};
    o.areaIsotropy = 2;
    CHECK_THROWS_AS(cloudSamples(line, o), ParameterError);
    o = {};
    o.areaGrowthPoints = 0;
    CHECK_THROWS_AS(cloudSamples(line, o), ParameterError);
}

TEST_CASE("input: a cylinder never covered keeps its first area: a patch's corners and a strip's ends as the fixed cylinder's", "[input]") {
    // A quarter disc (a corner) and a strip three points wide stay anisotropic however large the cylinder: growing
    // there would only count more of the same shape (an area up to 10× or 190× too large, measured before the rule).
    CloudNoiseOptions fixed;
    fixed.areaDoublings = 0;
    for (const int width : {40, 3}) {
        PointCloud patch;
        for (int i = 0; i < 40; ++i)
            for (int j = 0; j < width; ++j) {
                patch.positions.emplace_back(0.1 * i, 0.1 * j, 0);
                patch.normals.emplace_back(0, 0, 1);
            }
        const Samples grown = cloudSamples(patch).samples, first = cloudSamples(patch, fixed).samples;
        INFO("width " << width);
        CHECK(grown.normal == first.normal);
        CHECK(grown.lengthScale == first.lengthScale);
    }
    // Two points: one line, the first cylinder.
    PointCloud two;
    two.positions = {Vec3d(0, 0, 0), Vec3d(1, 0, 0)};
    two.normals = {Vec3d(0, 0, 1), Vec3d(0, 0, 1)};
    CHECK(cloudSamples(two).samples.lengthScale == cloudSamples(two, fixed).samples.lengthScale);
}

TEST_CASE("input: a cloud's given areas are checked: their count, NaN and negative values", "[input]") {
    PointCloud c = scanLineTorus(0.1, 0.1);
    c.areas.assign(c.positions.size() - 1, 0.01);
    CHECK_THROWS_WITH(cloudSamples(c), Catch::Contains("areas for"));
    c.areas.assign(c.positions.size(), 0.01);
    c.areas[5] = std::nan("");
    CHECK_THROWS_WITH(cloudSamples(c), Catch::Contains("point 6 has an area"));
    c.areas[5] = -1;
    CHECK_THROWS_WITH(cloudSamples(c), Catch::Contains("point 6 has an area"));
    c.areas.assign(c.positions.size(), 0.0);
    CHECK_THROWS_WITH(cloudSamples(c), Catch::Contains("areas are all 0"));
    c.areas.clear();
    c.normals[0] = Vec3d::Zero();
    CHECK_THROWS_WITH(cloudSamples(c), Catch::Contains("point 1 has a zero normal"));
}
