// The band's linear order and its cuts among MPI ranks (band/tree_partition.h, docs/mpi.md#band).
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>

#include "gpisvdb/band/tree_partition.h"
#include "gpisvdb/core/errors.h"

using namespace gpisvdb;
using openvdb::Coord;

namespace {

std::vector<Coord> randomCoords(std::mt19937_64& rng, int spread, std::size_t n) {
    std::uniform_int_distribution<int> u(-spread, spread);
    std::vector<Coord> c;
    for (std::size_t i = 0; i < n; ++i) c.emplace_back(u(rng), u(rng), u(rng));
    std::sort(c.begin(), c.end());
    c.erase(std::unique(c.begin(), c.end()), c.end());
    return c;
}

}  // namespace

TEST_CASE("tree partition: treeOrderLess is the order of OpenVDB's value-on iteration over an index tree", "[tree_partition]") {
    std::mt19937_64 rng(7);
    // Spreads within one leaf, across 128³ nodes, and across 4096³ root children on both sides of the origin.
    for (const int spread : {5, 300, 20000}) {
        const std::vector<Coord> coords = randomCoords(rng, spread, 20000);
        openvdb::Int32Grid grid(-1);
        auto acc = grid.getAccessor();
        for (std::size_t i = 0; i < coords.size(); ++i) acc.setValue(coords[i], int(i));
        std::vector<Coord> visited;
        for (auto it = grid.tree().cbeginValueOn(); it; ++it) visited.push_back(it.getCoord());
        REQUIRE(visited.size() == coords.size());
        std::vector<Coord> sorted = coords;
        std::sort(sorted.begin(), sorted.end(), treeOrderLess);
        CHECK(sorted == visited);
        for (std::size_t i = 1; i < visited.size(); ++i) CHECK_FALSE(treeOrderLess(visited[i], visited[i - 1]));
    }
}

TEST_CASE("tree partition: leaves are cut into contiguous ranges of nearly equal weight", "[tree_partition]") {
    std::mt19937_64 rng(11);
    std::vector<std::pair<Coord, double>> leaves;
    std::uniform_real_distribution<double> w(0.5, 1.5);
    for (const Coord& c : randomCoords(rng, 2000, 5000)) leaves.emplace_back(leafOrigin(c), w(rng));
    std::sort(leaves.begin(), leaves.end());
    leaves.erase(std::unique(leaves.begin(), leaves.end(), [](const auto& a, const auto& b) { return a.first == b.first; }), leaves.end());
    double total = 0, heaviest = 0;
    for (const auto& l : leaves) total += l.second, heaviest = std::max(heaviest, l.second);
    for (const int parts : {1, 2, 3, 7, 64}) {
        const TreePartition p = partitionLeaves(leaves, parts);
        REQUIRE(p.parts() == parts);
        std::vector<double> weight(std::size_t(parts), 0.0);
        for (const auto& l : leaves) {
            const int owner = p.owner(l.first);
            REQUIRE(owner >= 0);
            REQUIRE(owner < parts);
            // Every voxel of a leaf goes where its origin goes
            CHECK(p.owner(l.first.offsetBy(7)) == owner);
            weight[std::size_t(owner)] += l.second;
        }
        for (const double x : weight) CHECK(std::abs(x - total / parts) <= heaviest + 1e-9);
        // Ranges are contiguous: along the tree order the owner never decreases
        std::vector<std::pair<Coord, double>> ordered = leaves;
        std::sort(ordered.begin(), ordered.end(), [](const auto& a, const auto& b) { return treeOrderLess(a.first, b.first); });
        for (std::size_t i = 1; i < ordered.size(); ++i) CHECK(p.owner(ordered[i - 1].first) <= p.owner(ordered[i].first));
    }
}

TEST_CASE("tree partition: more parts than leaves leave the extra parts empty, no leaves send all to part 0, zero parts are refused",
          "[tree_partition]") {
    const std::vector<std::pair<Coord, double>> two = {{Coord(0, 0, 0), 1.0}, {Coord(8, 0, 0), 1.0}};
    const TreePartition p = partitionLeaves(two, 5);
    std::vector<int> owners = {p.owner(Coord(0, 0, 0)), p.owner(Coord(8, 0, 0))};
    CHECK(owners[0] != owners[1]);
    CHECK(partitionLeaves({}, 3).owner(Coord(5, -3, 2)) == 0);
    CHECK_THROWS_AS(partitionLeaves(two, 0), ParameterError);
}
