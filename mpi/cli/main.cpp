// gpisvdb-mpi: gpisvdb's band, green, spectrum, geodesic and regress across MPI ranks (docs/mpi.md). Run under mpirun (or alone: one rank).
// Exit codes as gpisvdb's. An error every rank knows of (the input, a parameter, the output on rank 0, a memory
// refusal) is printed once, by rank 0, and every rank exits 1 leaving no output; an error one rank met alone is
// printed by that rank, which then ends the job (MPI_Abort).
#include <slepcsys.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "common.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/worker_threads.h"
#include "gpisvdb/mpi/petsc_laplacian.h"
#include "gpisvdb/mpi/ranks.h"
#include "mpi_commands.h"

namespace {

int run(int argc, char** argv, const gpisvdb::mpi::Ranks& ranks) {
    using namespace gpisvdb;
    CLI::App app{"gpisvdb-mpi: gpisvdb's band, green, spectrum, geodesic and regress commands across MPI ranks (PETSc, hypre, SLEPc)"};
    app.set_version_flag("--version", std::string("gpisvdb-mpi ") + GPISVDB_VERSION);
    app.require_subcommand(1);
    app.footer(
        "Run under mpirun; every rank reads the input. Exit codes as gpisvdb's.\n"
        "Example:\n  mpirun -n 4 gpisvdb-mpi green bunny.obj --source 0.5,6,1 -o green.vdb --threads 1");
    cli::Action action;
    cli::addMpiBand(app, action, ranks);
    cli::addMpiGreen(app, action, ranks);
    cli::addMpiSpectrum(app, action, ranks);
    cli::addMpiGeodesic(app, action, ranks);
    cli::addMpiRegress(app, action, ranks);
    const bool speaks = ranks.rank == 0;
    if (const auto code = cli::parseCommandLine(app, argc, argv, speaks)) return *code;  // every rank parses alike
    const auto fail = [&](const std::string& message) {
        cli::removeCommittedOutputs();
        if (mpi::errorsAgreed()) {
            if (speaks) std::cerr << "gpisvdb-mpi: " << message << "\n";
            return;
        }
        std::cerr << "gpisvdb-mpi: rank " << ranks.rank << ": " << message << std::endl;
        MPI_Abort(ranks.comm, 1);  // the other ranks may wait in a collective for this one
    };
    return cli::runCommand(action, [&](const std::string& message, bool) { fail(message); });
}

}  // namespace

int main(int argc, char** argv) {
    gpisvdb::cli::installInterruptHandler("gpisvdb-mpi");  // before any thread starts
    int provided = 0;
    if (MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) {
        std::cerr << "gpisvdb-mpi: error: MPI could not start\n";
        return 1;
    }
    if (SlepcInitializeNoArguments() != 0) {  // PETSc's too
        std::cerr << "gpisvdb-mpi: error: PETSc/SLEPc could not start\n";
        MPI_Finalize();
        return 1;
    }
    gpisvdb::mpi::quietPetscErrors();
    int code = 0;
    {
        gpisvdb::WorkerThreadsJoin workers;  // joined at the end of this block, before PETSc, MPI and exit stop
        const gpisvdb::mpi::Ranks ranks(MPI_COMM_WORLD);
        code = run(argc, argv, ranks);
    }
    if (gpisvdb::cli::interruptRequested()) {
        // After Ctrl-C mpirun tears the job down and SIGKILLs ranks that are still alive a second later (Open MPI's
        // odls_base_sigkill_timeout); finalizing would wait on it. The outputs are already removed: leave now.
        std::cout.flush();
        std::cerr.flush();
        std::fflush(nullptr);
        std::_Exit(code);
    }
    SlepcFinalize();
    MPI_Finalize();
    return code;
}
