#pragma once
// Running engine work from Python: the GIL released, the thread count limited, Ctrl-C honoured and progress reported.
//
// The engine polls Progress::interrupted from the calling thread and from TBB workers (core/progress.h). Python's
// signal handlers run only in the main thread, when it checks for them; so the calling thread, at most every
// kPollInterval, takes the GIL back and calls PyErr_CheckSignals (which runs the handlers: the default SIGINT
// handler raises KeyboardInterrupt). An exception from a handler, or from the caller's progress callback, sets
// an atomic flag that every thread's poll reads, the engine throws Cancelled, and the Python exception is raised
// once the work has unwound, with the GIL held again. Nothing the engine built survives the interrupted call.
#include <pybind11/pybind11.h>
#include <tbb/global_control.h>

#include <atomic>
#include <chrono>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/core/progress.h"

namespace gpisvdb::python {

namespace py = pybind11;

/// How often the calling thread looks for Python signals: well under the one second a Ctrl-C may take.
constexpr std::chrono::milliseconds kPollInterval{50};

class Work {
public:
    /// threads: worker threads for this call (0: all cores); progress: None or a callable (stage: str,
    /// fraction: float), called on the calling thread with the GIL held.
    Work(int threads, py::object progress) : state_(std::make_shared<State>()) {
        if (threads < 0) throw ParameterError("threads must be >= 0 (got " + std::to_string(threads) + ")");
        if (threads > 0) limit_ = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
            throw ParameterError("progress must be None or a callable (stage: str, fraction: float)");
        state_->callback = std::move(progress);
        state_->caller = std::this_thread::get_id();
        const std::shared_ptr<State> s = state_;
        progress_.interrupted = [s] { return s->poll(); };
        progress_.report = [s](const std::string& stage, double fraction) { s->report(stage, fraction); };
    }
    ~Work() {
        py::gil_scoped_acquire gil;  // the callback and a stored exception are Python objects
        state_->callback = py::object();
        state_->error.reset();
    }

    /// f(progress) with the GIL released. Raises the Python exception a signal handler or the progress callback
    /// raised (the engine's Cancelled is then dropped); rethrows the engine's own errors for the translator.
    template <class F>
    auto operator()(F&& f) -> decltype(f(std::declval<const Progress&>())) {
        using R = decltype(f(std::declval<const Progress&>()));
        std::optional<R> result;
        std::exception_ptr failure;
        {
            py::gil_scoped_release release;
            try {
                result.emplace(f(progress_));
            } catch (...) {
                failure = std::current_exception();
            }
        }
        if (state_->error) {
            std::unique_ptr<py::error_already_set> e = std::move(state_->error);
            e->restore();
            throw py::error_already_set();
        }
        if (failure) std::rethrow_exception(failure);
        return std::move(*result);
    }

    const Progress& progress() const { return progress_; }

private:
    struct State {
        std::thread::id caller;
        std::atomic<bool> stop{false};
        std::chrono::steady_clock::time_point lastPoll{};
        py::object callback;
        std::unique_ptr<py::error_already_set> error;  // the exception to raise once the work has stopped

        /// Any thread: the flag; the calling thread also runs Python's signal handlers now and then.
        bool poll() {
            if (stop.load(std::memory_order_relaxed)) return true;
            if (std::this_thread::get_id() != caller) return false;
            const auto now = std::chrono::steady_clock::now();
            if (now - lastPoll < kPollInterval) return false;
            lastPoll = now;
            py::gil_scoped_acquire gil;
            if (PyErr_CheckSignals() != 0) keep(py::error_already_set());
            return stop.load();
        }
        /// The calling thread only (workers' reports are dropped: the callback is Python).
        void report(const std::string& stage, double fraction) {
            if (stop.load(std::memory_order_relaxed) || std::this_thread::get_id() != caller) return;
            py::gil_scoped_acquire gil;
            if (PyErr_CheckSignals() != 0) {
                keep(py::error_already_set());
                return;
            }
            if (callback.is_none() || !callback) return;
            try {
                callback(stage, fraction);
            } catch (py::error_already_set& e) {
                keep(std::move(e));
            }
        }
        void keep(py::error_already_set&& e) {
            if (!error) error = std::make_unique<py::error_already_set>(std::move(e));
            stop = true;
        }
    };
    std::shared_ptr<State> state_;
    std::unique_ptr<tbb::global_control> limit_;
    Progress progress_;
};

}  // namespace gpisvdb::python
