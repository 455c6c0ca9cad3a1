// libFuzzer target: the .gdp reader (Gaussian dipoles), through readInput (the parser and the covariances' checks).
#include "fuzz_common.h"
#include "gpisvdb/input/read_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    return gpisvdb::fuzz::readAsFile(data, size, ".gdp", [](const std::string& path) { gpisvdb::readInput(path); });
}
