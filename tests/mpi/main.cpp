// The MPI pieces' own tests (mpi/): one Catch2 run per rank under mpirun (tests/CMakeLists.txt runs them on 3 ranks);
// a failure on any rank fails the job.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>
#include <mpi.h>

int main(int argc, char** argv) {
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &provided);
    const int failed = Catch::Session().run(argc, argv);
    int anyFailed = 0;
    MPI_Allreduce(&failed, &anyFailed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    MPI_Finalize();
    return anyFailed ? 1 : 0;
}
