// The test executable's main: Catch2's session, then TBB's worker threads joined before exit
// (core/worker_threads.h), which every test run thereby checks: a run whose workers cannot be joined fails. The
// process's scratch files are removed (GPISVDB_KEEP_TEST_FILES keeps them, to look at a failure's files).
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "gpisvdb/core/worker_threads.h"
#include "helpers.h"

int main(int argc, char** argv) {
    gpisvdb::WorkerThreadsJoin workers;
    const int failed = Catch::Session().run(argc, argv);
    if (!std::getenv("GPISVDB_KEEP_TEST_FILES")) {
        std::error_code ignored;  // a file still open elsewhere is no failure of the tests
        std::filesystem::remove_all(gpisvdb::test::scratchDirPath(), ignored);
    }
    if (!workers.join()) {
        std::cerr << "gpisvdb_tests: TBB's worker threads could not be joined at exit (core/worker_threads.h)\n";
        return 1;
    }
    return failed ? 1 : 0;
}
