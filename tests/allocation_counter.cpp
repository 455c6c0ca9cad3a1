// Interposes the malloc family for the test executable (glibc: the executable's definitions win over libc's, and
// __libc_* are the real allocator), counting requests of at least a threshold while a counter is active.
#include "allocation_counter.h"

#include <atomic>
#include <cerrno>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
}

namespace {
std::atomic<std::size_t> gThreshold{0};  // 0: not counting
std::atomic<std::size_t> gCount{0};

inline void note(std::size_t bytes) {
    const std::size_t t = gThreshold.load(std::memory_order_relaxed);
    if (t != 0 && bytes >= t) gCount.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(std::size_t n) {
    note(n);
    return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
    note(a * b);
    return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
    note(n);
    return __libc_realloc(p, n);
}
void* memalign(std::size_t a, std::size_t n) {
    note(n);
    return __libc_memalign(a, n);
}
void* aligned_alloc(std::size_t a, std::size_t n) {
    note(n);
    return __libc_memalign(a, n);
}
int posix_memalign(void** p, std::size_t a, std::size_t n) {
    note(n);
    *p = __libc_memalign(a, n);
    return *p ? 0 : ENOMEM;
}
}

namespace gpisvdb::test {

CountLargeAllocations::CountLargeAllocations(std::size_t minBytes) {
    gCount = 0;
    gThreshold = minBytes ? minBytes : 1;
}
CountLargeAllocations::~CountLargeAllocations() { gThreshold = 0; }
std::size_t CountLargeAllocations::count() const { return gCount.load(); }

}  // namespace gpisvdb::test
