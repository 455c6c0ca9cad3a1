// The .vdb files we write, read back by independent readers: OpenVDB's vdb_print and Python's pyopenvdb.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>

#include "band_fixtures.h"
#include "gpisvdb/output/write_vdb.h"
#include "helpers.h"

using namespace gpisvdb;

namespace {

std::string runCapture(const std::string& cmd, int& code) {
    const std::string out = (test::scratchDir() / "capture.txt").string();
    const int status = std::system((cmd + " > " + out + " 2>&1").c_str());
    code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream in(out);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::string writeSmallBand(Band& keep) {
    keep = test::sphereBand();
    openvdb::MetaMap meta;
    meta.insertMeta("gpisvdb_version", openvdb::StringMetadata(GPISVDB_VERSION));
    meta.insertMeta("sigma_rel", openvdb::DoubleMetadata(1.0));
    const std::string path = (test::scratchDir() / "band.vdb").string();
    writeBandVdb(keep, path, meta);
    return path;
}

}  // namespace

TEST_CASE("output: vdb_print reads every grid of a band file", "[output]") {
    Band band;
    const std::string path = writeSmallBand(band);
    int code = 0;
    const std::string text = runCapture("vdb_print -l " + path, code);
    REQUIRE(code == 0);
    for (const char* name : {"mu", "mean", "stddev", "T_diag", "T_offdiag", "normal", "stencil_width"})
        CHECK_THAT(text, Catch::Contains(std::string("Name: ") + name));
    CHECK_THAT(text, Catch::Contains("class: fog volume"));
    CHECK_THAT(text, Catch::Contains("sigma_rel: 1"));
    CHECK_THAT(text, Catch::Contains(std::to_string(band.size())));
}

TEST_CASE("output: pyopenvdb reads names, classes, voxel size, value ranges and metadata", "[output]") {
    Band band;
    const std::string path = writeSmallBand(band);
    float lo = band.mu[0], hi = band.mu[0];
    for (float v : band.mu) lo = std::min(lo, v), hi = std::max(hi, v);
    const std::string script = (test::scratchDir() / "read.py").string();
    std::ofstream(script) << "import sys, pyopenvdb as vdb\n"
                             "grids, meta = vdb.readAll(sys.argv[1])\n"
                             "print('version', meta['gpisvdb_version'])\n"
                             "for g in grids:\n"
                             "    lo, hi = g.evalMinMax()\n"
                             "    print('|'.join([g.name, g.gridClass, '%.9g' % g.transform.voxelSize()[0], str(g.activeVoxelCount()), str(lo), str(hi)]))\n";
    int code = 0;
    const std::string text = runCapture("/usr/bin/python3 " + script + " " + path, code);
    INFO(text);
    REQUIRE(code == 0);
    CHECK_THAT(text, Catch::Contains("version " GPISVDB_VERSION));
    std::istringstream lines(text);
    std::string line;
    int grids = 0;
    while (std::getline(lines, line)) {
        if (line.rfind("version", 0) == 0) continue;
        std::vector<std::string> f;
        std::istringstream ls(line);
        for (std::string part; std::getline(ls, part, '|');) f.push_back(part);
        REQUIRE(f.size() == 6);
        const std::string& name = f[0];
        const std::string& cls = f[1];
        const std::string& voxel = f[2];
        const std::size_t count = std::stoul(f[3]);
        ++grids;
        CHECK(std::stod(voxel) == Approx(0.08).epsilon(1e-6));
        CHECK(count == band.size());
        if (name == "mu") {
            CHECK(cls == "fog volume");
            CHECK(std::stod(f[4]) == Approx(lo).epsilon(1e-6));
            CHECK(std::stod(f[5]) == Approx(hi).epsilon(1e-6));
        }
    }
    CHECK(grids == 7);
}
