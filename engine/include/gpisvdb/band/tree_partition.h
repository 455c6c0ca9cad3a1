#pragma once
// The band's linear order and its cuts among processes (docs/mpi.md#band). A band's linear indices follow
// OpenVDB's value-on iteration over its index tree (Band::coord): 8³ leaves, 16³ of them in a 128³ node, 32³ of
// those in a 4096³ node, each level x-major, the 4096³ nodes in lexicographic order of their origins. That order
// is a space-filling curve of nested blocks, so a contiguous range of it is a compact set of leaves; cutting it
// into ranges gives each process a piece of the band whose linear indices, offset by the counts before it, are the
// one-process band's own.
#include <cstddef>
#include <utility>
#include <vector>

#include <openvdb/openvdb.h>

namespace gpisvdb {

/// Whether a comes before b in a band's linear order (OpenVDB's Tree4<·, 5, 4, 3> value-on order; index space).
bool treeOrderLess(const openvdb::Coord& a, const openvdb::Coord& b);

/// The origin of the 8³ leaf holding c (index space).
inline openvdb::Coord leafOrigin(const openvdb::Coord& c) { return openvdb::Coord(c.x() & ~7, c.y() & ~7, c.z() & ~7); }

/// The linear order cut into `parts()` contiguous ranges: part p holds the coordinates c with
/// first[p] ≤ c < first[p + 1] in tree order (part 0 from the start, the last part to the end).
struct TreePartition {
    std::vector<openvdb::Coord> first;  ///< first[p] for p ≥ 1 (first[0] is ignored: part 0 starts at the beginning)
    int parts() const { return int(first.size()); }
    /// The part holding c (binary search over first).
    int owner(const openvdb::Coord& c) const;
};

/// Cuts leaves with weights (each leaf given by its origin; any order, distinct) into `parts` ranges of nearly equal
/// weight, at leaf boundaries: range p ends at the first leaf where the running weight reaches (p + 1)/parts of the
/// total. Throws ParameterError for parts < 1; with no leaves every coordinate goes to part 0.
TreePartition partitionLeaves(std::vector<std::pair<openvdb::Coord, double>> leaves, int parts);

}  // namespace gpisvdb
