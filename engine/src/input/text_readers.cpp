// OBJ, OFF and XYZ: small line-oriented text formats, parsed here so that every error can name its line.
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "readers.h"

namespace gpisvdb::detail {

namespace {

std::vector<std::string> split(const std::string& line) {
    std::vector<std::string> tokens;
    std::istringstream ss(line);
    std::string t;
    while (ss >> t) {
        if (t[0] == '#') break;
        tokens.push_back(t);
    }
    return tokens;
}

int parseIndex(const std::string& token, const std::string& path, std::size_t line) {
    char* end = nullptr;
    const long v = std::strtol(token.c_str(), &end, 10);
    if (end == token.c_str() || (*end != '\0' && *end != '/')) fail(path, line, "expected a vertex index, got '" + token + "'");
    if (v > std::numeric_limits<int>::max() || v < -long(std::numeric_limits<int>::max()))
        fail(path, line, "face index " + token + " is out of range");
    return int(v);
}

std::string requireText(const std::string& path, const char* format) {
    std::string bytes = slurp(path);
    if (looksBinary(bytes)) fail(path, 0, std::string("binary content: this is not a text ") + format + " file");
    return bytes;
}

}  // namespace

InputData readObj(const std::string& path) {
    static const std::set<std::string> known = {"v",          "vt",        "vn",       "vp",     "f",      "l",      "p",      "g",
                                                "o",          "s",         "mg",       "usemtl", "mtllib", "maplib", "usemap", "lod",
                                                "shadow_obj", "trace_obj", "cstype",   "deg",    "bmat",   "step",   "curv",   "curv2",
                                                "surf",       "parm",      "trim",     "hole",   "scrv",   "sp",     "end",    "con",
                                                "bevel",      "c_interp",  "d_interp", "call",   "csh",    "ctech",  "stech"};
    std::istringstream in(requireText(path, "OBJ"));
    InputData data;
    data.soup.emplace();
    std::vector<std::pair<std::vector<int>, std::size_t>> faces;  // raw indices, line
    std::string line;
    for (std::size_t ln = 1; std::getline(in, line); ++ln) {
        const auto tok = split(line);
        if (tok.empty()) continue;
        if (!known.count(tok[0])) fail(path, ln, "unexpected '" + tok[0] + "': not an OBJ file?");
        if (tok[0] == "v") {
            if (tok.size() < 4) fail(path, ln, "a vertex needs 3 coordinates");
            data.soup->vertices.emplace_back(parseFinite(tok[1], path, ln, "vertex coordinate"),
                                             parseFinite(tok[2], path, ln, "vertex coordinate"),
                                             parseFinite(tok[3], path, ln, "vertex coordinate"));
        } else if (tok[0] == "f") {
            if (tok.size() < 4) fail(path, ln, "a face needs at least 3 corners");
            std::vector<int> corners;
            for (std::size_t k = 1; k < tok.size(); ++k) {
                const int raw = parseIndex(tok[k], path, ln);
                // Negative indices count back from the vertices read so far.
                const long idx = raw < 0 ? long(data.soup->vertices.size()) + raw : long(raw) - 1;
                if (raw == 0 || idx < 0) fail(path, ln, "face index " + tok[k] + " is out of range");
                corners.push_back(int(idx));
            }
            faces.emplace_back(std::move(corners), ln);
        }
    }
    const long nv = long(data.soup->vertices.size());
    for (const auto& [corners, ln] : faces) {
        for (int c : corners)
            if (c >= nv)
                fail(path, ln,
                     "face index " + std::to_string(c + 1) + " is out of range (the file has " + std::to_string(nv) + " vertices)");
        addPolygon(data, corners);
    }
    return data;
}

InputData readOff(const std::string& path) {
    std::istringstream in(requireText(path, "OFF"));
    // Tokens with their line numbers, comments stripped (OFF allows counts and values across lines).
    std::vector<std::pair<std::string, std::size_t>> tok;
    std::string line;
    for (std::size_t ln = 1; std::getline(in, line); ++ln)
        for (auto& t : split(line)) tok.emplace_back(std::move(t), ln);
    std::size_t at = 0;
    auto next = [&](const char* what) -> const std::pair<std::string, std::size_t>& {
        if (at >= tok.size()) fail(path, 0, std::string("the file ends early, expected ") + what);
        return tok[at++];
    };
    const std::string head = tok.empty() ? std::string() : tok[0].first;
    if (head != "OFF" && head != "COFF" && head != "NOFF" && head != "CNOFF") fail(path, 1, "missing the OFF header: not an OFF file?");
    ++at;
    auto count = [&](const char* what) {
        const auto& [t, ln] = next(what);
        const double v = parseFinite(t, path, ln, what);
        // Checked before the cast (out of long's range it is undefined); indices are ints, so are counts.
        if (!(v >= 0 && v <= double(std::numeric_limits<int>::max())) || v != std::floor(v))
            fail(path, ln, std::string("invalid ") + what + " '" + t + "'");
        return long(v);
    };
    const long nv = count("vertex count"), nf = count("face count");
    count("edge count");
    checkSampleCount(path, std::size_t(nv), "vertices declared");  // before any allocation
    checkSampleCount(path, std::size_t(nf), "faces declared");
    InputData data;
    data.soup.emplace();
    data.soup->vertices.reserve(std::min(std::size_t(nv), tok.size() / 3));  // a count is no promise of data
    const bool colour = head == "COFF" || head == "CNOFF", normals = head == "NOFF" || head == "CNOFF";
    for (long i = 0; i < nv; ++i) {
        Vec3d p;
        for (int d = 0; d < 3; ++d) {
            const auto& [t, ln] = next("a vertex coordinate");
            p[d] = parseFinite(t, path, ln, "vertex coordinate");
        }
        at += (normals ? 3 : 0) + (colour ? 4 : 0);
        data.soup->vertices.push_back(p);
    }
    for (long f = 0; f < nf; ++f) {
        const std::size_t ln = at < tok.size() ? tok[at].second : 0;
        const long k = count("a face corner count");
        if (k < 3) fail(path, ln, "a face needs at least 3 corners");
        std::vector<int> corners;
        for (long c = 0; c < k; ++c) {
            const auto& [t, cl] = next("a face index");
            const double d = parseFinite(t, path, cl, "face index");
            if (d != std::floor(d)) fail(path, cl, "face index " + t + " is not an integer");
            if (!(d >= 0 && d < double(nv)))
                fail(path, cl, "face index " + t + " is out of range (the file has " + std::to_string(nv) + " vertices)");
            corners.push_back(int(d));
        }
        // Optional face colour: skip the rest of this line.
        while (at < tok.size() && tok[at].second == ln && ln != 0) ++at;
        addPolygon(data, corners);
    }
    return data;
}

InputData readXyz(const std::string& path) {
    std::istringstream in(requireText(path, "XYZ"));
    InputData data;
    data.cloud.emplace();
    PointCloud& c = *data.cloud;
    std::string line;
    std::size_t columns = 0;
    for (std::size_t ln = 1; std::getline(in, line); ++ln) {
        const auto tok = split(line);
        if (tok.empty()) continue;
        if (columns == 0) {
            columns = tok.size();
            if (columns == 3) fail(path, ln, "the point cloud has no normals: expected 'x y z nx ny nz [sigma]' per line");
            if (columns != 6 && columns != 7)
                fail(path, ln, "expected 6 or 7 columns 'x y z nx ny nz [sigma]', got " + std::to_string(columns));
        } else if (tok.size() != columns) {
            fail(path, ln, "expected " + std::to_string(columns) + " columns like the first line, got " + std::to_string(tok.size()));
        }
        double v[7];
        for (std::size_t k = 0; k < columns; ++k)
            v[k] = parseFinite(tok[k], path, ln, k < 3 ? "coordinate" : k < 6 ? "normal component" : "sigma");
        c.positions.emplace_back(v[0], v[1], v[2]);
        c.normals.emplace_back(v[3], v[4], v[5]);
        if (columns == 7) {
            if (!(v[6] > 0)) fail(path, ln, "sigma must be > 0");
            c.sigmas.push_back(v[6]);
        }
    }
    return data;
}

}  // namespace gpisvdb::detail
