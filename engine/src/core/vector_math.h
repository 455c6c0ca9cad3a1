#pragma once
// erf and exp over arrays, eight at a time in SIMD lanes from glibc's vector math library (libmvec) at the widest
// width the CPU has, chosen once; elsewhere (other compilers or architectures) the scalar functions. For code that
// needs many values at once outside the Barnes–Hut packets (whose lanes inline their own, model/packet_lanes.h).
// Results may differ from the scalar functions' in the last bits, never between thread counts.
#include <cstddef>

namespace gpisvdb {

/// erfOut[i] = erf(x[i]), expOut[i] = exp(y[i]) for i < 8: one step of the lanes.
void erfExp8(const double* x, const double* y, double* erfOut, double* expOut);

/// erfOut[i] = erf(x[i]), expOut[i] = exp(y[i]) for i < n.
void erfExpArrays(std::size_t n, const double* x, const double* y, double* erfOut, double* expOut);

}  // namespace gpisvdb
