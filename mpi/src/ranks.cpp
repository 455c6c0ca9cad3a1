#include "gpisvdb/mpi/ranks.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <map>
#include <mutex>
#include <string>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::mpi {

Ranks::Ranks(MPI_Comm c) : comm(c) {
    MPI_Comm_rank(comm, &rank);
    MPI_Comm_size(comm, &size);
}

bool& errorsAgreed() {
    static bool agreed = false;
    return agreed;
}

namespace {

// The exception types a rank's failure is rebuilt as on the others (in the order they are tried: most derived first).
enum Kind : int { kCancelled = 1, kMemory, kParameter, kInput, kOutput, kError, kInternal };

Kind kindOf(const std::exception_ptr& e) {
    try {
        std::rethrow_exception(e);
    } catch (const Cancelled&) {
        return kCancelled;
    } catch (const MemoryLimitError&) {
        return kMemory;
    } catch (const ParameterError&) {
        return kParameter;
    } catch (const InputError&) {
        return kInput;
    } catch (const OutputError&) {
        return kOutput;
    } catch (const Error&) {
        return kError;
    } catch (...) {
        return kInternal;
    }
}

std::string messageOf(const std::exception_ptr& e) {
    try {
        std::rethrow_exception(e);
    } catch (const std::exception& x) {
        return x.what();
    } catch (...) {
        return "an unknown exception";
    }
}

/// The Options fields an Error names (Error::parameters), one per line: the front end maps them to its flags.
std::string parametersOf(const std::exception_ptr& e) {
    try {
        std::rethrow_exception(e);
    } catch (const Error& x) {
        std::string joined;
        for (const std::string& p : x.parameters()) joined += (joined.empty() ? "" : "\n") + p;
        return joined;
    } catch (...) {
        return {};
    }
}

void broadcast(std::string& text, int root, MPI_Comm comm) {
    int length = int(text.size());
    MPI_Bcast(&length, 1, MPI_INT, root, comm);
    text.resize(std::size_t(length));
    MPI_Bcast(text.data(), length, MPI_CHAR, root, comm);
}

[[noreturn]] void rethrowAs(int kind, const std::string& message, const std::string& parameters, int rank) {
    errorsAgreed() = true;
    const std::string m = kind == kInternal ? "internal error on rank " + std::to_string(rank) + ": " + message : message;
    std::vector<std::string> fields;
    for (std::size_t at = 0; at < parameters.size();) {
        const std::size_t end = std::min(parameters.find('\n', at), parameters.size());
        fields.push_back(parameters.substr(at, end - at));
        at = end + 1;
    }
    switch (kind) {
        case kCancelled: throw Cancelled();
        case kMemory: throw MemoryLimitError(m, fields);
        case kParameter: throw ParameterError(m, fields);
        case kInput: throw InputError(m, fields);
        case kOutput: throw OutputError(m, fields);
        default: throw Error(m, fields);
    }
}

}  // namespace

void together(const Ranks& ranks, const std::function<void()>& work) {
    std::exception_ptr failure;
    try {
        work();
    } catch (...) {
        failure = std::current_exception();
    }
    // === Agree: the lowest failing rank, if any
    const int failing = failure ? ranks.rank : ranks.size;
    int first = ranks.size;
    MPI_Allreduce(&failing, &first, 1, MPI_INT, MPI_MIN, ranks.comm);
    if (first == ranks.size) return;
    // === Its error, sent to every rank; each throws it (the failing rank its own exception)
    const bool mine = failure && first == ranks.rank;
    int kind = mine ? kindOf(failure) : 0;
    std::string message = mine ? messageOf(failure) : std::string(), parameters = mine ? parametersOf(failure) : std::string();
    MPI_Bcast(&kind, 1, MPI_INT, first, ranks.comm);
    broadcast(message, first, ranks.comm);
    broadcast(parameters, first, ranks.comm);
    errorsAgreed() = true;
    if (mine && kind != kInternal) std::rethrow_exception(failure);
    rethrowAs(kind, message, parameters, first);
}

namespace detail {

MPI_Datatype bytesType(std::size_t size) {
    static std::mutex lock;
    static std::map<std::size_t, MPI_Datatype> types;
    std::lock_guard<std::mutex> guard(lock);
    auto it = types.find(size);
    if (it != types.end()) return it->second;
    MPI_Datatype t;
    MPI_Type_contiguous(int(size), MPI_BYTE, &t);
    MPI_Type_commit(&t);
    return types.emplace(size, t).first->second;
}

void timed(const Ranks& ranks, double bytes, const std::function<void()>& call) {
    const auto start = std::chrono::steady_clock::now();
    call();
    ranks.secondsExchanging += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ranks.bytesSent += bytes;
}

}  // namespace detail

double sum(const Ranks& ranks, double value) {
    double out = 0;
    MPI_Allreduce(&value, &out, 1, MPI_DOUBLE, MPI_SUM, ranks.comm);
    return out;
}
std::size_t sum(const Ranks& ranks, std::size_t value) {
    unsigned long long v = value, out = 0;
    MPI_Allreduce(&v, &out, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, ranks.comm);
    return std::size_t(out);
}
double max(const Ranks& ranks, double value) {
    double out = 0;
    MPI_Allreduce(&value, &out, 1, MPI_DOUBLE, MPI_MAX, ranks.comm);
    return out;
}
std::size_t max(const Ranks& ranks, std::size_t value) {
    unsigned long long v = value, out = 0;
    MPI_Allreduce(&v, &out, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, ranks.comm);
    return std::size_t(out);
}

}  // namespace gpisvdb::mpi
