#pragma once
// MPI as the distributed pieces use it (docs/mpi.md): a communicator's rank and size, vectors of plain data gathered
// and exchanged, and errors agreed on by every rank so that no rank waits forever in a collective for one that
// failed.
#include <mpi.h>

#include <cstddef>
#include <cstring>
#include <functional>
#include <type_traits>
#include <vector>

namespace gpisvdb::mpi {

/// A communicator with its rank and size, and the traffic its helpers carried.
struct Ranks {
    explicit Ranks(MPI_Comm comm = MPI_COMM_WORLD);
    MPI_Comm comm;
    int rank = 0, size = 1;
    mutable double bytesSent = 0;          ///< bytes this rank sent to other ranks through allToAll() and gathers
    mutable double secondsExchanging = 0;  ///< wall-clock seconds in those calls (waiting for slower ranks included)
};

/// Runs `work` on this rank, then agrees with every other rank on whether all succeeded (one allreduce). If any
/// threw, every rank throws the lowest failing rank's exception, rebuilt with its type (Cancelled, InputError,
/// ParameterError, MemoryLimitError, OutputError, Error), message and Error::parameters; errorsAgreed() is then true. Every rank
/// must call it the same number of times, with no collective call inside `work`.
void together(const Ranks& ranks, const std::function<void()>& work);

/// Whether the last exception thrown by together() is known to every rank (main exits cleanly then; otherwise a
/// rank-local failure must end the job with MPI_Abort).
bool& errorsAgreed();

namespace detail {
MPI_Datatype bytesType(std::size_t size);  // a contiguous type of `size` bytes, committed once per size
void timed(const Ranks& ranks, double bytes, const std::function<void()>& call);
}  // namespace detail

/// Sums over all ranks.
double sum(const Ranks& ranks, double value);
std::size_t sum(const Ranks& ranks, std::size_t value);
double max(const Ranks& ranks, double value);
std::size_t max(const Ranks& ranks, std::size_t value);

/// Every rank's `mine`, concatenated in rank order, on every rank; counts[r] = rank r's element count.
template <class T>
std::vector<T> allGather(const Ranks& ranks, const std::vector<T>& mine, std::vector<int>* counts = nullptr) {
    static_assert(std::is_trivially_copyable_v<T>);
    std::vector<int> n(std::size_t(ranks.size)), displ(std::size_t(ranks.size), 0);
    const int own = int(mine.size());
    MPI_Allgather(&own, 1, MPI_INT, n.data(), 1, MPI_INT, ranks.comm);
    for (int r = 1; r < ranks.size; ++r) displ[std::size_t(r)] = displ[std::size_t(r - 1)] + n[std::size_t(r - 1)];
    std::vector<T> all(std::size_t(displ.back() + n.back()));
    detail::timed(ranks, double(sizeof(T)) * double(mine.size()) * double(ranks.size - 1), [&] {
        MPI_Allgatherv(mine.data(), own, detail::bytesType(sizeof(T)), all.data(), n.data(), displ.data(), detail::bytesType(sizeof(T)),
                       ranks.comm);
    });
    if (counts) *counts = n;
    return all;
}

/// Every rank's `mine`, concatenated in rank order, on rank 0 (empty elsewhere).
template <class T>
std::vector<T> gatherToRoot(const Ranks& ranks, const std::vector<T>& mine) {
    static_assert(std::is_trivially_copyable_v<T>);
    std::vector<int> n(std::size_t(ranks.size)), displ(std::size_t(ranks.size), 0);
    const int own = int(mine.size());
    MPI_Gather(&own, 1, MPI_INT, n.data(), 1, MPI_INT, 0, ranks.comm);
    for (int r = 1; r < ranks.size; ++r) displ[std::size_t(r)] = displ[std::size_t(r - 1)] + n[std::size_t(r - 1)];
    std::vector<T> all(ranks.rank == 0 ? std::size_t(displ.back() + n.back()) : 0);
    detail::timed(ranks, ranks.rank == 0 ? 0.0 : double(sizeof(T)) * double(mine.size()), [&] {
        MPI_Gatherv(mine.data(), own, detail::bytesType(sizeof(T)), all.data(), n.data(), displ.data(), detail::bytesType(sizeof(T)), 0,
                    ranks.comm);
    });
    return all;
}

/// All-to-all: toEach[r] goes to rank r. Returns what every rank sent to this one, concatenated in rank order;
/// from[r] = the count that came from rank r.
template <class T>
std::vector<T> allToAll(const Ranks& ranks, const std::vector<std::vector<T>>& toEach, std::vector<int>* from = nullptr) {
    static_assert(std::is_trivially_copyable_v<T>);
    const std::size_t P = std::size_t(ranks.size);
    std::vector<int> sendCount(P), sendDispl(P, 0), recvCount(P), recvDispl(P, 0);
    std::vector<T> send;
    double remote = 0;
    for (std::size_t r = 0; r < P; ++r) {
        sendCount[r] = int(toEach[r].size());
        sendDispl[r] = int(send.size());
        send.insert(send.end(), toEach[r].begin(), toEach[r].end());
        if (int(r) != ranks.rank) remote += double(sizeof(T)) * double(toEach[r].size());
    }
    MPI_Alltoall(sendCount.data(), 1, MPI_INT, recvCount.data(), 1, MPI_INT, ranks.comm);
    for (std::size_t r = 1; r < P; ++r) recvDispl[r] = recvDispl[r - 1] + recvCount[r - 1];
    std::vector<T> received(std::size_t(recvDispl.back() + recvCount.back()));
    detail::timed(ranks, remote, [&] {
        MPI_Alltoallv(send.data(), sendCount.data(), sendDispl.data(), detail::bytesType(sizeof(T)), received.data(), recvCount.data(),
                      recvDispl.data(), detail::bytesType(sizeof(T)), ranks.comm);
    });
    if (from) *from = recvCount;
    return received;
}

}  // namespace gpisvdb::mpi
