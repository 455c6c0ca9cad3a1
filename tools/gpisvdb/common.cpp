#include "common.h"

#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <tbb/global_control.h>
#include <thread>
#include <vector>

#include "gpisvdb/app/parameter_names.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/output/temporary_path.h"

namespace gpisvdb::cli {

namespace {
std::atomic<bool> gInterrupted{false};
std::atomic<int> gSignal{0};  // the first SIGINT or SIGTERM
int gWakeWrite = -1;          // the watchdog's pipe: written by the handler (write is async-signal-safe)

void noteSignal(int sig) {
    int none = 0;
    gSignal.compare_exchange_strong(none, sig);
    gInterrupted = true;
}

// Installed for two reasons, though every thread of ours blocks SIGINT and SIGTERM (installInterruptHandler): a
// disposition other than "ignore" (a shell starts background jobs with SIGINT ignored, and an ignored signal never
// reaches the signalfd), and a thread a library started before main with the signals unblocked, which runs this.
extern "C" void onSignal(int sig) {
    noteSignal(sig);
    if (gWakeWrite >= 0) {
        const char c = 1;
        [[maybe_unused]] const ssize_t ignored = ::write(gWakeWrite, &c, 1);
    }
}

/// The temporaries of the AtomicOutput/AtomicDirectory objects alive now (leaked: the watchdog may read it while
/// static destructors run).
struct Temporaries {
    std::mutex mutex;
    std::set<std::string> files, directories;
    // Outputs this run already renamed into place: a command with several outputs (a .vdb, then its report)
    // interrupted between two commits takes the first back, so that "no output written" stays true.
    std::vector<std::string> committed;
    bool interruptReported = false;  ///< main has written its one line (reportInterrupted)
};

/// Removes the temporaries and the outputs committed so far; the caller holds the mutex.
void removeOutputsLocked(Temporaries& t) {
    namespace fs = std::filesystem;
    std::error_code ec;
    for (const std::string& f : t.files) {
        fs::remove(f, ec);
        // …and what a writer keeps beside a temporary under its name: the VDB writer's "T.part<pid>", green's
        // spilled grids "T.grids"
        const fs::path p(f);
        const std::string prefix = p.filename().string() + ".";
        const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
            if (it->path().filename().string().rfind(prefix, 0) == 0) {
                std::error_code ignored;
                fs::remove(it->path(), ignored);
            }
    }
    for (const std::string& d : t.directories) std::filesystem::remove_all(d, ec);
    for (const std::string& f : t.committed) std::filesystem::remove(f, ec);
}
Temporaries& temporaries() {
    static Temporaries* t = new Temporaries;
    return *t;
}
void registerTemporary(const std::string& path, bool directory) {
    Temporaries& t = temporaries();
    std::lock_guard<std::mutex> lock(t.mutex);
    (directory ? t.directories : t.files).insert(path);
}
void unregisterTemporary(const std::string& path, bool directory) {
    Temporaries& t = temporaries();
    std::lock_guard<std::mutex> lock(t.mutex);
    (directory ? t.directories : t.files).erase(path);
}

/// After a signal the work stops by itself within a few hundred milliseconds (the engine polls); a step that does
/// not poll (a CHOLMOD factorization, a VTK render, a large file write) would keep the user waiting, so past the
/// grace period this thread removes the temporaries and ends the process with the same exit code.
void watchdog(int signals, int wakeRead, std::string message) {
    pollfd fds[2] = {{signals, POLLIN, 0}, {wakeRead, POLLIN, 0}};
    while (::poll(fds, 2, -1) < 0 && errno == EINTR) {
    }
    signalfd_siginfo info;
    if ((fds[0].revents & POLLIN) && ::read(signals, &info, sizeof info) == ssize_t(sizeof info)) noteSignal(int(info.ssi_signo));
    std::this_thread::sleep_for(std::chrono::milliseconds(kInterruptGraceMs));
    Temporaries& t = temporaries();
    t.mutex.lock();  // held until _exit: no output can be registered, committed or left behind meanwhile
    removeOutputsLocked(t);
    // main may have reported the interruption already and be ending slowly (freeing a large band, a sanitizer's
    // exit checks): one message, not two.
    if (!t.interruptReported) {
        [[maybe_unused]] const ssize_t ignored = ::write(STDERR_FILENO, message.data(), message.size());
    }
    ::_exit(128 + gSignal.load());
}
}  // namespace

void reportInterrupted(const std::string& message) {
    Temporaries& t = temporaries();
    std::lock_guard<std::mutex> lock(t.mutex);
    std::cerr << message << std::flush;
    t.interruptReported = true;
}

void removeCommittedOutputs() {
    Temporaries& t = temporaries();
    std::lock_guard<std::mutex> lock(t.mutex);
    std::error_code ec;
    for (const std::string& f : t.committed) std::filesystem::remove(f, ec);
    t.committed.clear();
}

std::string& commandLine() {
    static std::string line;
    return line;
}

std::optional<int> parseCommandLine(CLI::App& app, int argc, char** argv, bool speaks) {
    for (int i = 0; i < argc; ++i) commandLine() += (i ? " " : "") + std::string(argv[i]);
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {
        return speaks ? app.exit(e) : 0;
    } catch (const CLI::ParseError& e) {
        if (speaks) app.exit(e);
        return 2;
    }
    return std::nullopt;
}

void installInterruptHandler(const std::string& program) {
    // SIGINT and SIGTERM are blocked in this thread and so in every thread started after it (TBB's workers
    // included), and received synchronously by the watchdog through a signalfd. No handler of ours then runs
    // asynchronously, and none that a library installs for a while can take them: METIS (ordering the eigen
    // solver's Cholesky factor) replaces the SIGTERM handler during its run and longjmps out of its own, which
    // swallowed the signal, or would crash on another thread.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    const int signals = ::signalfd(-1, &set, SFD_CLOEXEC);
    int fds[2];
    if (signals >= 0 && ::pipe(fds) == 0) {
        gWakeWrite = fds[1];
        std::thread(watchdog, signals, fds[0], program + ": interrupted, no output written (stopped in a step that does not poll)\n")
            .detach();
        std::signal(SIGINT, onSignal);
        std::signal(SIGTERM, onSignal);
    } else {
        pthread_sigmask(SIG_UNBLOCK, &set, nullptr);  // no watchdog: the signals keep their default action
    }
}
bool interruptRequested() { return gInterrupted; }
int interruptSignal() { return gSignal; }

void addModelFlags(CLI::App& app, ModelFlags& f, bool withModel) {
    app.add_option("--sigma", f.sigmaRel, "noise std σ of vertices/points, relative to the length scale ℓ (> 0)")->capture_default_str();
    if (withModel) {
        app.add_option("--smoothing", f.smoothingRel, "kernel smoothing s, relative to ℓ (regression: to the training spacing) (> 0)")
            ->capture_default_str();
        app.add_option("--noise-smoothing", f.noiseSmoothing,
                       "winding model: s is at least this × the samples' median position std, so that it follows the noise "
                       "where samples are denser than it (>= 0; 0: --smoothing × ℓ alone)")
            ->capture_default_str();
        app.add_option("--merge", f.mergeRel,
                       "winding model: where the samples are denser than the kernel (s > l), one Gaussian dipole per cell of this "
                       "× s (>= 0; 0: never)")
            ->capture_default_str();
        app.add_option("--beta", f.beta,
                       "Barnes-Hut accuracy: a node stands in for its samples beyond beta × its radius (2 × beta for the covariance near "
                       "the query) (> 1)")
            ->capture_default_str();
        app.add_flag("--exact", f.exact, "use the direct O(n) sum instead of Barnes-Hut");
        app.add_option("--model", f.model,
                       "GPIS model: winding (linearized winding number, paper Eq. 5) or regression (GP regression on labels, App. F; "
                       "surface at phi = 0)")
            ->check(CLI::IsMember({"winding", "regression"}))
            ->capture_default_str();
        app.add_option("--labels", f.labels,
                       "regression: training file x,y,z,label[,noise] (+1 inside, 0 on, -1 outside); default: generated from the input");
        app.add_option("--training-points", f.trainingPoints,
                       "regression: surface points kept from the input (farthest-point sampling), 3 labels each")
            ->capture_default_str();
        app.add_option("--training-offset", f.trainingOffset,
                       "regression: inside/outside label offset along the normal, relative to the training spacing sqrt(area/n)")
            ->capture_default_str();
        app.add_option("--label-noise", f.labelNoise, "regression: std of the labels (>= 0)")->capture_default_str();
    }
    app.add_option("--threads", f.threads, "worker threads (0 = all cores)")->capture_default_str();
    app.add_flag("--quiet", f.quiet, "no progress bar");
}

int runCommand(const std::function<void()>& action, const std::function<void(const std::string& message, bool interrupted)>& report) {
    try {
        action();
    } catch (const Cancelled&) {
        report("interrupted, no output written", true);
        return 128 + (interruptSignal() ? interruptSignal() : SIGINT);
    } catch (const Error& e) {
        report("error: " + app::frontEndMessage(e, app::FrontEnd::CommandLine), false);
        return 1;
    } catch (const std::exception& e) {
        report(std::string("internal error: ") + e.what(), false);
        return 1;
    }
    return 0;
}

std::shared_ptr<void> limitThreads(int threads) {
    if (threads < 0) throw ParameterError("--threads must be >= 0 (got " + std::to_string(threads) + ")");
    if (threads == 0) return nullptr;
    return std::make_shared<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
}

ModelOptions modelOptions(const ModelFlags& flags) {
    ModelOptions o;
    o.sigmaRel = flags.sigmaRel;
    o.smoothingRel = flags.smoothingRel;
    o.noiseSmoothing = flags.noiseSmoothing;
    o.mergeRel = flags.mergeRel;
    o.kind = flags.model == "regression" ? ModelKind::Regression : ModelKind::Winding;
    o.exact = flags.exact;
    o.barnesHut.beta = flags.beta;
    o.training.surfacePoints = flags.trainingPoints;
    o.training.offsetRelative = flags.trainingOffset;
    o.labelNoise = flags.labelNoise;
    if (o.kind == ModelKind::Regression && !flags.labels.empty()) o.labels = readLabelledPoints(flags.labels);
    return o;
}

std::unique_ptr<AtomicOutput> optionalOutput(const std::string& path) {
    return path.empty() ? nullptr : std::make_unique<AtomicOutput>(path);
}

AtomicOutput::AtomicOutput(std::string path) : path_(std::move(path)), temp_(temporaryPathBeside(path_)) {
    registerTemporary(temp_, false);
    std::ofstream probe(temp_);
    const bool writable = bool(probe);
    probe.close();
    // The writer makes the file again when the output is ready: until then a process killed outright (SIGKILL:
    // mpirun's second step after SIGTERM, a batch scheduler, the OOM killer) leaves nothing behind.
    std::remove(temp_.c_str());
    if (!writable) {
        unregisterTemporary(temp_, false);
        throw OutputError(path_ + ": cannot write in " + std::filesystem::path(temp_).parent_path().string());
    }
}

AtomicOutput::~AtomicOutput() {
    if (!committed_) std::remove(temp_.c_str());
    unregisterTemporary(temp_, false);
}

void AtomicOutput::commit() {
    if (interruptRequested()) throw Cancelled();  // a Ctrl-C during a step that does not poll still leaves nothing
    std::error_code ec;
    std::lock_guard<std::mutex> lock(temporaries().mutex);  // not while the watchdog removes the temporaries
    if (interruptRequested()) throw Cancelled();
    std::filesystem::rename(temp_, path_, ec);
    if (ec) throw OutputError(path_ + ": cannot rename the finished output into place: " + ec.message());
    committed_ = true;
    temporaries().committed.push_back(path_);
}

AtomicDirectory::AtomicDirectory(std::string path) : path_(std::move(path)) {
    namespace fs = std::filesystem;
    fs::path target = fs::path(path_).lexically_normal();
    if (target.filename().empty()) target = target.parent_path();
    std::error_code ec;
    if (fs::exists(target, ec) && !fs::is_directory(target, ec)) throw OutputError(path_ + ": exists and is not a directory");
    const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
    if (!fs::is_directory(parent, ec)) throw OutputError(path_ + ": the directory " + parent.string() + " does not exist");
    std::random_device rd;
    temp_ = (parent / ("." + target.filename().string() + ".tmp-" + std::to_string(rd() % 1000000))).string();
    registerTemporary(temp_, true);
    if (!fs::create_directory(temp_, ec) || ec) {
        unregisterTemporary(temp_, true);
        throw OutputError(path_ + ": cannot write in " + parent.string());
    }
    path_ = target.string();
}

AtomicDirectory::~AtomicDirectory() {
    std::error_code ec;
    if (!committed_) std::filesystem::remove_all(temp_, ec);
    unregisterTemporary(temp_, true);
}

void AtomicDirectory::commit() {
    if (interruptRequested()) throw Cancelled();
    namespace fs = std::filesystem;
    std::error_code ec;
    std::lock_guard<std::mutex> lock(temporaries().mutex);  // not while the watchdog removes the temporaries
    if (interruptRequested()) throw Cancelled();
    if (!fs::exists(path_, ec)) {
        fs::rename(temp_, path_, ec);
        if (ec) throw OutputError(path_ + ": cannot move the finished outputs into place: " + ec.message());
        committed_ = true;
        return;
    }
    // An existing directory: replace entry by entry (a previous run's subdirectories are replaced whole).
    for (const auto& entry : fs::directory_iterator(temp_)) {
        const fs::path to = fs::path(path_) / entry.path().filename();
        if (fs::is_directory(to, ec) && entry.is_directory()) fs::remove_all(to, ec);
        fs::rename(entry.path(), to, ec);
        if (ec) throw OutputError(to.string() + ": cannot move the finished output into place: " + ec.message());
    }
    fs::remove_all(temp_, ec);
    committed_ = true;
}

Progress makeProgress(bool quiet) {
    Progress p;
    p.interrupted = [] { return interruptRequested(); };
    if (quiet) return p;
    if (!isatty(STDERR_FILENO)) {
        // For programs that run gpisvdb and show its progress themselves (the Blender add-on): one line per whole
        // percent, "gpisvdb-progress STAGE PERCENT", only when asked for (docs/guide.md#progress-for-other-programs).
        const char* mode = std::getenv("GPISVDB_PROGRESS");
        if (!mode || std::string(mode) != "lines") return p;
        auto last = std::make_shared<std::pair<std::string, int>>("", -1);
        auto lock = std::make_shared<std::mutex>();
        p.report = [last, lock](const std::string& stage, double f) {
            const int percent = int(std::clamp(f, 0.0, 1.0) * 100);
            std::lock_guard<std::mutex> guard(*lock);
            if (stage == last->first && percent == last->second) return;
            *last = {stage, percent};
            std::fprintf(stderr, "gpisvdb-progress %s %d\n", stage.c_str(), percent);
            std::fflush(stderr);
        };
        return p;
    }
    p.report = [](const std::string& stage, double f) {
        const int width = 30, filled = int(f * width + 0.5);
        std::fprintf(stderr, "\r%-10s [%s%s] %3d%%", stage.c_str(), std::string(std::size_t(filled), '#').c_str(),
                     std::string(std::size_t(width - filled), ' ').c_str(), int(f * 100 + 0.5));
        if (f >= 1.0) std::fprintf(stderr, "\n");
        std::fflush(stderr);
    };
    return p;
}

}  // namespace gpisvdb::cli
