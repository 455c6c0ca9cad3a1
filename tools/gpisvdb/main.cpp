// gpisvdb: uncertainty-aware geometry processing on Gaussian Process Implicit Surfaces.
// Exit codes: 0 success, 1 error (input, parameter, output), 2 usage error, 130 interrupted (SIGINT, Ctrl-C),
// 143 terminated (SIGTERM); either way within a second, leaving no output.
#include <iostream>

#include "commands.h"
#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/worker_threads.h"

int main(int argc, char** argv) {
    using namespace gpisvdb;
    cli::installInterruptHandler();  // before any thread starts
    WorkerThreadsJoin workers;       // joined when main returns, before the exit handlers run
    CLI::App app{"gpisvdb: geometry processing on Gaussian Process Implicit Surfaces (GPIS), on OpenVDB"};
    app.set_version_flag("--version", std::string("gpisvdb ") + GPISVDB_VERSION);
    app.require_subcommand(1);
    app.footer(
        "Run 'gpisvdb COMMAND --help' for the flags and examples of each command.\n"
        "Exit codes: 0 success, 1 error (one line on stderr, no output left behind), 2 usage error,\n"
        "130 interrupted (SIGINT, Ctrl-C), 143 terminated (SIGTERM): stops within a second, no output left behind.\n"
        "Example:\n  gpisvdb demo -o demo-output");
    cli::Action action;
    cli::addInfo(app, action);
    cli::addEvaluate(app, action);
    cli::addDemo(app, action);
    cli::addBand(app, action);
    cli::addGreen(app, action);
    cli::addSpectrum(app, action);
    cli::addRegress(app, action);
    cli::addGeodesic(app, action);
    cli::addHodge(app, action);
    cli::addDistance(app, action);
    cli::addMesh(app, action);
    cli::addRender(app, action);
    cli::addSample(app, action);
    cli::addSurfaces(app, action);
    cli::addQuery(app, action);
    cli::addConvert(app, action);
    if (const auto code = cli::parseCommandLine(app, argc, argv)) return *code;
    return cli::runCommand(action, [](const std::string& message, bool interrupted) {
        cli::removeCommittedOutputs();  // all of a command's outputs or none
        if (interrupted) cli::reportInterrupted("gpisvdb: " + message + "\n");
        else std::cerr << "gpisvdb: " << message << "\n";
    });
}
