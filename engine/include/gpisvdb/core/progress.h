#pragma once
// Progress reporting and cancellation for long work: harmless by default (both callbacks empty).
#include <cstddef>
#include <functional>
#include <string>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

struct Progress {
    /// Called with a stage name and the fraction done in [0, 1]; may be empty.
    std::function<void(const std::string& stage, double fraction)> report;
    /// Returns true when the caller wants the work to stop; may be empty. Long loops poll it from TBB worker
    /// threads too (every few hundred points), so it must be thread-safe and cheap, e.g. the load of an atomic flag.
    std::function<bool()> interrupted;

    void update(const std::string& stage, double fraction) const {
        if (report) report(stage, fraction);
    }
    /// Throws Cancelled when the caller asked to stop.
    void checkInterrupt() const {
        if (interrupted && interrupted()) throw Cancelled();
    }
    /// For the body of a parallel loop, on any thread: checkInterrupt() at every `every`-th index (one branch
    /// otherwise). The Cancelled it throws cancels the rest of a tbb::parallel_for, which rethrows it in the caller
    /// once the running chunks have returned; the results of a loop that is not interrupted are unchanged.
    void checkInterruptAt(std::size_t index, std::size_t every = 256) const {
        if (index % every == 0) checkInterrupt();
    }
    /// The same cancellation without the reports: for inner steps whose own progress would garble the caller's.
    Progress interruptOnly() const {
        Progress p;
        p.interrupted = interrupted;
        return p;
    }
};

}  // namespace gpisvdb
