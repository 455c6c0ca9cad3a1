#pragma once
// The SIMD lanes of the engine's vectorised loops (the Barnes–Hut packets, the Kac–Rice QMC sums, the box spline's
// corners, the plausible surfaces' draws): eight doubles as a GCC vector type, and one clone of each vectorised
// function per instruction set. An implementation header of engine/src.
//
// GCC function multi-versioning chooses a clone once at load time: the same binary runs everywhere and uses AVX-512
// (the 8 lanes are one register) or AVX2 where the CPU has them. The AVX-512 and AVX2 clones contract multiply-adds
// into FMA and erf and exp come from libmvec's variant for the CPU (core/vector_math.h), so results may differ
// between CPUs in the last bits (as libm's scalar exp already does between CPUs with and without FMA); on one CPU
// they never depend on the thread count.
#ifdef GPISVDB_SIMD_CLONES
// defined by the build (empty: one clone, for comparisons)
#elif defined(__SANITIZE_THREAD__)
// ThreadSanitizer instruments the clones' ifunc resolver, which the loader runs before the sanitizer's runtime is
// set up (the executable crashed at load): one clone there (the same code, at the baseline instruction set).
#define GPISVDB_SIMD_CLONES
#elif defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define GPISVDB_SIMD_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define GPISVDB_SIMD_CLONES
#endif
#pragma GCC diagnostic ignored "-Wpsabi"  // lanes never cross a call: the functions taking them are inlined

namespace gpisvdb::simd {

constexpr int kLanes = 8;
typedef double Lanes __attribute__((vector_size(kLanes * sizeof(double))));
typedef unsigned long long ULanes __attribute__((vector_size(kLanes * sizeof(unsigned long long))));

}  // namespace gpisvdb::simd
