#include "gpisvdb/mpi/petsc_laplacian.h"

#include <algorithm>
#include <array>
#include <string>

#include "gpisvdb/core/errors.h"

namespace gpisvdb::mpi {

void quietPetscErrors() { PetscPushErrorHandler(PetscReturnErrorHandler, nullptr); }

void checkPetsc(PetscErrorCode code, const char* what) {
    if (code == 0) return;
    const char* text = nullptr;
    PetscErrorMessage(code, &text, nullptr);
    throw Error(std::string("PETSc failed in ") + what + ": " + (text ? text : "unknown error"));
}

PetscMatrix& PetscMatrix::operator=(PetscMatrix&& o) noexcept {
    if (this != &o) {
        if (m_) MatDestroy(&m_);
        m_ = o.m_;
        o.m_ = nullptr;
    }
    return *this;
}

PetscMatrix::~PetscMatrix() {
    if (m_) MatDestroy(&m_);
}

namespace {

using Key = std::array<std::int32_t, 3>;
Key keyOf(const openvdb::Coord& c) { return {c.x(), c.y(), c.z()}; }

}  // namespace

std::vector<std::int64_t> globalStencilNeighbours(const Ranks& ranks, const DistributedBand& d) {
    const Band& band = d.local;
    const std::size_t P = std::size_t(ranks.size), n = band.size();
    std::vector<std::int64_t> out(12 * n, -1);
    std::vector<std::vector<Key>> ask(P);
    const auto neighbour = [&](std::size_t i, int k, int s) {  // x_i + e_k (s = 0) or x_i − e_k (s = 1)
        const auto& e = band.stencil[i].offset[std::size_t(k)];
        const int sign = s == 0 ? 1 : -1;
        return band.coord[i] + openvdb::Coord(sign * e[0], sign * e[1], sign * e[2]);
    };
    // === Neighbours held here: through the index tree; the others: asked of their rank (each coordinate once)
    {
        auto acc = band.index->getConstAccessor();
        for (std::size_t i = 0; i < n; ++i) {
            for (int k = 0; k < band.stencil[i].count; ++k)
                for (int s = 0; s < 2; ++s) {
                    const openvdb::Coord c = neighbour(i, k, s);
                    const int owner = d.partition.owner(c);
                    if (owner == ranks.rank) {
                        const int j = acc.getValue(c);
                        out[12 * i + std::size_t(2 * k + s)] = j >= 0 ? std::int64_t(d.offset) + j : -1;
                    } else {
                        ask[std::size_t(owner)].push_back(keyOf(c));
                    }
                }
        }
    }
    for (auto& list : ask) {
        std::sort(list.begin(), list.end());
        list.erase(std::unique(list.begin(), list.end()), list.end());
    }
    std::vector<int> from;
    const std::vector<Key> asked = allToAll(ranks, ask, &from);
    // === Answer: the linear index of each coordinate asked of this rank, −1 outside the band
    std::vector<std::vector<std::int64_t>> answer(P);
    {
        auto acc = band.index->getConstAccessor();
        std::size_t at = 0;
        for (std::size_t r = 0; r < P; ++r)
            for (int q = 0; q < from[r]; ++q, ++at) {
                const int j = acc.getValue(openvdb::Coord(asked[at][0], asked[at][1], asked[at][2]));
                answer[r].push_back(j >= 0 ? std::int64_t(d.offset) + j : -1);
            }
    }
    std::vector<int> got;
    const std::vector<std::int64_t> answers = allToAll(ranks, answer, &got);
    // === Fill the remote slots: the answer to a coordinate sits at its place in the sorted list asked of its rank
    std::vector<std::size_t> base(P, 0);
    for (std::size_t r = 1; r < P; ++r) base[r] = base[r - 1] + std::size_t(got[r - 1]);
    for (std::size_t i = 0; i < n; ++i) {
        for (int k = 0; k < band.stencil[i].count; ++k)
            for (int s = 0; s < 2; ++s) {
                const openvdb::Coord c = neighbour(i, k, s);
                const std::size_t owner = std::size_t(d.partition.owner(c));
                if (int(owner) == ranks.rank) continue;
                const auto& list = ask[owner];
                const std::size_t q = std::size_t(std::lower_bound(list.begin(), list.end(), keyOf(c)) - list.begin());
                out[12 * i + std::size_t(2 * k + s)] = answers[base[owner] + q];
            }
    }
    return out;
}

PetscLaplacian assembleLaplacianPetsc(const Ranks& ranks, const DistributedBand& d) {
    const Band& band = d.local;
    const std::size_t n = band.size();
    if (d.globalSize >= std::size_t(PETSC_MAX_INT))
        throw Error(
            "the band has more voxels than this PETSc's 32-bit indices can number (2^31): build PETSc with "
            "--with-64-bit-indices, or use a coarser voxel size");
    const std::vector<std::int64_t> nb = globalStencilNeighbours(ranks, d);
    const double halfH = 0.5 * band.voxelSize;

    // === Contributions: each edge of a voxel's stencil adds w to both ends' diagonals and −w to both off-diagonal
    // entries. Rows held here are counted, then filled in place; another rank's row goes to it as a triplet.
    struct Triplet {
        std::int64_t row, col;
        double value;
    };
    const std::int64_t first = std::int64_t(d.offset), last = first + std::int64_t(n);
    std::vector<std::int64_t> rankStart(d.counts.size() + 1, 0);
    for (std::size_t r = 0; r < d.counts.size(); ++r) rankStart[r + 1] = rankStart[r] + std::int64_t(d.counts[r]);
    const auto rankOf = [&](std::int64_t j) {
        return std::size_t(std::upper_bound(rankStart.begin(), rankStart.end(), j) - rankStart.begin()) - 1;
    };
    std::vector<double> diagonal(n, 0.0);
    std::vector<std::vector<Triplet>> toRank(std::size_t(ranks.size));
    std::vector<PetscInt> start(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i)
        for (int slot = 0; slot < 2 * band.stencil[i].count; ++slot) {
            const double w = halfH * double(band.stencil[i].weight[std::size_t(slot / 2)]);
            diagonal[i] += w;  // u = 0 outside the band: an edge leaving it adds to the diagonal only
            const std::int64_t j = nb[12 * i + std::size_t(slot)];
            if (j < 0) continue;
            ++start[i + 1];
            if (j >= first && j < last) {
                diagonal[std::size_t(j - first)] += w;
                ++start[std::size_t(j - first) + 1];
            } else {
                auto& list = toRank[rankOf(j)];
                list.push_back({j, j, w});
                list.push_back({j, first + std::int64_t(i), -w});
            }
        }
    const std::vector<Triplet> received = allToAll(ranks, toRank);
    std::vector<std::vector<Triplet>>().swap(toRank);
    for (const Triplet& t : received)
        if (t.row == t.col) diagonal[std::size_t(t.row - first)] += t.value;
        else ++start[std::size_t(t.row - first) + 1];
    for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i] + 1;  // + the diagonal
    std::vector<PetscInt> column(static_cast<std::size_t>(start[n]));
    std::vector<PetscScalar> value(static_cast<std::size_t>(start[n]));
    {
        std::vector<PetscInt> cursor(start.begin(), start.end() - 1);
        const auto put = [&](std::size_t row, std::int64_t col, double v) {
            column[std::size_t(cursor[row])] = PetscInt(col), value[std::size_t(cursor[row]++)] = v;
        };
        for (std::size_t i = 0; i < n; ++i) put(i, first + std::int64_t(i), diagonal[i]);
        for (std::size_t i = 0; i < n; ++i)
            for (int slot = 0; slot < 2 * band.stencil[i].count; ++slot) {
                const std::int64_t j = nb[12 * i + std::size_t(slot)];
                if (j < 0) continue;
                const double w = halfH * double(band.stencil[i].weight[std::size_t(slot / 2)]);
                put(i, j, -w);
                if (j >= first && j < last) put(std::size_t(j - first), first + std::int64_t(i), -w);
            }
        for (const Triplet& t : received)
            if (t.row != t.col) put(std::size_t(t.row - first), t.col, t.value);
    }
    // === Each row sorted by column, equal columns summed: the compressed rows PETSc takes
    std::vector<PetscInt> rowStart(n + 1, 0);
    {
        std::vector<std::pair<PetscInt, PetscScalar>> row;
        PetscInt at = 0;
        for (std::size_t i = 0; i < n; ++i) {
            row.clear();
            for (PetscInt e = start[i]; e < start[i + 1]; ++e) row.emplace_back(column[std::size_t(e)], value[std::size_t(e)]);
            std::stable_sort(row.begin(), row.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
            rowStart[i] = at;
            for (const auto& [c, v] : row) {
                if (at > rowStart[i] && column[std::size_t(at - 1)] == c) value[std::size_t(at - 1)] += v;
                else column[std::size_t(at)] = c, value[std::size_t(at++)] = v;
            }
        }
        rowStart[n] = at;
    }

    Mat L = nullptr;
    checkPetsc(MatCreateMPIAIJWithArrays(ranks.comm, PetscInt(n), PetscInt(n), PetscInt(d.globalSize), PetscInt(d.globalSize),
                                         rowStart.data(), column.data(), value.data(), &L),
               "MatCreateMPIAIJWithArrays");
    PetscLaplacian out;
    out.L = PetscMatrix(L);
    checkPetsc(MatSetOption(L, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
    checkPetsc(MatSetOption(L, MAT_SPD, PETSC_TRUE), "MatSetOption");
    // === The halo: the off-diagonal block's columns are the other ranks' unknowns a product reads here
    Mat Ad = nullptr, Ao = nullptr;
    const PetscInt* garray = nullptr;
    checkPetsc(MatMPIAIJGetSeqAIJ(L, &Ad, &Ao, &garray), "MatMPIAIJGetSeqAIJ");
    PetscInt rows = 0, cols = 0;
    checkPetsc(MatGetSize(Ao, &rows, &cols), "MatGetSize");
    out.ghosts = std::size_t(cols);
    return out;
}

}  // namespace gpisvdb::mpi
