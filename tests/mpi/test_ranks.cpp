// mpi/include/gpisvdb/mpi/ranks.h: gathers and exchanges deliver every rank's data in rank order, and an error on one
// rank reaches every rank with its type, message and parameters, so that none waits in a collective.
#include <catch2/catch.hpp>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/mpi/ranks.h"

using namespace gpisvdb;

namespace {
struct Item {  // plain data, as the helpers require
    int from, k;
    bool operator==(const Item& o) const { return from == o.from && k == o.k; }
};
}  // namespace

TEST_CASE("ranks: allGather and gatherToRoot concatenate every rank's data in rank order", "[ranks]") {
    const mpi::Ranks ranks;
    REQUIRE(ranks.size >= 2);
    const std::vector<int> mine(std::size_t(ranks.rank + 1), ranks.rank);  // rank r sends r + 1 copies of r
    std::vector<int> counts;
    const std::vector<int> all = mpi::allGather(ranks, mine, &counts);
    std::vector<int> expected;
    for (int r = 0; r < ranks.size; ++r) expected.insert(expected.end(), std::size_t(r + 1), r);
    CHECK(all == expected);
    CHECK(counts.size() == std::size_t(ranks.size));
    const std::vector<int> root = mpi::gatherToRoot(ranks, mine);
    CHECK(root == (ranks.rank == 0 ? expected : std::vector<int>{}));
    CHECK(mpi::sum(ranks, std::size_t(ranks.rank)) == std::size_t(ranks.size * (ranks.size - 1) / 2));
    CHECK(mpi::max(ranks, double(ranks.rank)) == double(ranks.size - 1));
}

TEST_CASE("ranks: allToAll delivers toEach[r] to rank r, received in the senders' order", "[ranks]") {
    const mpi::Ranks ranks;
    std::vector<std::vector<Item>> toEach(std::size_t(ranks.size));
    for (int r = 0; r < ranks.size; ++r)
        for (int k = 0; k <= r; ++k) toEach[std::size_t(r)].push_back({ranks.rank, k});  // rank r gets r + 1 from each
    std::vector<int> from;
    const auto got = mpi::allToAll(ranks, toEach, &from);
    std::vector<Item> expected;
    for (int s = 0; s < ranks.size; ++s)
        for (int k = 0; k <= ranks.rank; ++k) expected.push_back({s, k});
    CHECK(got == expected);
    CHECK(from == std::vector<int>(std::size_t(ranks.size), ranks.rank + 1));
    CHECK(ranks.bytesSent > 0);
}

TEST_CASE("ranks: together throws on every rank the lowest failing rank's error, its type, message and parameters", "[ranks]") {
    const mpi::Ranks ranks;
    mpi::errorsAgreed() = false;
    CHECK_NOTHROW(mpi::together(ranks, [] {}));
    CHECK_FALSE(mpi::errorsAgreed());
    // Ranks 1 and 2 fail (2 with another error): every rank sees rank 1's
    try {
        mpi::together(ranks, [&] {
            if (ranks.rank == 1)
                throw ParameterError("the voxel size (BandOptions::voxelSize) is bad on rank 1", {"BandOptions::voxelSize"});
            if (ranks.rank == 2) throw InputError("rank 2's input");
        });
        FAIL("together returned although rank 1 failed");
    } catch (const ParameterError& e) {
        CHECK(std::string(e.what()) == "the voxel size (BandOptions::voxelSize) is bad on rank 1");
        CHECK(e.parameters() == std::vector<std::string>{"BandOptions::voxelSize"});
    }
    CHECK(mpi::errorsAgreed());
    // A cancellation stays a cancellation; a foreign exception becomes an internal error naming its rank
    CHECK_THROWS_AS(mpi::together(ranks,
                                  [&] {
                                      if (ranks.rank == ranks.size - 1) throw Cancelled();
                                  }),
                    Cancelled);
    try {
        mpi::together(ranks, [&] {
            if (ranks.rank == 1) throw std::runtime_error("boom");
        });
        FAIL("together returned although rank 1 failed");
    } catch (const Error& e) {
        CHECK(std::string(e.what()).find(ranks.rank == 1 ? "boom" : "internal error on rank 1: boom") != std::string::npos);
    } catch (const std::runtime_error& e) {
        CHECK(ranks.rank == 1);  // the failing rank keeps its own exception
    }
}
