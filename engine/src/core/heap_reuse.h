#pragma once
// glibc's malloc thresholds, which the engine fixes (solve/boomer_amg.cpp), and a scope that raises them while a stage
// allocates and frees large arrays batch after batch (docs/memory.md#heap-reuse).
#include <cstddef>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace gpisvdb {

/// glibc's own start values for the mmap and trim thresholds (it raises them as blocks are freed, but once set they
/// stay fixed): blocks from 128 KiB up are fresh pages from the kernel and go back to it when freed.
constexpr int kMallocThresholdBytes = 128 * 1024;

/// Returns the free pages of malloc's heap to the kernel (malloc_trim); no-op outside glibc.
inline void returnFreedPages() {
#if defined(__GLIBC__)
    malloc_trim(0);
#endif
}

/// While alive, blocks below 32 MiB (glibc's ceiling for its own raised threshold) come from malloc's heap and are
/// reused when freed, instead of being mapped, page-faulted in (≈ 6 µs per 4 KiB page, measured on a virtual
/// machine) and unmapped each time; free memory at the heap's top is kept up to 64 MiB. On exit the thresholds go
/// back and the free pages to the kernel (malloc_trim). Process-wide, as mallopt is: a concurrent stage elsewhere
/// only sees a different allocation policy. No-op outside glibc.
class ScopedHeapReuse {
public:
    ScopedHeapReuse() { set(32 << 20, 64 << 20); }
    ~ScopedHeapReuse() {
        set(kMallocThresholdBytes, kMallocThresholdBytes);
        returnFreedPages();
    }
    ScopedHeapReuse(const ScopedHeapReuse&) = delete;
    ScopedHeapReuse& operator=(const ScopedHeapReuse&) = delete;

private:
    static void set([[maybe_unused]] int mmapThreshold, [[maybe_unused]] int trimThreshold) {
#if defined(__GLIBC__)
        mallopt(M_MMAP_THRESHOLD, mmapThreshold);
        mallopt(M_TRIM_THRESHOLD, trimThreshold);
#endif
    }
};

}  // namespace gpisvdb
