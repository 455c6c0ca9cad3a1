// Prompt cancellation (issue 21): Progress::interrupted set mid-way stops the long loops with Cancelled, also
// inside TBB parallel loops (no worker keeps polling afterwards); SIGINT and SIGTERM stop every long command of
// the program within a second at any stage, exit 130 / 143, and leave no output, report or temporary.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "band_fixtures.h"
#include "cli_run.h"
#include "gpisvdb/band/build_band.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/solve/fast_marching.h"
#include "gpisvdb/solve/pcg.h"
#include "gpisvdb/tasks/spectrum.h"
#include "helpers.h"

using namespace gpisvdb;
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// A Progress whose flag turns on at the `after`-th poll (counting every poll, from any thread).
struct CountingInterrupt {
    std::atomic<long> polls{0};
    long after;
    explicit CountingInterrupt(long a) : after(a) {}
    Progress progress() {
        Progress p;
        p.interrupted = [this] { return ++polls >= after; };
        return p;
    }
};

/// A flag set by a timer thread `seconds` after start; the latency is measured from that moment.
struct TimedInterrupt {
    std::atomic<bool> flag{false};
    Clock::time_point setAt;
    std::thread timer;
    explicit TimedInterrupt(double seconds)
        : timer([this, seconds] {
              std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
              setAt = Clock::now();
              flag = true;
          }) {}
    ~TimedInterrupt() { timer.join(); }
    Progress progress() {
        Progress p;
        p.interrupted = [this] { return flag.load(); };
        return p;
    }
};

}  // namespace

TEST_CASE("interrupt: buildBand stops within a second of the flag, inside a level's model evaluation", "[interrupt]") {
    // The bunny at its default resolution: ~1.5 M voxels, minutes of work; the flag comes during the first levels.
    const Samples samples = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
    const BarnesHutGpis model(samples, 0.4 * samples.lengthScale);
    BandOptions o;
    o.voxelSize = 0.05;
    for (const double at : {0.3, 1.0}) {
        TimedInterrupt t(at);
        CHECK_THROWS_AS(buildBand(model, samples, o, t.progress()), Cancelled);
        const double latency = since(t.setAt);
        WARN("buildBand: flag at " << at << " s, stopped " << latency << " s later");
        if (test::kTimingChecked) CHECK(latency < 1.0);
    }
}

TEST_CASE("interrupt: a flag polled inside a parallel model evaluation stops every worker", "[interrupt]") {
    const Samples samples = makeSamples(readInput(test::dataPath("bunny.obj")), {0.5}).samples;
    const BarnesHutGpis model(samples, 0.4 * samples.lengthScale);
    std::vector<Vec3d> xs(200000);
    for (std::size_t i = 0; i < xs.size(); ++i) xs[i] = Vec3d(std::sin(0.001 * i), 9.0 * (i % 997) / 997.0, 0.0);
    for (const bool dense : {false, true}) {  // packets, and the cells of evaluateDense (a band's voxels)
        INFO(std::string(dense ? "evaluateDense" : "evaluate"));
        CountingInterrupt c(40);  // past the block boundary poll: inside the parallel loop
        CHECK_THROWS_AS(dense ? model.evaluateDense(xs, c.progress()) : model.evaluate(xs, c.progress()), Cancelled);
        const long after = c.polls;
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        CHECK(c.polls == after);                                                // no worker still running (and polling) once evaluate threw
        CHECK(after < 40 + 4 * long(std::thread::hardware_concurrency()) + 8);  // each worker stops at its next poll
        // Polling does not change the results.
        const std::vector<Vec3d> few(xs.begin(), xs.begin() + 1000);
        Progress never;
        never.interrupted = [] { return false; };
        const std::vector<ValueGradient> a = dense ? model.evaluateDense(few) : model.evaluate(few),
                                         b = dense ? model.evaluateDense(few, never) : model.evaluate(few, never);
        for (std::size_t i = 0; i < few.size(); ++i) REQUIRE(a[i].mean == b[i].mean);
    }
}

TEST_CASE("interrupt: the PCG, fast marching and the eigen solver stop at the flag", "[interrupt]") {
    const Band ball = test::anisotropicBall(40, 0.05, 4);
    SECTION("PCG") {
        const LaplacianOperator L(ball);
        std::vector<float> b(ball.size(), 0.0f), x;
        b[ball.size() / 2] = 1.0f;
        PcgOptions o;
        o.tolerance = 1e-7;
        for (Preconditioner pc : {Preconditioner::Jacobi, Preconditioner::Multigrid}) {
            INFO(preconditionerName(pc));
            o.preconditioner = pc;
            CountingInterrupt c(5);
            CHECK_THROWS_AS(solvePcg(L, b, x, o, c.progress()), Cancelled);
            CHECK(c.polls == 5);  // polled every iteration: stopped at the 5th
        }
    }
    SECTION("fast marching") {
        CountingInterrupt c(2);
        CHECK_THROWS_AS(fastMarching(ball, {0}, {}, {}, c.progress()), Cancelled);
        CHECK(c.polls == 2);
    }
    SECTION("eigen solver") {
        const Band& sphere = test::sphereBand();
        EigenOptions o;
        o.count = 4;
        CountingInterrupt c(6);
        CHECK_THROWS_AS(spectrum(sphere, o, c.progress()), Cancelled);
        CHECK(c.polls == 6);
    }
    SECTION("timed: PCG on a large ball within a second") {
        const Band big = test::anisotropicBall(55, 0.05, 4);
        const LaplacianOperator L(big);
        std::vector<float> b(big.size(), 0.0f), x;
        b[big.size() / 2] = 1.0f;
        PcgOptions o;
        o.tolerance = 1e-7;
        o.maxIterations = 1000000;
        // Jacobi: its iterations are what polls. (The multigrid's set-up, ≈ 4 µs per voxel inside hypre, does not
        // poll; its iterations do, as the section above checks.)
        o.preconditioner = Preconditioner::Jacobi;
        TimedInterrupt t(0.3);
        const auto start = Clock::now();
        try {
            solvePcg(L, b, x, o, t.progress());
            WARN("the PCG converged before the flag (" << since(start) << " s)");
        } catch (const Cancelled&) {
            const double latency = since(t.setAt);
            WARN("PCG over " << big.size() << " voxels: stopped " << latency << " s after the flag");
            if (test::kTimingChecked) CHECK(latency < 1.0);
        }
    }
}

// ---------------------------------------------------------------------------------------------------------------
// The program under SIGINT / SIGTERM

namespace {

struct Signalled {
    int code = -1;          // exit code; 128 + signal if killed by one
    bool finished = false;  // exited before the signal
    double latency = 0;     // seconds from the signal to the exit
    std::string err;
};

/// Runs gpisvdb with `args` (split on spaces), sends `sig` after `delay` seconds, waits for it.
Signalled runSignalled(const std::string& args, int sig, double delay) {
    std::vector<std::string> words{GPISVDB_EXE};
    std::istringstream in(args);
    for (std::string w; in >> w;) words.push_back(w);
    const std::string errPath = (test::scratchDir() / "gpisvdb_interrupt_stderr").string();
    const pid_t pid = test::cli::spawn(words, errPath);
    Signalled s;
    int status = 0;
    const auto start = Clock::now();
    while (since(start) < delay) {
        if (waitpid(pid, &status, WNOHANG) == pid) {
            s.finished = true;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (!s.finished) {
        kill(pid, sig);
        const auto signalled = Clock::now();
        waitpid(pid, &status, 0);
        s.latency = since(signalled);
    }
    // A signal that lands before main() installs its handlers (the dynamic loader alone can take that long on a
    // loaded machine) kills the process outright; a shell reports that as 128 + signal too, and nothing was written.
    s.code = WIFEXITED(status) ? WEXITSTATUS(status) : WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
    s.err = test::cli::fileText(errPath);
    return s;
}

}  // namespace

TEST_CASE("interrupt: SIGINT and SIGTERM stop every long command within a second, exit 130 or 143, leave nothing", "[interrupt][cli]") {
    using namespace gpisvdb::test::cli;
    const std::string bunny = test::dataPath("bunny.obj");
    const std::string vdb = temp("sig.vdb"), json = temp("sig.json"), png = temp("sig.png"), dir = temp("sig_demo");
    const std::string data = temp("sig.csv", "0,6,0,1\n");
    // Voxel sizes chosen so that each run takes 3-10 s on an idle 2-core machine (measured): every signal moment
    // lands in the band's levels or the task's own stage, not after the run has finished.
    const auto at = [&](const char* voxelSize) {
        return std::string(" --voxel-size ") + voxelSize + " -o " + vdb + " --report " + json + " --quiet";
    };
    const std::vector<std::pair<std::string, std::string>> commands = {
        {"band", "band " + bunny + " -o " + vdb + " --report " + json + " --quiet"},  // default size: ~10 s
        {"green", "green " + bunny + " --source 0.5,6,1" + at("0.08")},
        {"geodesic", "geodesic " + bunny + " --source 0.5,6,1" + at("0.08")},
        {"spectrum", "spectrum " + bunny + " -k 40" + at("0.12")},
        {"hodge", "hodge " + bunny + " --preset mixed" + at("0.1")},
        {"distance", "distance " + bunny + " --alpha 20" + at("0.25")},
        {"regress", "regress " + bunny + " --data " + data + at("0.2")},
        {"demo", "demo -o " + dir + " --quiet"},
    };
    // Early (the band's first levels), middle and late (the task's own stage), each signal at least twice.
    const std::vector<std::pair<int, double>> moments = {{SIGINT, 0.3}, {SIGTERM, 0.8}, {SIGINT, 1.5}, {SIGTERM, 2.5}};
    double worst = 0;
    for (const auto& [name, args] : commands) {
        int inFlight = 0;  // signals that found the command still running
        for (const auto& [sig, delay] : moments) {
            INFO(name << " signal " << sig << " after " << delay << " s");
            fs::remove(vdb), fs::remove(json), fs::remove_all(dir);
            const Signalled s = runSignalled(args, sig, delay);
            INFO(s.err);
            if (s.finished) {
                CHECK(s.code == 0);
                continue;
            }
            ++inFlight;
            WARN(name << ": signal " << sig << " at " << delay << " s, exit " << s.code << " after " << s.latency << " s");
            worst = std::max(worst, s.latency);
            if (s.code == 0 && s.latency < 0.1) {
                // It finished between the last poll and the signal (the run takes about as long as the delay): a
                // complete run, so its outputs must all be there.
                CHECK((fs::exists(json) || fs::exists(fs::path(dir) / "report.json")));
                continue;
            }
            if (s.err.find("does not poll") != std::string::npos) WARN(name << ": stopped by the watchdog, not by a poll");
            CHECK(s.code == 128 + sig);
            if (test::kTimingChecked) CHECK(s.latency < 1.5);  // the promise is 1 s; margin for a loaded CI machine
            CHECK_FALSE(leftovers(vdb));
            CHECK_FALSE(leftovers(json));
            CHECK_FALSE(directoryLeftovers(dir));
        }
        INFO(name << " finished before " << moments.size() - inFlight << " of the " << moments.size() << " signals");
        CHECK(inFlight >= 3);  // otherwise the command is too small to test its cancellation
    }
    // render alone takes well under a second on these inputs; the demo covers it (its pictures are its last stage).
    WARN("worst latency " << worst << " s");
}
