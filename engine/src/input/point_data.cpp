#include "gpisvdb/input/point_data.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& message) {
    throw InputError(path + ":" + std::to_string(line) + ": " + message);
}

/// The fields of a row split at commas, semicolons or whitespace.
std::vector<std::string> fields(const std::string& line) {
    std::vector<std::string> out;
    std::string current;
    for (char c : line) {
        if (c == ',' || c == ';' || std::isspace(static_cast<unsigned char>(c))) {
            if (!current.empty()) out.push_back(current);
            current.clear();
        } else {
            current += c;
        }
    }
    if (!current.empty()) out.push_back(current);
    return out;
}

bool parse(const std::string& token, double& v) {
    char* end = nullptr;
    v = std::strtod(token.c_str(), &end);
    return end != token.c_str() && *end == '\0';
}

}  // namespace

PointData readPointData(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw InputError(path + ": no such file");
    if (std::filesystem::is_directory(path, ec)) throw InputError(path + ": is a directory, expected a CSV of x,y,z,value[,noise]");
    std::ifstream in(path);
    if (!in) throw InputError(path + ": cannot be opened");
    PointData data;
    std::string line;
    std::size_t lineNo = 0;
    bool firstRow = true;
    while (std::getline(in, line)) {
        ++lineNo;
        const std::vector<std::string> f = fields(line);
        if (f.empty() || f[0][0] == '#') continue;
        double x[5];
        bool numeric = true;
        for (std::size_t i = 0; i < f.size() && i < 5; ++i) numeric = numeric && parse(f[i], x[i]);
        if (!numeric && firstRow) {  // a header
            firstRow = false;
            continue;
        }
        firstRow = false;
        if (f.size() != 4 && f.size() != 5)
            fail(path, lineNo, "expected 4 or 5 columns (x,y,z,value[,noise]), got " + std::to_string(f.size()));
        if (!numeric) fail(path, lineNo, "expected numbers in x,y,z,value[,noise]");
        for (std::size_t i = 0; i < f.size(); ++i)
            if (!std::isfinite(x[i])) fail(path, lineNo, "non-finite number '" + f[i] + "'");
        const double noise = f.size() == 5 ? x[4] : 0.0;
        if (noise < 0) fail(path, lineNo, "the noise (standard deviation) must be ≥ 0");
        data.position.emplace_back(x[0], x[1], x[2]);
        data.value.push_back(x[3]);
        data.noise.push_back(noise);
    }
    if (data.value.empty()) throw InputError(path + ": no data rows (expected x,y,z,value[,noise] per line)");
    return data;
}

}  // namespace gpisvdb
