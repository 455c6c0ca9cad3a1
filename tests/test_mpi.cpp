// gpisvdb-mpi under mpirun (docs/mpi.md): the distributed band equals the one-process band to the bit for any rank
// count, the PETSc Green's function equals gpisvdb green within the tolerance, ranks are balanced, and an error on
// one rank ends every rank with one message and no output. Built only with gpisvdb-mpi (tests/CMakeLists.txt).
#include <catch2/catch.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <functional>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <chrono>
#include <fstream>
#include <map>
#include <sstream>

#include "cli_run.h"

using namespace gpisvdb::test::cli;

namespace {

/// gpisvdb-mpi on `ranks` processes (oversubscribing the cores is fine; each rank runs one thread).
Run runMpi(int ranks, const std::string& args) {
    const std::string root = geteuid() == 0 ? " --allow-run-as-root" : "";
    return runShell(std::string(GPISVDB_MPIEXEC) + root + " --oversubscribe -n " + std::to_string(ranks) + " " + GPISVDB_MPI_EXE + " " +
                    args + " --threads 1");
}

/// Every active voxel of every float and vec3 grid: name → (coordinate → components).
using Grids = std::map<std::string, std::map<openvdb::Coord, std::vector<float>>>;
Grids readGrids(const std::string& path) {
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open();
    Grids out;
    const openvdb::GridPtrVecPtr grids = file.getGrids();
    for (const auto& base : *grids) {
        auto& g = out[base->getName()];
        if (auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(base))
            for (auto it = f->cbeginValueOn(); it; ++it) g[it.getCoord()] = {*it};
        else if (auto v = openvdb::gridPtrCast<openvdb::Vec3fGrid>(base))
            for (auto it = v->cbeginValueOn(); it; ++it) g[it.getCoord()] = {(*it)[0], (*it)[1], (*it)[2]};
    }
    file.close();
    return out;
}

nlohmann::json readJson(const std::string& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

double spread(const std::vector<std::size_t>& counts) {
    const auto [lo, hi] = std::minmax_element(counts.begin(), counts.end());
    double mean = 0;
    for (std::size_t c : counts) mean += double(c) / double(counts.size());
    return double(*hi - *lo) / mean;
}

const std::string kBunny = gpisvdb::test::dataPath("bunny.obj") + " --sigma 1 --voxel-size 0.15 --quiet";

}  // namespace

TEST_CASE("mpi: the band on 1, 2 and 3 ranks equals gpisvdb band to the bit, every grid and the stencils", "[mpi]") {
    const std::string one = temp("mpi_band_one.vdb");
    REQUIRE(run("band " + kBunny + " --stencils -o " + one).code == 0);
    const Grids expected = readGrids(one);
    REQUIRE(expected.count("mu"));
    for (const int ranks : {1, 2, 3}) {
        const std::string out = temp("mpi_band_" + std::to_string(ranks) + ".vdb"), report = temp("mpi_band.json");
        const Run r = runMpi(ranks, "band " + kBunny + " --stencils -o " + out + " --report " + report);
        INFO(r.err);
        REQUIRE(r.code == 0);
        const Grids got = readGrids(out);
        CHECK(got.size() == expected.size());
        for (const auto& [name, voxels] : expected) {
            INFO(name << " on " << ranks << " ranks");
            CHECK(got.count(name));
            if (got.count(name)) CHECK(got.at(name) == voxels);
        }
        const nlohmann::json j = readJson(report);
        const auto counts = j["mpi"]["voxels_per_rank"].get<std::vector<std::size_t>>();
        CHECK(int(counts.size()) == ranks);
        std::size_t total = 0;
        for (std::size_t c : counts) total += c;
        CHECK(total == expected.at("mu").size());
        CHECK(j["band"]["voxels"].get<std::size_t>() == total);
        CHECK(*std::max_element(counts.begin(), counts.end()) - *std::min_element(counts.begin(), counts.end()) <= 1);
    }
}

TEST_CASE("mpi: the search partition from the samples' areas balances the band within 10% on the bunny and a sphere", "[mpi]") {
    for (const std::string& input :
         {kBunny, gpisvdb::test::dataPath("sphere_20k_normal.xyz") + " --sigma 1 --resolution-scale 2 --quiet"}) {
        const std::string out = temp("mpi_balance.vdb"), report = temp("mpi_balance.json");
        const Run r = runMpi(2, "band " + input + " -o " + out + " --report " + report);
        INFO(input << "\n" << r.err);
        REQUIRE(r.code == 0);
        const nlohmann::json j = readJson(report);
        const auto search = j["mpi"]["search_voxels_per_rank"].get<std::vector<std::size_t>>();
        INFO(j["mpi"].dump());
        CHECK(spread(search) <= 0.10);
        CHECK(j["mpi"]["bytes_exchanged"].get<double>() > 0);
    }
}

TEST_CASE("mpi: the PETSc Green's function equals gpisvdb green within the tolerance, with either preconditioner", "[mpi]") {
    const std::string args = kBunny + " --source 0.5,6,1 --tolerance 1e-9";
    const std::string one = temp("mpi_green_one.vdb");
    REQUIRE(run("green " + args + " -o " + one).code == 0);
    const auto expected = readGrids(one).at("green");
    float scale = 0;
    for (const auto& [c, v] : expected) scale = std::max(scale, std::abs(v[0]));
    REQUIRE(scale > 0);
    for (const std::string preconditioner : {"multigrid", "Jacobi"}) {
        const std::string out = temp("mpi_green.vdb"), report = temp("mpi_green.json");
        const Run r = runMpi(2, "green " + args + " --preconditioner " + (preconditioner == "Jacobi" ? "jacobi" : preconditioner) + " -o " +
                                    out + " --report " + report);
        INFO(preconditioner << "\n" << r.err);
        REQUIRE(r.code == 0);
        const auto got = readGrids(out).at("green");
        REQUIRE(got.size() == expected.size());
        double worst = 0;
        for (const auto& [c, v] : expected) worst = std::max(worst, double(std::abs(got.at(c)[0] - v[0])));
        CHECK(worst <= 1e-5 * scale);
        const nlohmann::json j = readJson(report);
        CHECK(j["solver"]["relative_residual"].get<double>() <= 1e-9);
        CHECK(j["solver"]["preconditioner"] == preconditioner);
        CHECK(j["mpi"]["halo_unknowns"].get<std::size_t>() > 0);
    }
}

TEST_CASE("mpi: SLEPc's eigenpairs (MUMPS shift-invert and LOBPCG) equal gpisvdb spectrum's on 2 ranks", "[mpi]") {
    const std::string args = kBunny + " -k 6";
    const std::string one = temp("mpi_spectrum_one.vdb"), oneReport = temp("mpi_spectrum_one.json");
    REQUIRE(run("spectrum " + args + " -o " + one + " --report " + oneReport).code == 0);
    const auto expected = readJson(oneReport)["spectrum"]["eigenvalues"].get<std::vector<double>>();
    const Grids expectedGrids = readGrids(one);
    for (const std::string method : {"lanczos", "lobpcg"}) {
        const std::string out = temp("mpi_spectrum.vdb"), report = temp("mpi_spectrum.json");
        const Run r = runMpi(2, "spectrum " + args + " --eigen-method " + method + " -o " + out + " --report " + report);
        INFO(method << "\n" << r.err);
        REQUIRE(r.code == 0);
        const nlohmann::json j = readJson(report)["spectrum"];
        const auto values = j["eigenvalues"].get<std::vector<double>>();
        REQUIRE(values.size() == expected.size());
        for (std::size_t i = 0; i < values.size(); ++i) CHECK(std::abs(values[i] / expected[i] - 1) <= 1e-8);
        CHECK(j["orthonormality_error"].get<double>() <= 1e-10);
        for (const double residual : j["residuals"].get<std::vector<double>>()) CHECK(residual <= 1e-8);
        // The bunny's lowest eigenvalues are simple: each vector is determined up to the sign both fix alike
        const Grids got = readGrids(out);
        for (int i = 0; i < 6; ++i) {
            const std::string name = "eigen_00" + std::to_string(i);
            double worst = 0, scale = 0;
            for (const auto& [c, v] : expectedGrids.at(name)) {
                worst = std::max(worst, double(std::abs(got.at(name).at(c)[0] - v[0])));
                scale = std::max(scale, double(std::abs(v[0])));
            }
            INFO(name);
            CHECK(worst <= 1e-5 * scale);
        }
    }
}

TEST_CASE("mpi: geodesic (marched on rank 0) equals gpisvdb geodesic to the bit, paths included, and regress within the eigen tolerance",
          "[mpi]") {
    const std::string geo = kBunny + " --source 0.5,6,1 --target -2,9,0";
    const std::string oneVdb = temp("mpi_geo_one.vdb"), onePaths = temp("mpi_geo_one.json");
    REQUIRE(run("geodesic " + geo + " -o " + oneVdb + " --paths " + onePaths).code == 0);
    const std::string out = temp("mpi_geo.vdb"), paths = temp("mpi_geo.json");
    Run r = runMpi(2, "geodesic " + geo + " -o " + out + " --paths " + paths);
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(readGrids(out) == readGrids(oneVdb));
    CHECK(readJson(paths) == readJson(onePaths));

    // Data on the surface: every 50th vertex of the bunny, valued by its x
    std::ifstream obj(gpisvdb::test::dataPath("bunny.obj"));
    std::string line, csv;
    for (int k = 0; std::getline(obj, line);)
        if (line.rfind("v ", 0) == 0 && ++k % 50 == 0) {
            std::istringstream v(line.substr(2));
            double x, y, z;
            v >> x >> y >> z;
            csv += std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(z) + "," + std::to_string(x) + "\n";
        }
    const std::string data = temp("mpi_regress.csv", csv), args = kBunny + " -k 12 --data " + data;
    const std::string oneRegress = temp("mpi_regress_one.vdb"), oneReport = temp("mpi_regress_one.json");
    REQUIRE(run("regress " + args + " -o " + oneRegress + " --report " + oneReport).code == 0);
    // The variance's scale is the prior's: near the data it is a small difference of quantities of that size
    const double amplitude = readJson(oneReport)["regression"]["amplitude"].get<double>();
    const std::string regressOut = temp("mpi_regress.vdb"), report = temp("mpi_regress.json");
    r = runMpi(2, "regress " + args + " -o " + regressOut + " --report " + report);
    INFO(r.err);
    REQUIRE(r.code == 0);
    const Grids expected = readGrids(oneRegress), got = readGrids(regressOut);
    for (const std::string name : {"regression_mean", "regression_variance"}) {
        double worst = 0, scale = name == "regression_variance" ? amplitude : 0.0;
        for (const auto& [c, v] : expected.at(name)) {
            worst = std::max(worst, double(std::abs(got.at(name).at(c)[0] - v[0])));
            if (name == "regression_mean") scale = std::max(scale, double(std::abs(v[0])));
        }
        INFO(name << ": " << worst << " against a scale of " << scale);
        CHECK(worst <= 1e-5 * scale);
    }
    CHECK(readJson(report)["spectrum"]["method"].get<std::string>().find("SLEPc") != std::string::npos);
}

TEST_CASE("mpi: an error on one rank or all ends every rank with one message, exit 1 and no output", "[mpi]") {
    const std::string out = temp("mpi_error.vdb");
    // Only rank 0 opens the output: the others learn of its failure
    Run r = runMpi(2, "band " + kBunny + " -o /nonexistent-dir/x.vdb");
    CHECK(r.code == 1);
    CHECK(r.err.find("gpisvdb-mpi: error: /nonexistent-dir/x.vdb") != std::string::npos);
    // Every rank refuses the band before building it
    r = runMpi(2, "band " + kBunny + " --max-memory 1M -o " + out);
    CHECK(r.code == 1);
    CHECK(r.err.find("--max-memory") != std::string::npos);
    // A missing input, a bad parameter, a solve that stops short
    CHECK(runMpi(2, "band missing-input.obj -o " + out).code == 1);
    CHECK(runMpi(2, "band " + kBunny + " --qmc 0 -o " + out).code == 1);
    r = runMpi(2, "green " + kBunny + " --source 0,0,0 --max-iterations 2 -o " + out);
    CHECK(r.code == 1);
    CHECK(r.err.find("--max-iterations") != std::string::npos);
    for (const std::string& e : {r.err}) {
        std::size_t lines = 0;
        for (std::size_t at = e.find("gpisvdb-mpi:"); at != std::string::npos; at = e.find("gpisvdb-mpi:", at + 1)) ++lines;
        CHECK(lines == 1);
    }
    CHECK_FALSE(leftovers(out));
}

TEST_CASE("mpi: Ctrl-C (SIGINT to mpirun) stops every rank within seconds and leaves no output", "[mpi]") {
    const std::string out = temp("mpi_interrupted.vdb"), errPath = temp("mpi_interrupted.err");
    std::vector<std::string> words = {GPISVDB_MPIEXEC,
                                      "--oversubscribe",
                                      "-n",
                                      "2",
                                      GPISVDB_MPI_EXE,
                                      "green",
                                      gpisvdb::test::dataPath("bunny.obj"),
                                      "--sigma",
                                      "0.25",
                                      "--source",
                                      "0.5,6,1",
                                      "--threads",
                                      "1",
                                      "-o",
                                      out};
    if (geteuid() == 0) words.insert(words.begin() + 1, "--allow-run-as-root");
    // One progress line per percent on the piped stderr: the signal waits for the ranks' first one
    const pid_t pid = spawn(words, errPath, {"GPISVDB_PROGRESS=lines"});
    REQUIRE(pid > 0);
    // Signalled once the band reports progress, not at a fixed moment: on a loaded machine mpirun's start-up alone
    // can outlast a fixed delay, and a signal before the ranks install their handlers kills them without a word.
    const auto since = [](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    // Waits up to `limit` seconds for mpirun to end (true) or for `until` to hold (false).
    int status = 0;
    const auto waitFor = [&](double limit, const std::function<bool()>& until) {
        for (const auto start = std::chrono::steady_clock::now(); since(start) < limit && !until();
             std::this_thread::sleep_for(std::chrono::milliseconds(20)))
            if (waitpid(pid, &status, WNOHANG) == pid) return true;
        return false;
    };
    const auto progressed = [&] { return fileText(errPath).find("gpisvdb-progress band") != std::string::npos; };
    const bool endedFirst = waitFor(120, progressed);
    INFO(fileText(errPath));
    if (endedFirst || !progressed()) {
        if (!endedFirst) kill(pid, SIGKILL), waitpid(pid, &status, 0);
        FAIL("gpisvdb-mpi " << (endedFirst ? "ended" : "reported no band progress within 120 s") << " before the signal");
    }
    kill(pid, SIGINT);
    const auto signalled = std::chrono::steady_clock::now();
    const bool ended = waitFor(30, [] { return false; });
    const double seconds = since(signalled);
    if (!ended) {
        kill(pid, SIGKILL), waitpid(pid, &status, 0);
        FAIL("mpirun still running 30 s after SIGINT");
    }
    const std::string err = fileText(errPath);
    INFO(err);
    CHECK(!(WIFEXITED(status) && WEXITSTATUS(status) == 0));
    CHECK(err.find("gpisvdb-mpi: interrupted") != std::string::npos);
    CHECK(err.find("gpisvdb: ") == std::string::npos);  // every rank's message, the watchdog's too, names gpisvdb-mpi
    CHECK(seconds < 10);
    CHECK_FALSE(leftovers(out));
}
