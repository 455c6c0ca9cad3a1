// The test executable's main: Catch2's session, then TBB's worker threads joined before exit
// (core/worker_threads.h), which every test run thereby checks: a run whose workers cannot be joined fails.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>
#include <iostream>

#include "gpisvdb/core/worker_threads.h"

int main(int argc, char** argv) {
    gpisvdb::WorkerThreadsJoin workers;
    const int failed = Catch::Session().run(argc, argv);
    if (!workers.join()) {
        std::cerr << "gpisvdb_tests: TBB's worker threads could not be joined at exit (core/worker_threads.h)\n";
        return 1;
    }
    return failed ? 1 : 0;
}
