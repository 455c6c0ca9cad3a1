#pragma once
// The SIMD lanes of the Barnes–Hut packets (docs/model.md#packets): one double per point of a packet, GCC vector
// extensions, and erf and exp in lanes from glibc's libmvec (core/vector_math.h). An implementation header of
// barnes_hut_packet.cpp, its only includer: its helpers are inlined into each instruction-set clone of the traversal.
#include <cmath>
#include <cstdint>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "core/vector_math.h"
#include "gpisvdb/model/barnes_hut_gpis.h"

namespace gpisvdb {

namespace {

// Helpers are inlined into the traversal so that each of its clones (barnes_hut_packet.cpp) compiles them for its own instruction set.
#define GPISVDB_LANES_INLINE __attribute__((always_inline)) inline
#pragma GCC diagnostic ignored "-Wpsabi"  // Lanes never cross a call: every function taking them is inlined

// One clone of the traversal (and of its near field) per instruction set, chosen once at load time (GCC function
// multi-versioning): the same binary runs everywhere and uses AVX-512 or AVX2 where the CPU has them. The AVX-512 and
// AVX2 clones contract multiply-adds into FMA (≈ 9 % faster) and erf and exp come from libmvec's variant for the CPU,
// so results may differ between CPUs in the last bits (as libm's scalar exp already does between CPUs with and without
// FMA); on one CPU they never depend on the thread count.
#ifdef GPISVDB_PACKET_CLONES
// defined by the build (empty: one clone, for comparisons)
#elif defined(__SANITIZE_THREAD__)
// ThreadSanitizer instruments the clones' ifunc resolver, which the loader runs before the sanitizer's runtime is
// set up (the executable crashed at load): one clone there (the same code, at the baseline instruction set).
#define GPISVDB_PACKET_CLONES
#elif defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define GPISVDB_PACKET_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define GPISVDB_PACKET_CLONES
#endif

constexpr int kLanes = BarnesHutGpis::kPacket;
// One double per point of the packet. GCC/Clang vector extensions: the compiler maps the 8 lanes to whatever the
// target has (4 SSE2, 2 AVX or 1 AVX-512 instruction per operation).
typedef double Lanes __attribute__((vector_size(kLanes * sizeof(double))));
using LaneMask = std::uint32_t;  // bit l: lane l
constexpr LaneMask kAllLanes = (1u << kLanes) - 1;

GPISVDB_LANES_INLINE Lanes splat(double v) {
    Lanes r;
    for (int l = 0; l < kLanes; ++l) r[l] = v;
    return r;
}

/// 1 in the lanes of `mask`, 0 elsewhere: terms are multiplied by it (every term is finite in every lane).
GPISVDB_LANES_INLINE Lanes select(LaneMask mask) {
    Lanes r;
    for (int l = 0; l < kLanes; ++l) r[l] = (mask >> l) & 1u ? 1.0 : 0.0;
    return r;
}

struct LaneVec3 {
    Lanes v[3];
    const Lanes& operator[](int i) const { return v[i]; }
    Lanes& operator[](int i) { return v[i]; }
};

GPISVDB_LANES_INLINE Lanes dot(const LaneVec3& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

struct LaneKernel {
    Lanes F1, F2, F3, F4;
};

// === erf and exp for 8 lanes at once: core/vector_math.h's libmvec lanes, chosen once for the CPU.
GPISVDB_LANES_INLINE void erfExp(const double* x, const double* y, double* ex, double* ey) { erfExp8(x, y, ex, ey); }

/// The symmetric 4×4 accumulators: the mean (γ, ∇γ) and the upper triangle of the covariance.
struct LaneSums {
    Lanes mean[4];
    Lanes cov[4][4];  // only a ≤ b is used
    LaneSums() {
        for (auto& m : mean) m = splat(0);
        for (auto& row : cov)
            for (auto& c : row) c = splat(0);
    }
};

}  // namespace

}  // namespace gpisvdb
