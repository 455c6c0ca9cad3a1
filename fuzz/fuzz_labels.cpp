// libFuzzer target: the regression model's labels file (x,y,z,label[,noise] rows; `--model regression --labels`).
#include "fuzz_common.h"
#include "gpisvdb/model/regression_gpis.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
    return gpisvdb::fuzz::readAsFile(data, size, ".csv", [](const std::string& path) {
        const gpisvdb::LabelledPoints t = gpisvdb::readLabelledPoints(path);
        if (t.label.size() != t.size() || (!t.noise.empty() && t.noise.size() != t.size())) std::abort();
    });
}
