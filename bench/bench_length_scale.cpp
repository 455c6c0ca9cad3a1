// The length scale ℓ of a point cloud (docs/math.md#length-scale): candidates side by side on clouds whose
// spacing is known, against the truth √(A / N) (A the surface's area, N the points on it).
// Clouds: a unit sphere sampled at random, evenly (a Fibonacci lattice), at two densities (the upper half 10×
// denser) and at random with 1 % outliers in [−2, 2]³; a torus (major 3, minor 1) sampled along scan lines with
// spacings across / along = 1, 3, 10, 30 (procedural.h's scanLineTorus); the data/ clouds (no known truth).
// Candidates: the mean nearest-neighbour distance (ℓ before); √ of the mean, median and 99 %-trimmed mean of the
// cylinder areas, the cylinder fixed (areaDoublings 0) or growing across scan lines (the default); the median
// k-NN radius √(π r_16² / 16). The chosen ℓ is cloudSamples' own. Times: cloudSamples with the fixed and the
// growing cylinder, medians of --repeat runs alternated, on each cloud and on a random sphere of --big points (with
// and without 1 % outliers).
// Usage: bench_length_scale [--points N (default 20000)] [--big N (default 1000000, 0: none)] [--repeat R (3)]
//        [--data DIR] [--out bench/results/length_scale.json]
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <nanoflann.hpp>
#include <nlohmann/json.hpp>
#include <random>

#include "gpisvdb/input/point_cloud.h"
#include "gpisvdb/input/procedural.h"
#include "gpisvdb/input/read_input.h"

#include "timing.h"

using namespace gpisvdb;

namespace {

struct Adaptor {
    const std::vector<Vec3d>& pts;
    std::size_t kdtree_get_point_count() const { return pts.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][int(d)]; }
    template <class B>
    bool kdtree_get_bbox(B&) const {
        return false;
    }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>, Adaptor, 3, std::size_t>;

Vec3d randomDirection(std::mt19937_64& rng) {
    std::normal_distribution<double> g;
    return Vec3d(g(rng), g(rng), g(rng)).normalized();
}

PointCloud sphereRandom(std::size_t n, std::mt19937_64& rng) {
    PointCloud c;
    for (std::size_t i = 0; i < n; ++i) {
        const Vec3d d = randomDirection(rng);
        c.positions.push_back(d);
        c.normals.push_back(d);
    }
    return c;
}

PointCloud sphereFibonacci(std::size_t n) {
    PointCloud c;
    const double golden = M_PI * (3.0 - std::sqrt(5.0));
    for (std::size_t i = 0; i < n; ++i) {
        const double z = 1.0 - (2.0 * double(i) + 1.0) / double(n), r = std::sqrt(1.0 - z * z), a = golden * double(i);
        const Vec3d d(r * std::cos(a), r * std::sin(a), z);
        c.positions.push_back(d);
        c.normals.push_back(d);
    }
    return c;
}

/// The upper half (z > 0) 10 × denser than the lower: n points in all.
PointCloud sphereTwoDensities(std::size_t n, std::mt19937_64& rng) {
    PointCloud c;
    const std::size_t upper = n * 10 / 11;
    while (c.positions.size() < n) {
        Vec3d d = randomDirection(rng);
        const bool wantUpper = c.positions.size() < upper;
        if ((d.z() > 0) != wantUpper) d.z() = -d.z();
        c.positions.push_back(d);
        c.normals.push_back(d);
    }
    return c;
}

PointCloud withOutliers(PointCloud c, std::size_t outliers, std::mt19937_64& rng) {
    std::uniform_real_distribution<double> box(-2.0, 2.0);
    for (std::size_t i = 0; i < outliers; ++i) {
        c.positions.emplace_back(box(rng), box(rng), box(rng));
        c.normals.push_back(randomDirection(rng));
    }
    return c;
}

double median(std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return v[v.size() / 2];
}

double mean(const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return s / double(v.size());
}

double trimmedMean(std::vector<double> v) {
    const std::size_t kept = v.size() - v.size() / 100;
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(kept - 1), v.end());
    v.resize(kept);
    return mean(v);
}

std::vector<double> areasOf(const Samples& s) {
    std::vector<double> a;
    for (const Vec3d& w : s.normal) a.push_back(w.norm());
    return a;
}

nlohmann::json measure(const std::string& name, const PointCloud& cloud, double truth, int repeat) {
    Adaptor adaptor{cloud.positions};
    Tree tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    tree.buildIndex();
    const std::size_t n = cloud.positions.size(), k = 16;
    std::vector<double> nearest(n), knn(n), d2(k + 1);
    std::vector<std::size_t> idx(k + 1);
    for (std::size_t i = 0; i < n; ++i) {
        tree.knnSearch(cloud.positions[i].data(), k + 1, idx.data(), d2.data());
        nearest[i] = std::sqrt(d2[1]);
        knn[i] = std::sqrt(M_PI * d2[k] / double(k));
    }
    CloudNoiseOptions fixed;
    fixed.areaDoublings = 0;
    Samples grown, fixedSamples;
    std::vector<double> tGrown, tFixed;
    for (int r = 0; r < repeat; ++r) {
        auto t0 = bench::Clock::now();
        fixedSamples = cloudSamples(cloud, fixed).samples;
        tFixed.push_back(bench::seconds(t0));
        t0 = bench::Clock::now();
        grown = cloudSamples(cloud).samples;
        tGrown.push_back(bench::seconds(t0));
    }
    const std::vector<double> aGrown = areasOf(grown), aFixed = areasOf(fixedSamples);
    nlohmann::json row = {
        {"cloud", name},
        {"points", n},
        {"ell", grown.lengthScale},
        {"mean_nearest_neighbour", mean(nearest)},
        {"sqrt_mean_area_fixed", std::sqrt(mean(aFixed))},
        {"sqrt_trimmed_mean_area_fixed", std::sqrt(trimmedMean(aFixed))},
        {"sqrt_mean_area", std::sqrt(mean(aGrown))},
        {"sqrt_trimmed_mean_area", std::sqrt(trimmedMean(aGrown))},
        {"sqrt_median_area", std::sqrt(median(aGrown))},
        {"median_knn16_radius", median(knn)},
        {"seconds_fixed", median(tFixed)},
        {"seconds_grown", median(tGrown)},
    };
    if (truth > 0) {
        row["truth"] = truth;
        nlohmann::json ratio;
        for (const char* key : {"ell", "mean_nearest_neighbour", "sqrt_mean_area_fixed", "sqrt_trimmed_mean_area_fixed", "sqrt_mean_area",
                                "sqrt_trimmed_mean_area", "sqrt_median_area", "median_knn16_radius"})
            ratio[key] = row[key].get<double>() / truth;
        row["ratio_to_truth"] = ratio;
    }
    std::cerr << name << ": " << row.dump() << "\n";
    return row;
}

}  // namespace

int main(int argc, char** argv) {
    std::size_t points = 20000, big = 1000000;
    int repeat = 3;
    std::string data = "data", out = "bench/results/length_scale.json";
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string a = argv[i], v = argv[i + 1];
        if (a == "--points") points = std::size_t(std::stod(v));
        else if (a == "--big") big = std::size_t(std::stod(v));
        else if (a == "--repeat") repeat = std::stoi(v);
        else if (a == "--data") data = v;
        else if (a == "--out") out = v;
        else {
            std::cerr << "unknown option " << a << "\n";
            return 2;
        }
    }
    std::mt19937_64 rng(7);
    const double sphereArea = 4 * M_PI, torusArea = 4 * M_PI * M_PI * 3.0;
    nlohmann::json rows = nlohmann::json::array();
    const auto sphereTruth = [&](std::size_t n) { return std::sqrt(sphereArea / double(n)); };
    rows.push_back(measure("sphere, random", sphereRandom(points, rng), sphereTruth(points), repeat));
    rows.push_back(measure("sphere, Fibonacci lattice", sphereFibonacci(points), sphereTruth(points), repeat));
    rows.push_back(measure("sphere, upper half 10x denser", sphereTwoDensities(points, rng), sphereTruth(points), repeat));
    rows.push_back(
        measure("sphere, random, 1 % outliers", withOutliers(sphereRandom(points, rng), points / 100, rng), sphereTruth(points), repeat));
    for (double ratio : {1.0, 3.0, 10.0, 30.0}) {
        const double cell = torusArea / double(points), across = std::sqrt(cell * ratio), along = across / ratio;
        const PointCloud c = scanLineTorus(along, across);
        rows.push_back(measure("torus, scan lines, across/along " + std::to_string(int(ratio)), c,
                               std::sqrt(torusArea / double(c.positions.size())), repeat));
    }
    for (const char* file : {"kitten.xyz", "sphere_20k_normal.xyz"})
        rows.push_back(measure(file, *readInput(data + "/" + file).cloud, 0, repeat));
    if (big > 0) {
        rows.push_back(measure("sphere, random, big", sphereRandom(big, rng), sphereTruth(big), 1));
        rows.push_back(
            measure("sphere, random, big, 1 % outliers", withOutliers(sphereRandom(big, rng), big / 100, rng), sphereTruth(big), 1));
    }
    std::ofstream(out) << nlohmann::json{{"bench", "length_scale"}, {"points", points}, {"rows", rows}}.dump(2) << "\n";
    std::cerr << "wrote " << out << "\n";
}
