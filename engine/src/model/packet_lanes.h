#pragma once
// The SIMD lanes of the Barnes–Hut packets (docs/model.md#packets): one double per point of a packet, GCC vector
// extensions, and erf and exp in lanes from glibc's libmvec (core/vector_math.h). An implementation header of
// barnes_hut_packet.cpp, its only includer: its helpers are inlined into each instruction-set clone of the traversal.
#include <cmath>
#include <cstdint>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "core/simd_lanes.h"
#include "core/vector_math.h"
#include "gpisvdb/model/barnes_hut_gpis.h"

namespace gpisvdb {

namespace {

// Helpers are inlined into the traversal so that each of its clones (barnes_hut_packet.cpp) compiles them for its own instruction set.
#define GPISVDB_LANES_INLINE __attribute__((always_inline)) inline
// One clone of the traversal (and of its near field) per instruction set: GPISVDB_SIMD_CLONES (core/simd_lanes.h).

constexpr int kLanes = BarnesHutGpis::kPacket;
static_assert(kLanes == simd::kLanes, "a packet's points are the SIMD lanes");
// One double per point of the packet. GCC/Clang vector extensions: the compiler maps the 8 lanes to whatever the
// target has (4 SSE2, 2 AVX or 1 AVX-512 instruction per operation).
using Lanes = simd::Lanes;
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
