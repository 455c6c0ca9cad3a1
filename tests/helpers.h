#pragma once
// Shared test fixtures: data paths, random numbers, soups without shared vertices.
#include <unistd.h>

#include <filesystem>
#include <random>
#include <string>

#include "gpisvdb/input/read_input.h"
#include "gpisvdb/input/triangle_soup.h"

namespace gpisvdb::test {

/// Where this test process's scratch files go (CTest runs tests in parallel processes); the test main removes it at
/// exit unless GPISVDB_KEEP_TEST_FILES is set.
inline std::filesystem::path scratchDirPath() {
    return std::filesystem::temp_directory_path() / ("gpisvdb_test_" + std::to_string(getpid()));
}
/// scratchDirPath(), made if need be.
inline std::filesystem::path scratchDir() {
    const auto dir = scratchDirPath();
    std::filesystem::create_directories(dir);
    return dir;
}

inline std::string dataPath(const std::string& name) { return std::string(GPISVDB_DATA_DIR) + "/" + name; }
/// Data made for the tests alone (tests/data/README.md), not inputs users have.
inline std::string testDataPath(const std::string& name) { return std::string(GPISVDB_TEST_DATA_DIR) + "/" + name; }

/// Whether timing promises (a flag or signal stops the work within a second) are checked. Not in sanitizer
/// builds (tools/sanitize), which run the same code 10–100× slower: there the tests run every step and check every
/// other outcome, and report the latencies only.
#ifdef GPISVDB_SANITIZER_BUILD
inline constexpr bool kTimingChecked = false;
#else
inline constexpr bool kTimingChecked = true;
#endif

/// Whether measured memory (resident set, its peak) is checked against estimates. Not in sanitizer builds, whose
/// allocator adds redzones to every block, keeps freed blocks in quarantine and grows its own tables in the
/// background: there the tests run every step and report the figures only.
inline constexpr bool kMemoryChecked = kTimingChecked;

/// Every triangle with its own three vertices (a soup in the App. B sense: no shared noise).
inline TriangleSoup unshare(const TriangleSoup& s) {
    TriangleSoup out;
    for (const auto& f : s.triangles) {
        const int b = int(out.vertices.size());
        for (int k = 0; k < 3; ++k) out.vertices.push_back(s.vertices[f[k]]);
        out.triangles.push_back({b, b + 1, b + 2});
    }
    return out;
}

inline Vec3d randomUnit(std::mt19937_64& rng) {
    std::normal_distribution<double> n;
    Vec3d v(n(rng), n(rng), n(rng));
    return v.normalized();
}

/// n random points on the unit sphere (std::mt19937 from `seed`), normals radial, each with its own σ (world
/// units): a scan of a sphere as a cloud with a σ column gives it.
inline InputData sphereCloudWithSigma(int n, double sigma, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> g;
    InputData data;
    data.cloud = PointCloud{};
    for (int i = 0; i < n; ++i) {
        const Vec3d p = Vec3d(g(rng), g(rng), g(rng)).normalized();
        data.cloud->positions.push_back(p), data.cloud->normals.push_back(p), data.cloud->sigmas.push_back(sigma);
    }
    return data;
}

}  // namespace gpisvdb::test
