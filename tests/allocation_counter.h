#pragma once
// Counts heap allocations of at least a given size made while a CountLargeAllocations object lives (every
// malloc-family call of the test process passes through allocation_counter.cpp, or through the sanitizer's
// allocation hook in a sanitizer build). One at a time.
#include <cstddef>

namespace gpisvdb::test {

class CountLargeAllocations {
public:
    explicit CountLargeAllocations(std::size_t minBytes);
    ~CountLargeAllocations();
    std::size_t count() const;
};

}  // namespace gpisvdb::test
