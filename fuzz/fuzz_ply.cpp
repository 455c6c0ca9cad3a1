// libFuzzer target: the PLY reader (ascii and binary, either endianness), through readInput (the format's parser and the checks on what it
// read).
#include "fuzz_common.h"
#include "gpisvdb/input/read_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    return gpisvdb::fuzz::readAsFile(data, size, ".ply", [](const std::string& path) { gpisvdb::readInput(path); });
}
