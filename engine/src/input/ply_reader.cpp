// PLY (ascii and binary, either endianness). Parsed here because VTK's reader keeps only a fixed set of
// vertex properties and we need arbitrary ones (per-point `sigma`, `area`).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <sstream>

#include "gpisvdb/core/errors.h"
#include "readers.h"

namespace gpisvdb::detail {

namespace {

enum class Type { I8, U8, I16, U16, I32, U32, F32, F64 };

struct Property {
    std::string name;
    Type type = Type::F32;
    bool isList = false;
    Type countType = Type::U8;
};
struct Element {
    std::string name;
    std::size_t count = 0;
    std::vector<Property> props;
};

int typeSize(Type t) {
    switch (t) {
        case Type::I8:
        case Type::U8: return 1;
        case Type::I16:
        case Type::U16: return 2;
        case Type::I32:
        case Type::U32:
        case Type::F32: return 4;
        case Type::F64: return 8;
    }
    return 0;
}

bool parseType(const std::string& s, Type& t) {
    static const std::map<std::string, Type> types = {
        {"char", Type::I8},   {"int8", Type::I8},     {"uchar", Type::U8},   {"uint8", Type::U8},
        {"short", Type::I16}, {"int16", Type::I16},   {"ushort", Type::U16}, {"uint16", Type::U16},
        {"int", Type::I32},   {"int32", Type::I32},   {"uint", Type::U32},   {"uint32", Type::U32},
        {"float", Type::F32}, {"float32", Type::F32}, {"double", Type::F64}, {"float64", Type::F64}};
    auto it = types.find(s);
    if (it == types.end()) return false;
    t = it->second;
    return true;
}

/// Reads values one at a time from the body, ascii or binary.
class Body {
public:
    Body(const std::string& bytes, std::size_t offset, int format, const std::string& path)
        : bytes_(bytes), pos_(offset), format_(format), path_(path) {
        if (format_ == 0) text_.str(bytes_.substr(offset));
    }
    double read(Type t) {
        if (format_ == 0) {
            std::string tok;
            if (!(text_ >> tok)) fail(path_, 0, "the file ends before all elements were read");
            return parseFinite(tok, path_, 0, "value");
        }
        const int n = typeSize(t);
        if (pos_ + std::size_t(n) > bytes_.size()) fail(path_, 0, "the file ends before all elements were read");
        unsigned char b[8];
        std::memcpy(b, bytes_.data() + pos_, std::size_t(n));
        pos_ += std::size_t(n);
        const bool little = format_ == 1;
        const bool hostLittle = [] {
            const uint16_t x = 1;
            return *reinterpret_cast<const uint8_t*>(&x) == 1;
        }();
        if (little != hostLittle) std::reverse(b, b + n);
        switch (t) {
            case Type::I8: {
                int8_t v;
                std::memcpy(&v, b, 1);
                return v;
            }
            case Type::U8: {
                uint8_t v;
                std::memcpy(&v, b, 1);
                return v;
            }
            case Type::I16: {
                int16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case Type::U16: {
                uint16_t v;
                std::memcpy(&v, b, 2);
                return v;
            }
            case Type::I32: {
                int32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::U32: {
                uint32_t v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::F32: {
                float v;
                std::memcpy(&v, b, 4);
                return v;
            }
            case Type::F64: {
                double v;
                std::memcpy(&v, b, 8);
                return v;
            }
        }
        return 0;
    }

private:
    const std::string& bytes_;
    std::size_t pos_;
    int format_;  // 0 ascii, 1 little endian, 2 big endian
    const std::string& path_;
    std::istringstream text_;
};

}  // namespace

InputData readPly(const std::string& path) {
    const std::string bytes = slurp(path);
    if (bytes.compare(0, 3, "ply") != 0) fail(path, 1, "missing the 'ply' magic: not a PLY file?");
    const std::size_t endHeader = bytes.find("end_header");
    if (endHeader == std::string::npos) fail(path, 0, "no 'end_header': not a PLY file?");
    std::size_t bodyStart = bytes.find('\n', endHeader);
    bodyStart = bodyStart == std::string::npos ? bytes.size() : bodyStart + 1;

    // === Header
    std::istringstream header(bytes.substr(0, endHeader));
    std::vector<Element> elements;
    int format = -1;
    std::string line;
    for (std::size_t ln = 1; std::getline(header, line); ++ln) {
        std::istringstream ls(line);
        std::string kw;
        ls >> kw;
        if (kw == "format") {
            std::string f;
            ls >> f;
            format = f == "ascii" ? 0 : f == "binary_little_endian" ? 1 : f == "binary_big_endian" ? 2 : -1;
            if (format < 0) fail(path, ln, "unknown PLY format '" + f + "'");
        } else if (kw == "element") {
            Element e;
            long long count = -1;
            ls >> e.name >> count;
            if (count < 0) fail(path, ln, "invalid element count");
            for (const Element& other : elements)
                if (other.name == e.name && (e.name == "vertex" || e.name == "face")) fail(path, ln, "a second '" + e.name + "' element");
            e.count = std::size_t(count);
            if (e.name == "vertex" || e.name == "face") checkSampleCount(path, e.count, e.name + " elements declared");
            elements.push_back(e);
        } else if (kw == "property") {
            if (elements.empty()) fail(path, ln, "a property before any element");
            Property p;
            std::string t;
            ls >> t;
            if (t == "list") {
                std::string ct, it;
                ls >> ct >> it >> p.name;
                p.isList = true;
                if (!parseType(ct, p.countType) || !parseType(it, p.type)) fail(path, ln, "unknown list property type");
            } else {
                ls >> p.name;
                if (!parseType(t, p.type)) fail(path, ln, "unknown property type '" + t + "'");
            }
            elements.back().props.push_back(p);
        } else if (!kw.empty() && kw != "ply" && kw != "comment" && kw != "obj_info") {
            fail(path, ln, "unexpected header line '" + line + "'");
        }
    }
    if (format < 0) fail(path, 0, "the header has no 'format' line");
    for (const Element& e : elements)  // such an element reads nothing: a huge count would loop for ever
        if (e.count > 0 && e.props.empty()) fail(path, 0, "element '" + e.name + "' has no properties");

    // === Body
    Body body(bytes, bodyStart, format, path);
    std::vector<std::vector<double>> vertexProps;  // per vertex, per scalar property
    std::map<std::string, int> vertexIndex;
    std::vector<std::vector<double>> faces;
    for (const Element& e : elements) {
        const bool isVertex = e.name == "vertex", isFace = e.name == "face";
        if (isVertex)
            for (std::size_t k = 0; k < e.props.size(); ++k) vertexIndex[e.props[k].name] = int(k);
        for (std::size_t i = 0; i < e.count; ++i) {
            std::vector<double> scalars(e.props.size(), 0.0);
            for (std::size_t k = 0; k < e.props.size(); ++k) {
                const Property& p = e.props[k];
                if (!p.isList) {
                    scalars[k] = body.read(p.type);
                    continue;
                }
                const double n = body.read(p.countType);
                if (!(n >= 0 && n <= 1e6) || n != std::floor(n)) fail(path, 0, "invalid list length in element '" + e.name + "'");
                std::vector<double> list(static_cast<std::size_t>(n));  // doubles: checked before any cast to int
                for (auto& v : list) v = body.read(p.type);
                if (isFace && (p.name == "vertex_indices" || p.name == "vertex_index")) faces.push_back(std::move(list));
            }
            if (isVertex) vertexProps.push_back(std::move(scalars));
        }
    }

    // === Assemble a soup (faces present) or an oriented cloud
    auto column = [&](const char* name) {
        auto it = vertexIndex.find(name);
        return it == vertexIndex.end() ? -1 : it->second;
    };
    const int ix = column("x"), iy = column("y"), iz = column("z");
    if (ix < 0 || iy < 0 || iz < 0) fail(path, 0, "the vertex element lacks x, y or z");
    std::vector<Vec3d> points;
    for (const auto& v : vertexProps) points.emplace_back(v[ix], v[iy], v[iz]);
    InputData data;
    if (!faces.empty()) {
        data.soup.emplace();
        data.soup->vertices = std::move(points);
        const long nv = long(data.soup->vertices.size());
        for (const auto& f : faces) {
            if (f.size() < 3) fail(path, 0, "a face needs at least 3 corners");
            std::vector<int> corners;
            for (double c : f) {
                if (!(c >= 0 && c < double(nv)))
                    fail(path, 0, "face index " + numberText(c) + " is out of range (the file has " + std::to_string(nv) + " vertices)");
                if (c != std::floor(c)) fail(path, 0, "face index " + numberText(c) + " is not an integer");
                corners.push_back(int(c));
            }
            addPolygon(data, corners);
        }
        return data;
    }
    data.cloud.emplace();
    data.cloud->positions = std::move(points);
    const int inx = column("nx"), iny = column("ny"), inz = column("nz");
    if (inx >= 0 && iny >= 0 && inz >= 0)
        for (const auto& v : vertexProps) data.cloud->normals.emplace_back(v[inx], v[iny], v[inz]);
    if (const int is = column("sigma"); is >= 0)
        for (const auto& v : vertexProps) data.cloud->sigmas.push_back(v[is]);
    if (const int ia = column("area"); ia >= 0)
        for (const auto& v : vertexProps) data.cloud->areas.push_back(v[ia]);
    return data;
}

}  // namespace gpisvdb::detail
