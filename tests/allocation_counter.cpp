// Counts heap allocations of at least a threshold while a counter is active.
//  - Normal builds interpose the malloc family for the test executable (glibc: the executable's definitions win
//    over libc's, and __libc_* are the real allocator).
//  - Sanitizer builds (AddressSanitizer, ThreadSanitizer) must not: their runtime owns malloc, calls it while it
//    initialises (before this file's globals and shadow memory exist: the interposer crashed every run of the
//    test executable, and CTest's discovery of the Catch2 cases with it), and memory from __libc_malloc would
//    reach the sanitizer's free. There the sanitizer's own allocation hook counts the same requests.
#include "allocation_counter.h"

#include <atomic>
#include <cerrno>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define GPISVDB_SANITIZER_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define GPISVDB_SANITIZER_ALLOCATOR 1
#endif
#endif

#ifdef GPISVDB_SANITIZER_ALLOCATOR
// From the sanitizers' allocator_interface.h, which GCC 12 does not install (libasan and libtsan export it).
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, std::size_t),
                                                         void (*free_hook)(const volatile void*));
#endif

namespace {
std::atomic<std::size_t> gThreshold{0};  // 0: not counting
std::atomic<std::size_t> gCount{0};

inline void note(std::size_t bytes) {
    const std::size_t t = gThreshold.load(std::memory_order_relaxed);
    if (t != 0 && bytes >= t) gCount.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

#ifdef GPISVDB_SANITIZER_ALLOCATOR
namespace {
// Called by the sanitizer's allocator for every malloc, calloc, realloc, aligned allocation and operator new.
void onAllocation(const volatile void*, std::size_t bytes) { note(bytes); }
void onFree(const volatile void*) {}
void installHook() {
    static const bool installed = __sanitizer_install_malloc_and_free_hooks(onAllocation, onFree) != 0;
    (void)installed;
}
}  // namespace
#else
extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);

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
namespace {
void installHook() {}
}  // namespace
#endif

namespace gpisvdb::test {

CountLargeAllocations::CountLargeAllocations(std::size_t minBytes) {
    installHook();
    gCount = 0;
    gThreshold = minBytes ? minBytes : 1;
}
CountLargeAllocations::~CountLargeAllocations() { gThreshold = 0; }
std::size_t CountLargeAllocations::count() const { return gCount.load(); }

}  // namespace gpisvdb::test
