#include "core/vector_math.h"

#include <cmath>
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#include <immintrin.h>
#endif

namespace gpisvdb {

namespace {

constexpr std::size_t kLanes = 8;

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
extern "C" {
__m128d _ZGVbN2v_erf(__m128d);
__m128d _ZGVbN2v_exp(__m128d);
__m256d _ZGVdN4v_erf(__m256d);
__m256d _ZGVdN4v_exp(__m256d);
__m512d _ZGVeN8v_erf(__m512d);
__m512d _ZGVeN8v_exp(__m512d);
}

void lanesSse(const double* x, const double* y, double* ex, double* ey) {
    for (std::size_t k = 0; k < kLanes; k += 2) {
        _mm_storeu_pd(ex + k, _ZGVbN2v_erf(_mm_loadu_pd(x + k)));
        _mm_storeu_pd(ey + k, _ZGVbN2v_exp(_mm_loadu_pd(y + k)));
    }
}
__attribute__((target("avx2"))) void lanesAvx2(const double* x, const double* y, double* ex, double* ey) {
    for (std::size_t k = 0; k < kLanes; k += 4) {
        _mm256_storeu_pd(ex + k, _ZGVdN4v_erf(_mm256_loadu_pd(x + k)));
        _mm256_storeu_pd(ey + k, _ZGVdN4v_exp(_mm256_loadu_pd(y + k)));
    }
}
__attribute__((target("avx512f"))) void lanesAvx512(const double* x, const double* y, double* ex, double* ey) {
    _mm512_storeu_pd(ex, _ZGVeN8v_erf(_mm512_loadu_pd(x)));
    _mm512_storeu_pd(ey, _ZGVeN8v_exp(_mm512_loadu_pd(y)));
}
using Lanes8 = void (*)(const double*, const double*, double*, double*);
const Lanes8 lanes8 = [] {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) return Lanes8(lanesAvx512);
    if (__builtin_cpu_supports("avx2")) return Lanes8(lanesAvx2);
    return Lanes8(lanesSse);
}();
#else
void lanes8(const double* x, const double* y, double* ex, double* ey) {
    for (std::size_t k = 0; k < kLanes; ++k) ex[k] = std::erf(x[k]), ey[k] = std::exp(y[k]);
}
#endif

}  // namespace

void erfExp8(const double* x, const double* y, double* erfOut, double* expOut) { lanes8(x, y, erfOut, expOut); }

void erfExpArrays(std::size_t n, const double* x, const double* y, double* erfOut, double* expOut) {
    std::size_t i = 0;
    for (; i + kLanes <= n; i += kLanes) lanes8(x + i, y + i, erfOut + i, expOut + i);
    if (i == n) return;
    // The tail through one more padded step, so that every value comes from the same functions.
    double xs[kLanes] = {}, ys[kLanes] = {}, ex[kLanes], ey[kLanes];
    for (std::size_t k = 0; i + k < n; ++k) xs[k] = x[i + k], ys[k] = y[i + k];
    lanes8(xs, ys, ex, ey);
    for (std::size_t k = 0; i + k < n; ++k) erfOut[i + k] = ex[k], expOut[i + k] = ey[k];
}

}  // namespace gpisvdb
