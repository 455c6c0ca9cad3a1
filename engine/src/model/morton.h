#pragma once
// Morton (Z-order) keys: nearby points get nearby keys. An implementation header of the model's batch paths.
#include <cstdint>

namespace gpisvdb::detail {

/// Interleaves the bits of three 21-bit integers.
inline std::uint64_t morton(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
    auto spread = [](std::uint64_t v) {
        v &= 0x1fffff;
        v = (v | v << 32) & 0x1f00000000ffffULL;
        v = (v | v << 16) & 0x1f0000ff0000ffULL;
        v = (v | v << 8) & 0x100f00f00f00f00fULL;
        v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
        v = (v | v << 2) & 0x1249249249249249ULL;
        return v;
    };
    return spread(a) | spread(b) << 1 | spread(c) << 2;
}

}  // namespace gpisvdb::detail
