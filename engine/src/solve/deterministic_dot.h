#pragma once
// Σ a_i b_i in double for the solvers' vectors: the deterministic reduction splits [0, n) by `grain` alone, so the
// sum is bitwise the same for any thread count.
#include <cstddef>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>
#include <tbb/partitioner.h>

namespace gpisvdb::detail {

template <class T>
double deterministicDot(const T* a, const T* b, std::size_t n, std::size_t grain = 4096) {
    return tbb::parallel_deterministic_reduce(
        tbb::blocked_range<std::size_t>(0, n, grain), 0.0,
        [&](const tbb::blocked_range<std::size_t>& r, double s) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) s += double(a[i]) * double(b[i]);
            return s;
        },
        [](double x, double y) { return x + y; }, tbb::simple_partitioner());
}

}  // namespace gpisvdb::detail
