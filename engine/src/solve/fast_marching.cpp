#include "gpisvdb/solve/fast_marching.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sys/mman.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "gpisvdb/band/stencil_neighbours.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kSlots = kStencilSlots;

/// Solves Σ_k λ_k max(0, U − m_k)² = h² for U, m_k the smaller accepted neighbour value of term k (+∞ if none).
/// The terms enter in increasing m_k while m_k is below the root of those already in: with f(U) = a U² − 2 b U + c
/// their sum minus h², m_k is below the larger root exactly when f(m_k) < 0, so one square root suffices.
double localSolve(const float* lambda, const double* m, int count, double h2) {
    double mk[6], lk[6];
    int terms = 0;
    for (int k = 0; k < count; ++k) {  // insertion sort by m of the usable terms: at most 6
        if (!(m[k] < kInf) || !(lambda[k] > 0)) continue;
        int q = terms++;
        for (; q > 0 && mk[q - 1] > m[k]; --q) mk[q] = mk[q - 1], lk[q] = lk[q - 1];
        mk[q] = m[k], lk[q] = lambda[k];
    }
    if (terms == 0) return kInf;
    double a = lk[0], b = lk[0] * mk[0], c = lk[0] * mk[0] * mk[0] - h2;
    for (int q = 1; q < terms; ++q) {
        if (!(a * mk[q] * mk[q] - 2 * b * mk[q] + c < 0)) break;  // m_q at or above the root: inactive
        a += lk[q];
        b += lk[q] * mk[q];
        c += lk[q] * mk[q] * mk[q];
    }
    return (b + std::sqrt(std::max(0.0, b * b - a * c))) / a;  // the larger root of a U² − 2 b U + c = 0
}

constexpr std::uint32_t kAccepted = 0xfffffffeu;

/// Reserves room for n elements and asks the kernel to back it with huge pages, before the first write touches
/// it: the march visits these arrays in front order, all over the band, and with 4 KiB pages it mostly waits on
/// address translation (measured 1.13× faster on the 100³ box of bench_geodesic).
template <class T>
void reserveHuge(std::vector<T>& v, std::size_t n) {
    v.reserve(n);
    constexpr std::uintptr_t huge = std::uintptr_t(2) << 20;
    const auto first = (reinterpret_cast<std::uintptr_t>(v.data()) + huge - 1) & ~(huge - 1);
    const auto last = (reinterpret_cast<std::uintptr_t>(v.data() + n)) & ~(huge - 1);
    if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);  // a hint: failure is harmless
}

struct Node {
    double m[6];
    float lambda[6];
};

/// Sifts of an indexed 4-ary min-heap (entries ordered by operator<): e moves up from slot i, or down from the root;
/// place(i, e) writes e at slot i and records its position wherever the caller keeps positions.
template <class Entry, class Place>
void heapSiftUp(std::vector<Entry>& heap, std::uint32_t i, const Entry& e, Place place) {
    while (i > 0) {
        const std::uint32_t parent = (i - 1) / 4;
        if (!(e < heap[parent])) break;
        place(i, heap[parent]);
        i = parent;
    }
    place(i, e);
}

template <class Entry, class Place>
void heapSiftDown(std::vector<Entry>& heap, const Entry& e, Place place) {
    const std::uint32_t size = std::uint32_t(heap.size());
    std::uint32_t i = 0;
    for (;;) {
        const std::uint32_t first = 4 * i + 1;
        if (first >= size) break;
        std::uint32_t best = first;
        for (std::uint32_t c = first + 1; c < std::min(first + 4, size); ++c)
            if (heap[c] < heap[best]) best = c;
        if (!(heap[best] < e)) break;
        place(i, heap[best]);
        i = best;
    }
    place(i, e);
}

/// The front: an indexed 4-ary min-heap of voxels ordered by (U, index), with decrease-key, so each voxel sits in
/// it once; entries carry their key, so sifting reads the heap only. Its position table also marks accepted voxels.
class Front {
public:
    static constexpr std::uint32_t kFar = 0xffffffffu;

    explicit Front(std::size_t n) {
        reserveHuge(pos_, n);
        pos_.assign(n, kFar);
    }
    bool empty() const { return heap_.empty(); }
    /// The voxel likely to be accepted next (the least one now).
    std::uint32_t peek() const { return heap_.front().voxel; }
    bool accepted(std::uint32_t x) const { return pos_[x] == kAccepted; }

    /// Inserts x with key u, or lowers its key to u.
    void update(std::uint32_t x, double u) {
        if (pos_[x] == kFar) pos_[x] = std::uint32_t(heap_.size()), heap_.push_back({u, x});
        siftUp(pos_[x], {u, x});
    }
    /// Removes the least voxel and marks it accepted.
    std::uint32_t pop() {
        const std::uint32_t top = heap_.front().voxel;
        pos_[top] = kAccepted;
        const Entry last = heap_.back();
        heap_.pop_back();
        if (!heap_.empty()) siftDown(last);
        return top;
    }

private:
    struct Entry {
        double key;
        std::uint32_t voxel;
        bool operator<(const Entry& o) const { return key < o.key || (key == o.key && voxel < o.voxel); }
    };
    void place(std::uint32_t i, const Entry& e) { heap_[i] = e, pos_[e.voxel] = i; }
    void siftUp(std::uint32_t i, const Entry& e) {
        heapSiftUp(heap_, i, e, [this](std::uint32_t at, const Entry& x) { place(at, x); });
    }
    void siftDown(const Entry& e) {  // e enters at the root
        heapSiftDown(heap_, e, [this](std::uint32_t at, const Entry& x) { place(at, x); });
    }

    std::vector<std::uint32_t> pos_;
    std::vector<Entry> heap_;
};

/// Calls f(first, neighbours) for consecutive chunks of voxels [first, first + count), neighbours as
/// stencilNeighbours for that chunk: 2^16 voxels (3 MiB of neighbours) amortise the parallel loop and stay
/// small beside any band worth chunking.
template <class F>
void forEachChunkOfNeighbours(const Band& band, F&& f) {
    constexpr std::size_t kChunk = std::size_t(1) << 16;
    std::vector<std::int32_t> forward;
    for (std::size_t first = 0; first < band.size(); first += kChunk) {
        stencilNeighbours(band, first, std::min(band.size(), first + kChunk), forward);
        f(first, forward);
    }
}

/// A voxel the march has touched and not yet accepted: m_k, the least accepted neighbour value of term k of its
/// stencil (+∞ if none), λ_k (copied from the band's stencil when the voxel is first touched, so an update reads
/// this record only), its tentative U and its place in the front. Only touched, unaccepted voxels hold one, in a
/// pool whose slots are reused once a voxel is accepted: the pool follows the front (a surface of the accepted
/// region), not the band, which is what brings a march under 100 B per voxel (docs/memory.md).
struct Touched {
    double m[6];
    float lambda[6];
    double u;
    std::uint32_t voxel;
    std::uint32_t heapPos;
};
static_assert(sizeof(Touched) == 88, "FastMarching::kTouchedBytes counts an 88 B record");

/// The compact march's front: the same indexed 4-ary min-heap on (U, voxel) as Front (so voxels leave it in the
/// same order, and the march gives the same U bit for bit), its positions kept in the pool records.
class CompactFront {
public:
    static constexpr std::uint32_t kNone = 0xffffffffu;

    explicit CompactFront(std::vector<Touched>& pool) : pool_(pool) {}
    bool empty() const { return heap_.empty(); }
    std::size_t size() const { return heap_.size(); }
    std::uint32_t peekVoxel() const { return heap_.front().voxel; }
    /// Inserts the voxel of slot s with key u, or lowers its key to u.
    void update(std::uint32_t s, double u) {
        Touched& t = pool_[s];
        if (t.heapPos == kNone) t.heapPos = std::uint32_t(heap_.size()), heap_.push_back({u, t.voxel, s});
        siftUp(t.heapPos, {u, t.voxel, s});
    }
    /// Removes the least entry and returns its slot.
    std::uint32_t pop() {
        const std::uint32_t top = heap_.front().slot;
        pool_[top].heapPos = kNone;
        const Entry last = heap_.back();
        heap_.pop_back();
        if (!heap_.empty()) siftDown(last);
        return top;
    }

private:
    struct Entry {
        double key;
        std::uint32_t voxel;
        std::uint32_t slot;
        bool operator<(const Entry& o) const { return key < o.key || (key == o.key && voxel < o.voxel); }
    };
    void place(std::uint32_t i, const Entry& e) { heap_[i] = e, pool_[e.slot].heapPos = i; }
    void siftUp(std::uint32_t i, const Entry& e) {
        heapSiftUp(heap_, i, e, [this](std::uint32_t at, const Entry& x) { place(at, x); });
    }
    void siftDown(const Entry& e) {  // e enters at the root
        heapSiftDown(heap_, e, [this](std::uint32_t at, const Entry& x) { place(at, x); });
    }

    std::vector<Touched>& pool_;
    std::vector<Entry> heap_;
};

void checkPoints(std::size_t n, const std::vector<std::size_t>& sources, const std::vector<std::size_t>& targets) {
    if (sources.empty()) throw ParameterError("fast marching needs at least one source");
    for (std::size_t s : sources)
        if (s >= n) throw ParameterError("a fast-marching source is not a band voxel");
    for (std::size_t t : targets)
        if (t >= n) throw ParameterError("a fast-marching target is not a band voxel");
}

}  // namespace

FastMarching::FastMarching(const Band& band) : band_(band) {
    const std::size_t n = band.size();
    if (n >= (std::size_t(1) << 29)) throw ParameterError("fast marching handles at most 5.4e8 voxels");
    // === Reverse table by counting sort (deterministic: sources in index order), each entry with the term of
    // the source's stencil that reaches y. The forward neighbours are resolved by chunks of voxels, twice (once to
    // count, once to fill), rather than held for the whole band: the whole forward table is 48 B per voxel, which
    // beside the reverse table would make the build, not the march, the peak (≈ 100 B per voxel).
    reserveHuge(reverseStart_, n + 1);
    reverseStart_.assign(n + 1, 0);
    forEachChunkOfNeighbours(band, [&](std::size_t, const std::vector<std::int32_t>& forward) {
        for (std::int32_t j : forward)
            if (j >= 0) ++reverseStart_[std::size_t(j) + 1];
    });
    for (std::size_t y = 0; y < n; ++y) reverseStart_[y + 1] += reverseStart_[y];
    reserveHuge(reverse_, reverseStart_[n]);
    reverse_.resize(reverseStart_[n]);
    // reverseStart_[y] serves as y's fill cursor, so it ends at y + 1's start; shifted back afterwards (saves a
    // 4 B-per-voxel cursor array)
    forEachChunkOfNeighbours(band, [&](std::size_t first, const std::vector<std::int32_t>& forward) {
        const std::size_t count = forward.size() / kSlots;
        for (std::size_t i = 0; i < count; ++i)
            for (int s = 0; s < kSlots; ++s) {
                const std::int32_t j = forward[kSlots * i + std::size_t(s)];
                if (j >= 0) reverse_[reverseStart_[std::size_t(j)]++] = std::uint32_t(first + i) << 3 | std::uint32_t(s / 2);
            }
    });
    for (std::size_t y = n; y > 0; --y) reverseStart_[y] = reverseStart_[y - 1];
    reverseStart_[0] = 0;
}

double FastMarching::bytesPerVoxel() const {
    const double n = double(std::max<std::size_t>(1, band_.size()));
    return double(reverseStart_.capacity() * sizeof(std::uint32_t) + reverse_.capacity() * sizeof(std::uint32_t)) / n;
}

FastMarchingResult fastMarching(const Band& band, const std::vector<std::size_t>& sources, const std::vector<std::size_t>& targets,
                                const FastMarchingOptions& options, const Progress& progress) {
    return FastMarching(band).run(sources, targets, options, progress);
}

FastMarchingResult FastMarching::run(const std::vector<std::size_t>& sources, const std::vector<std::size_t>& targets,
                                     const FastMarchingOptions& options, const Progress& progress) const {
    const Band& band = band_;
    const std::size_t n = band.size();
    checkPoints(n, sources, targets);
    const double h2 = band.voxelSize * band.voxelSize;

    FastMarchingResult r;
    reserveHuge(r.distance, n);
    r.distance.assign(n, kInf);  // written once per voxel, when it is accepted
    std::vector<std::uint8_t> isTarget(n, 0);
    std::size_t targetsLeft = 0;
    for (std::size_t t : targets)
        if (!isTarget[t]) isTarget[t] = 1, ++targetsLeft;

    // Per voxel, 4 B: untouched, accepted, or its slot in the pool of touched voxels.
    constexpr std::uint32_t kUntouched = 0xffffffffu;
    std::vector<std::uint32_t> slot;
    reserveHuge(slot, n);
    slot.assign(n, kUntouched);
    std::vector<Touched> pool;
    std::vector<std::uint32_t> freeSlots;
    CompactFront front(pool);
    auto touch = [&](std::uint32_t x) {
        std::uint32_t s;
        if (!freeSlots.empty()) s = freeSlots.back(), freeSlots.pop_back();
        else s = std::uint32_t(pool.size()), pool.emplace_back();
        Touched& t = pool[s];
        const VoxelStencil& st = band.stencil[x];
        for (int k = 0; k < 6; ++k) {
            t.m[k] = kInf;
            t.lambda[k] = k < st.count ? st.weight[std::size_t(k)] : 0.0f;
        }
        t.u = kInf;
        t.voxel = x;
        t.heapPos = CompactFront::kNone;
        slot[x] = s;
        return s;
    };

    // === Seeds (fixed at 0), then Dijkstra order on (U, index): ties resolved by index, so the march is unique
    for (std::size_t s : sources) {
        const std::uint32_t x = std::uint32_t(s);
        const std::uint32_t q = slot[x] == kUntouched ? touch(x) : slot[x];
        pool[q].u = 0;
        front.update(q, 0.0);
    }
    while (!front.empty()) {
        const std::uint32_t ys = front.pop();
        const std::uint32_t y = pool[ys].voxel;
        const double uy = pool[ys].u;
        r.distance[y] = uy;
        slot[y] = kAccepted;
        freeSlots.push_back(ys);
        ++r.accepted;
        if (r.accepted % 65536 == 0) {
            progress.checkInterrupt();
            progress.update("geodesic", double(r.accepted) / double(n));
        }
        if (targetsLeft > 0 && isTarget[y] && --targetsLeft == 0 && options.stopAtTargets) {
            r.stoppedEarly = r.accepted < n;
            break;
        }
        // === Update every voxel whose stencil reaches y. Their slots are scattered over the band: fetch them all
        // before the first is needed (the pool records are few and mostly cached).
        const std::uint32_t begin = reverseStart_[y], end = reverseStart_[y + 1];
        for (std::uint32_t q = begin; q < end; ++q) __builtin_prefetch(&slot[reverse_[q] >> 3]);
        if (!front.empty()) __builtin_prefetch(&reverse_[reverseStart_[front.peekVoxel()]]);
        // Then what each update reads: a touched voxel's record, or an untouched one's stencil weights (read once,
        // when it is touched). The slots fetched above arrive together; the wait is for the first only.
        for (std::uint32_t q = begin; q < end; ++q) {
            const std::uint32_t x = reverse_[q] >> 3, sx = slot[x];
            if (sx == kUntouched) __builtin_prefetch(&band.stencil[x]);
            else if (sx != kAccepted) __builtin_prefetch(&pool[sx]), __builtin_prefetch(reinterpret_cast<const char*>(&pool[sx]) + 64);
        }
        for (std::uint32_t q = begin; q < end; ++q) {
            const std::uint32_t x = reverse_[q] >> 3, k = reverse_[q] & 7;
            std::uint32_t sx = slot[x];
            if (sx == kAccepted) continue;
            if (sx == kUntouched) sx = touch(x);  // m_k = +∞ > uy: the update below always applies
            Touched& t = pool[sx];
            if (!(uy < t.m[k])) continue;
            t.m[k] = uy;
            const double v = localSolve(t.lambda, t.m, 6, h2);
            if (v < t.u) {
                t.u = v;
                front.update(sx, v);
            }
        }
    }
    // === Whatever was not accepted is not final: left at +∞ and counted
    r.unreached = n - r.accepted;
    r.peakTouched = pool.size();  // slots are reused, never released: the pool's size is its peak
    progress.update("geodesic", 1.0);
    return r;
}

FastMarchingResult FastMarching::runReference(const std::vector<std::size_t>& sources, const std::vector<std::size_t>& targets,
                                              const FastMarchingOptions& options, const Progress& progress) const {
    const Band& band = band_;
    const std::size_t n = band.size();
    checkPoints(n, sources, targets);
    const double h2 = band.voxelSize * band.voxelSize;

    FastMarchingResult r;
    reserveHuge(r.distance, n);
    r.distance.assign(n, kInf);
    std::vector<std::uint8_t> isTarget(n, 0);
    std::size_t targetsLeft = 0;
    for (std::size_t t : targets)
        if (!isTarget[t]) isTarget[t] = 1, ++targetsLeft;

    // === Seeds (fixed at 0), then Dijkstra order on (U, index): ties resolved by index, so the march is unique
    Front front(n);
    for (std::size_t s : sources) {
        r.distance[s] = 0;
        front.update(std::uint32_t(s), 0.0);
    }
    // Per voxel x, side by side (one record, about one cache line): m_k, the least accepted neighbour value of
    // term k of x's stencil, kept up to date as voxels are accepted, and λ_k; an update reads x's record only.
    std::vector<Node> node;
    reserveHuge(node, n);
    node.resize(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
            const VoxelStencil& st = band.stencil[i];
            for (int k = 0; k < 6; ++k) {
                node[i].m[k] = kInf;
                node[i].lambda[k] = k < st.count ? st.weight[std::size_t(k)] : 0.0f;
            }
        }
    });
    while (!front.empty()) {
        const std::uint32_t y = front.pop();
        node[y].m[0] = -1;  // accepted (m ≥ 0 otherwise): checked through the record an update reads anyway
        ++r.accepted;
        if (r.accepted % 65536 == 0) {
            progress.checkInterrupt();
            progress.update("geodesic", double(r.accepted) / double(n));
        }
        if (targetsLeft > 0 && isTarget[y] && --targetsLeft == 0 && options.stopAtTargets) {
            r.stoppedEarly = r.accepted < n;
            break;
        }
        // === Update every voxel whose stencil reaches y. Their data are scattered in memory: fetch them all
        // before the first is needed.
        const double uy = r.distance[y];
        const std::uint32_t begin = reverseStart_[y], end = reverseStart_[y + 1];
        for (std::uint32_t q = begin; q < end; ++q) {
            const std::uint32_t x = reverse_[q] >> 3;
            __builtin_prefetch(&node[x]);
            __builtin_prefetch(reinterpret_cast<const char*>(&node[x]) + 64);
            __builtin_prefetch(&r.distance[x]);
        }
        if (!front.empty()) __builtin_prefetch(&reverse_[reverseStart_[front.peek()]]);
        for (std::uint32_t q = begin; q < end; ++q) {
            const std::uint32_t x = reverse_[q] >> 3, k = reverse_[q] & 7;
            Node& nx = node[x];
            if (nx.m[0] < 0) continue;  // accepted
            if (!(uy < nx.m[k])) continue;
            nx.m[k] = uy;
            const double v = localSolve(nx.lambda, nx.m, 6, h2);
            if (v < r.distance[x]) {
                r.distance[x] = v;
                front.update(x, v);
            }
        }
    }
    // === Whatever was not accepted is not final: +∞ and counted
    for (std::size_t i = 0; i < n; ++i)
        if (!front.accepted(std::uint32_t(i))) r.distance[i] = kInf, ++r.unreached;
    progress.update("geodesic", 1.0);
    return r;
}

double fastMarchingBytes(std::size_t n, std::size_t entries, double frontShare) {
    const double voxels = double(n);
    const double tables = 4.0 * double(entries) + 4.0 * (voxels + 1);
    const double march = FastMarching::kMarchBytesPerVoxel * voxels;
    // The pool and the heap grow by doubling: on average 1.5× what they hold at their peak.
    const double pool = 1.5 * FastMarching::kTouchedBytes * frontShare * voxels;
    return tables + march + pool;
}

double fastMarchingFrontShare(std::size_t n) {
    // Measured peak touched share (bench_geodesic, bench/results/geodesic.json): from a point source in a solid
    // block the front is a sphere's surface, N^(2/3) voxels: 0.0119, 0.0079, 0.0059 on the 100³, 150³, 200³ boxes
    // (1.19 N^(−1/3)), 0.0147 on the 200³ box with a varying metric. In a band (a shell across which T is small) it
    // is a ring that sweeps the surface, swept across the shell's thickness slowly: 0.091 and 0.084 on the bunny's
    // 80 k-voxel bands, 0.056 on its 300 k-voxel band (26–31 N^(−1/2)). The larger of the two bounds both shapes up
    // to 1e8 voxels, where the pool is under 1 B per voxel either way.
    const double voxels = double(std::max<std::size_t>(1, n));
    return std::min(1.0, std::max(1.5 / std::cbrt(voxels), 32.0 / std::sqrt(voxels)));
}

}  // namespace gpisvdb
