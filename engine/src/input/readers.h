#pragma once
// Per-format readers behind readInput(). Each throws InputError naming the file (and line where known).
#include <string>

#include "gpisvdb/input/read_input.h"

namespace gpisvdb::detail {

InputData readObj(const std::string& path);
InputData readOff(const std::string& path);
InputData readPly(const std::string& path);
InputData readXyz(const std::string& path);
InputData readStl(const std::string& path);
InputData readVtp(const std::string& path);
InputData readGdp(const std::string& path);  // gdp.cpp

/// Whole file as bytes; throws InputError when it cannot be opened or is empty.
std::string slurp(const std::string& path);
/// True when the bytes hold a NUL or other control bytes a text format never has.
bool looksBinary(const std::string& bytes);
/// Parses a finite double; throws InputError "<path>:<line>: <what> ..." otherwise.
double parseFinite(const std::string& token, const std::string& path, std::size_t line, const char* what);
[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& message);
/// Adds a polygon (corner indices already 0-based and checked) as a triangle fan.
void addPolygon(InputData& data, const std::vector<int>& corners);
/// Checks every vertex is finite; throws naming the first bad one.
void checkFinite(const std::string& path, const std::vector<Vec3d>& points, const char* what);
/// Throws InputError when `count` (vertices, faces, triangles or points, as `what` says) exceeds kMaxInputSamples.
void checkSampleCount(const std::string& path, std::size_t count, const std::string& what);

}  // namespace gpisvdb::detail
