#pragma once
// Wall-clock helpers shared by the benchmarks: seconds since a time point, and the median of repeated runs.
#include <algorithm>
#include <chrono>
#include <vector>

namespace gpisvdb::bench {

using Clock = std::chrono::steady_clock;

inline double seconds(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Median wall time of `repeat` calls of f (at least one).
template <class F>
double medianSeconds(int repeat, F&& f) {
    std::vector<double> t;
    for (int r = 0; r < std::max(1, repeat); ++r) {
        const auto t0 = Clock::now();
        f();
        t.push_back(seconds(t0));
    }
    std::sort(t.begin(), t.end());
    return t[t.size() / 2];
}

}  // namespace gpisvdb::bench
