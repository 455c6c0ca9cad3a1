#pragma once
// Progress reporting and cancellation for long work: harmless by default (both callbacks empty).
#include <functional>
#include <string>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

struct Progress {
    /// Called with a stage name and the fraction done in [0, 1]; may be empty.
    std::function<void(const std::string& stage, double fraction)> report;
    /// Returns true when the caller wants the work to stop; may be empty.
    std::function<bool()> interrupted;

    void update(const std::string& stage, double fraction) const {
        if (report) report(stage, fraction);
    }
    /// Throws Cancelled when the caller asked to stop.
    void checkInterrupt() const {
        if (interrupted && interrupted()) throw Cancelled();
    }
};

}  // namespace gpisvdb
