// The memory stages that were estimated last (docs/memory.md, issue 18 item 2): the spectrum's assembled L refused
// before it is made, regress's posterior refused before the eigen solver runs, and the sample, info and demo
// commands' estimates; each against the peak a child gpisvdb measures over its stage, and each refusal: exit 1,
// one line, nothing written.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "helpers.h"
#include "memory_checks.h"

using namespace gpisvdb::test::cli;
using namespace gpisvdb::test::memory;

namespace {

/// `args` refused: exit 1, one line on stderr that names --max-memory and each of `expect`, `output` not written.
/// (`--quiet` is added where the command has it: all but info.)
void checkRefused(const std::string& args, const std::string& output, const std::vector<std::string>& expect,
                  bool directory = false) {
    const Run r = run(args.rfind("info ", 0) == 0 ? args : args + " --quiet");
    INFO(args << "\nstderr: " << r.err);
    CHECK(r.code == 1);
    CHECK(lines(r.err) == 1);
    CHECK_THAT(r.err, Catch::Contains("(--max-memory)"));
    for (const std::string& e : expect) CHECK_THAT(r.err, Catch::Contains(e));
    const bool left = directory ? directoryLeftovers(output) : leftovers(output);
    CHECK_FALSE(left);
}

std::string bytes(double b) { return std::to_string(std::llround(b)); }

}  // namespace

TEST_CASE("memory: spectrum refuses its assembled Laplacian before assembling it, then the eigen solver's factor beside it, and writes nothing", "[memory][cli]") {
    const std::string bunny = gpisvdb::test::dataPath("bunny.obj"), vdb = temp("memory_spectrum.vdb");
    for (const char* h : {"0.4", "0.25"}) {
        const std::string args = "spectrum " + bunny + " --sigma 2 --voxel-size " + h + " -o " + vdb;
        const nlohmann::json fits = childStage(args + " -k 5 --quiet", "spectrum");
        std::filesystem::remove(vdb);
        const double baseline = fits["baseline_bytes"], L = fits["parts_bytes"]["laplacian_double"];
        INFO("h " << h << ": " << fits.dump());
        // Half of L beside what the process holds: refused before L is assembled, naming the voxel size that fits
        checkRefused(args + " -k 5 --max-memory " + bytes(baseline + 0.5 * L), vdb,
                     {"the assembled Laplacian of the eigen solver needs about", "use a voxel size (--voxel-size) of"});
        // L, M and the assembly's peak (≈ 3.5 L) fit in 5 L, the factor and the Lanczos basis do not: the solver's
        // refusal, after its symbolic analysis
        checkRefused(args + " -k 5 --eigen-method lanczos --max-memory " + bytes(baseline + 5 * L), vdb,
                     {"Cholesky factor of", "lower the eigenpair count (-k)"});
        // …and where LOBPCG would take over without a factor, it does not fit either
        checkRefused(args + " -k 200 --max-memory " + bytes(baseline + 5 * L), vdb, {"and LOBPCG without a factor about"});
    }
}
