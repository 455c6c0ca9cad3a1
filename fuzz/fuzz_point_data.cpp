// libFuzzer target: the CSV point-data reader (x,y,z,value[,noise] rows; `regress --data`).
#include "fuzz_common.h"
#include "gpisvdb/input/point_data.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    return gpisvdb::fuzz::readAsFile(data, size, ".csv", [](const std::string& path) { gpisvdb::readPointData(path); });
}
