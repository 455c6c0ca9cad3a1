#pragma once
// The end of a program's parallel work: TBB's worker threads joined before the process exits.
#include <tbb/global_control.h>

#include <new>

namespace gpisvdb {

/// Joins TBB's worker threads in `join()` (or its destructor), at the end of `main`. Without it the workers are
/// told to stop by the TBB library's own shutdown, during `exit`, and may still be stopping while the other exit
/// handlers run: LeakSanitizer's leak check, one of them, stops every thread and now and then dies on a thread
/// half-way through exiting (docs/sanitizers.md#the-leak-check-at-exit). Make one at the start of `main`, before
/// any parallel work, and let it outlive every `tbb::global_control`.
class WorkerThreadsJoin {
public:
    WorkerThreadsJoin() : handle_(tbb::attach{}) {}
    WorkerThreadsJoin(const WorkerThreadsJoin&) = delete;
    WorkerThreadsJoin& operator=(const WorkerThreadsJoin&) = delete;
    ~WorkerThreadsJoin() { join(); }

    /// Waits until every worker thread has exited. False when TBB could not join them (another thread still holds
    /// the scheduler, or this is called inside parallel work); the workers are then left to the library's shutdown.
    /// Later calls return the first call's answer.
    bool join() {
        if (handle_) joined_ = tbb::finalize(handle_, std::nothrow);
        return joined_;
    }

private:
    tbb::task_scheduler_handle handle_;
    bool joined_ = false;
};

}  // namespace gpisvdb
