#pragma once
// Shared pieces of the command line: model flags, outputs written atomically, progress and Ctrl-C.
#include <chrono>
#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/read_input.h"
#include "gpisvdb/model/barnes_hut_gpis.h"
#include "gpisvdb/model/load_model.h"

namespace gpisvdb::cli {

/// Flags every subcommand that builds a GPIS shares (same names and meanings everywhere).
struct ModelFlags {
    double sigmaRel = kDefaultSigmaRel;          ///< --sigma: vertex/point noise std relative to ℓ
    double smoothingRel = kDefaultSmoothingRel;  ///< --smoothing: kernel smoothing s relative to ℓ
    double noiseSmoothing = kNoiseSmoothing;     ///< --noise-smoothing: s at least this × the median position std
    double mergeRel = ModelOptions{}.mergeRel;   ///< --merge: samples merged per cell of this × s
    double beta = BarnesHutOptions{}.beta;       ///< --beta: Barnes–Hut opening criterion
    bool exact = false;                          ///< --exact: direct O(n) sums instead of Barnes–Hut
    std::string model = "winding";               ///< --model: winding (paper Eq. 5) or regression (App. F)
    std::string labels;                          ///< --labels: x,y,z,label[,noise] training file for the regression model
    std::size_t trainingPoints = 300;            ///< --training-points: surface points kept for generated labels
    double trainingOffset = 0.5;                 ///< --training-offset: inside/outside offset, relative to the training spacing
    double labelNoise = 0.05;                    ///< --label-noise: std of the labels
    int threads = 0;                             ///< --threads: 0 = all cores
    bool quiet = false;                          ///< --quiet: no progress bar
};
void addModelFlags(CLI::App& app, ModelFlags& flags, bool withModel);

/// Applies --threads for the life of the returned object.
std::shared_ptr<void> limitThreads(int threads);

using Clock = std::chrono::steady_clock;

/// Sets the subcommand's action (run after parsing) to run(start) with the limit of `threads` (--threads, read when
/// the action runs) held; `start` is when the action began, from which the report's total time counts.
template <class Run>
void onRun(CLI::App& cmd, std::function<void()>& action, const int& threads, Run run) {
    cmd.callback([&action, &threads, run] {
        action = [&threads, run] {
            const Clock::time_point start = Clock::now();
            const auto limit = limitThreads(threads);
            run(start);
        };
    });
}

/// A subcommand's --help: its one-line summary, and the footer (what it writes, an example).
struct CommandHelp {
    std::string summary;
    std::string footer;
};

/// Registers the subcommand `name`: an Args of its own, its flags (addFlags(cmd, args)), and as its action
/// execute(args, start) with --threads (threads(args)) held (onRun).
template <class Args, class AddFlags, class Threads, class Execute>
void addCommand(CLI::App& app, std::function<void()>& action, const std::string& name, const CommandHelp& help, AddFlags addFlags,
                Threads threads, Execute execute) {
    auto* cmd = app.add_subcommand(name, help.summary);
    auto a = std::make_shared<Args>();
    addFlags(*cmd, *a);
    cmd->footer(help.footer);
    onRun(*cmd, action, threads(*a), [a, execute](Clock::time_point start) { execute(*a, start); });
}

/// The engine's model options for the flags (reads --labels): pass to loadModel (gpisvdb/model/load_model.h).
ModelOptions modelOptions(const ModelFlags& flags);

/// A file written under a temporary name in the target's directory and renamed on commit(); removed
/// if never committed (error or interrupt). Opening fails at once when the directory is not writable (a probe,
/// removed again: the temporary exists only while the writer writes it).
class AtomicOutput {
public:
    explicit AtomicOutput(std::string path);
    ~AtomicOutput();
    const std::string& tempPath() const { return temp_; }
    void commit();

private:
    std::string path_, temp_;
    bool committed_ = false;
};

/// An AtomicOutput for `path`, or none where `path` is empty (an optional output such as --report).
std::unique_ptr<AtomicOutput> optionalOutput(const std::string& path);

/// After an interrupt or an error: removes the files earlier AtomicOutput::commit() calls of this run put in place
/// (a command stopped between its .vdb and its report leaves neither).
void removeCommittedOutputs();
/// Writes main's line for an interruption to stderr, after which the watchdog, if it fires while the process
/// ends, exits without a second line.
void reportInterrupted(const std::string& message);

/// A directory of outputs written under a temporary name beside the target and moved into it on commit()
/// (each entry renamed; an existing target keeps its other files); removed if never committed.
class AtomicDirectory {
public:
    explicit AtomicDirectory(std::string path);
    ~AtomicDirectory();
    const std::string& tempPath() const { return temp_; }
    void commit();

private:
    std::string path_, temp_;
    bool committed_ = false;
};

/// Progress on stderr when it is a terminal (and not --quiet); interrupted after Ctrl-C.
Progress makeProgress(bool quiet);
/// The command line as typed (recorded in output metadata).
std::string& commandLine();
/// Records the command line (commandLine()) and parses it: the exit code where parsing ends the program (0 after
/// --help or --version, 2 after a usage error, each printed where `speaks`), nothing where a command is to run.
std::optional<int> parseCommandLine(CLI::App& app, int argc, char** argv, bool speaks = true);

/// Runs a parsed command: an exception becomes one message for `report` ("error: …", the engine's fields named by
/// their flags (app/parameter_names.h); "interrupted, no output written" with interrupted = true; or "internal
/// error: …"), and the exit code main returns (0; 1 for an error; 128 + the signal for an interrupt). report
/// removes the outputs and prints.
int runCommand(const std::function<void()>& action, const std::function<void(const std::string& message, bool interrupted)>& report);

/// Sets up Ctrl-C and SIGTERM handling; call first in main, before any thread starts (they inherit the blocked
/// signals). SIGINT and SIGTERM set a flag the Progress polls; a watchdog thread ends the process kInterruptGraceMs
/// after the signal if the work has not stopped by then (removing every AtomicOutput/AtomicDirectory temporary),
/// with 128 + the signal, its message prefixed with `program`. Child processes must unblock the signals
/// (headless_display.cpp does for Xvfb).
void installInterruptHandler(const std::string& program = "gpisvdb");
bool interruptRequested();
/// The first signal received (SIGINT or SIGTERM), 0 if none: main returns 128 + it.
int interruptSignal();
constexpr int kInterruptGraceMs = 500;
/// What an INPUT may be, for the commands' --help (readInput's formats).
constexpr const char* kInputHelp = "mesh (.obj .off .ply .stl .vtp), oriented cloud (.xyz .ply .vtp) or Gaussian dipoles (.gdp)";

}  // namespace gpisvdb::cli
