#include "gpisvdb/input/read_input.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "gpisvdb/core/errors.h"
#include "readers.h"

namespace gpisvdb {

namespace detail {

[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& message) {
    throw InputError(path + (line ? ":" + std::to_string(line) : std::string()) + ": " + message);
}

std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path, 0, "cannot open the file for reading");
    std::ostringstream ss;
    ss << in.rdbuf();
    std::string bytes = ss.str();
    if (bytes.find_first_not_of(" \t\r\n") == std::string::npos) fail(path, 0, "the file is empty");
    return bytes;
}

bool looksBinary(const std::string& bytes) {
    const std::size_t n = std::min<std::size_t>(bytes.size(), 4096);
    for (std::size_t i = 0; i < n; ++i) {
        const unsigned char c = static_cast<unsigned char>(bytes[i]);
        if (c == 0 || (c < 32 && c != '\n' && c != '\r' && c != '\t' && c != '\f' && c != '\v')) return true;
    }
    return false;
}

double parseFinite(const std::string& token, const std::string& path, std::size_t line, const char* what) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') fail(path, line, std::string("expected a number for ") + what + ", got '" + token + "'");
    if (!std::isfinite(v)) fail(path, line, std::string("non-finite ") + what + " '" + token + "'");
    return v;
}

void addPolygon(InputData& data, const std::vector<int>& corners) {
    if (corners.size() > 3) ++data.polygonsTriangulated;
    for (std::size_t k = 1; k + 1 < corners.size(); ++k) data.soup->triangles.push_back({corners[0], corners[k], corners[k + 1]});
}

void checkFinite(const std::string& path, const std::vector<Vec3d>& points, const char* what) {
    for (std::size_t i = 0; i < points.size(); ++i)
        if (!points[i].allFinite()) fail(path, 0, std::string("non-finite ") + what + " at index " + std::to_string(i));
}

void checkSampleCount(const std::string& path, std::size_t count, const std::string& what) {
    if (count > kMaxInputSamples)
        throw InputError(path + ": " + std::to_string(count) + " " + what + ", more than the " + numberText(double(kMaxInputSamples)) +
                         " samples an input may hold: decimate or subsample it first");
}

}  // namespace detail

InputData readInput(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (!fs::exists(path, ec)) throw InputError(path + ": no such file");
    if (fs::is_directory(path, ec)) throw InputError(path + ": is a directory, expected a mesh or point-cloud file");
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    InputData data;
    if (ext == ".obj") data = detail::readObj(path);
    else if (ext == ".off") data = detail::readOff(path);
    else if (ext == ".ply") data = detail::readPly(path);
    else if (ext == ".stl") data = detail::readStl(path);
    else if (ext == ".xyz") data = detail::readXyz(path);
    else if (ext == ".vtp") data = detail::readVtp(path);
    else if (ext == ".gdp") data = detail::readGdp(path);
    else
        throw InputError(path + ": unknown extension '" + ext +
                         "' (meshes: .obj .off .ply .stl .vtp; oriented clouds: .xyz .ply .vtp; Gaussian dipoles: .gdp)");
    data.path = path;
    detail::checkSampleCount(path,
                             data.soup    ? data.soup->triangles.size()
                             : data.cloud ? data.cloud->positions.size()
                                          : 0,
                             data.soup ? "triangles" : "points");
    if (data.soup) {
        if (data.soup->triangles.empty()) throw InputError(path + ": the mesh has no faces");
        detail::checkFinite(path, data.soup->vertices, "vertex coordinate");
    } else if (data.cloud) {
        if (data.cloud->positions.empty()) throw InputError(path + ": the point cloud has no points");
        detail::checkFinite(path, data.cloud->positions, "point coordinate");
        if (data.cloud->normals.size() != data.cloud->positions.size())
            throw InputError(path + ": the point cloud has no normals (an oriented cloud needs nx ny nz per point)");
        detail::checkFinite(path, data.cloud->normals, "normal");
        for (double s : data.cloud->sigmas)
            if (!(s > 0) || !std::isfinite(s)) throw InputError(path + ": per-point sigma must be finite and > 0");
        for (double v : data.cloud->positionVariances)
            if (!(v > 0) || !std::isfinite(v)) throw InputError(path + ": per-point position variance must be finite and > 0");
    }
    return data;
}

double samplesBytes(std::size_t n) { return double(n) * double(2 * sizeof(Vec3d) + sizeof(double) + sizeof(Sym3)); }

std::vector<std::pair<std::string, double>> makeSamplesBytes(const InputData& input) {
    if (input.soup) return {{"samples", samplesBytes(input.soup->triangles.size())}};
    if (input.cloud) {
        const std::size_t n = input.cloud->positions.size();
        return {{"samples", samplesBytes(n)}, {"spacing_and_areas", cloudSamplingBytes(n)}};
    }
    return {};
}

InputSamples makeSamples(const InputData& input, const NoiseOptions& options) {
    InputSamples out;
    detail::checkSampleCount(input.path,
                             input.soup    ? input.soup->triangles.size()
                             : input.cloud ? input.cloud->positions.size()
                                           : 0,
                             input.soup ? "triangles" : "points");
    if (input.soup) {
        SoupSamples s = soupSamples(*input.soup, {options.sigmaRel});
        out.samples = std::move(s.samples);
        out.sigma = s.sigma;
        out.degenerateSkipped = s.degenerateSkipped;
        out.isSoup = true;
    } else if (input.cloud) {
        CloudNoiseOptions co;
        co.sigmaRel = options.sigmaRel;
        CloudSamples s = cloudSamples(*input.cloud, co);
        out.samples = std::move(s.samples);
        out.sigma = s.sigma;
        out.absoluteNoise = !input.cloud->sigmas.empty() || !input.cloud->positionVariances.empty();
        out.lengthScaleGiven = input.cloud->lengthScale > 0;
    } else {
        throw InputError(input.path + ": holds neither a mesh nor a point cloud");
    }
    return out;
}

}  // namespace gpisvdb
