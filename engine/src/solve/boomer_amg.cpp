#include "gpisvdb/solve/boomer_amg.h"

#include <malloc.h>
#include <mpi.h>
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif
// hypre's internal headers: the hierarchy's levels and the vectors' storage, which the public API does not expose.
#include <_hypre_parcsr_ls.h>
#include <algorithm>
#include <cstdlib>
#include <HYPRE.h>
#include <HYPRE_parcsr_ls.h>
#include <mutex>
#include <string>
#include <vector>

#include "../core/heap_reuse.h"
#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

// Debian's hypre pulls in SuperLU_DIST, whose start-up (as the program loads, before main) sets glibc's malloc
// never to use mmap for large blocks nor to trim its heap, as RDMA-pinned MPI codes want. We run MPI for one process
// over its self transport and pin nothing, so those settings only cost memory: large freed blocks never went back to
// the system, and a band build peaked at its staging blocks plus the finished band (+110 MB on 1.2 M voxels). This
// initialiser runs after the libraries' (they are loaded first) and restores glibc's behaviour (its default
// thresholds, fixed: mallopt has no way back to the dynamic ones). docs/memory.md.
const bool kMallocRestored = [] {
#ifdef M_MMAP_MAX
    mallopt(M_MMAP_MAX, 65536);
    mallopt(M_MMAP_THRESHOLD, kMallocThresholdBytes);
    mallopt(M_TRIM_THRESHOLD, kMallocThresholdBytes);
#endif
    return true;
}();

// hypre and MPI are called from whichever thread runs a solve; one call at a time (MPI_THREAD_SERIALIZED).
std::mutex& hypreLock() {
    static std::mutex m;
    return m;
}

void finalizeMpi() {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (finalized) return;
#if defined(__SANITIZE_ADDRESS__)
    // LeakSanitizer's own end-of-process check stops every thread; Open MPI's threads, winding down after
    // MPI_Finalize, crashed its tracer now and then (measured: 1 process in ~30). Checked here instead, while they
    // are parked; the end-of-process check is then skipped.
    __lsan_do_leak_check();
#endif
    HYPRE_Finalize();
    MPI_Finalize();
}

/// MPI for this process alone, once, unless the program already initialised it (an MPI front end). Open MPI's
/// singleton start would otherwise fork a runtime daemon (orted) and probe the network: neither is needed by one
/// process talking to itself, so unless a launcher started us (its variables are set) the singleton is isolated and
/// the transports limited to the process's own.
void ensureMpi() {
    static std::once_flag once;
    std::call_once(once, [] {
        int initialized = 0;
        MPI_Initialized(&initialized);
        if (!initialized) {
            const bool launched = std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMIX_RANK") || std::getenv("PMI_RANK");
            if (!launched) {
                setenv("OMPI_MCA_ess_singleton_isolated", "1", 0);
                setenv("OMPI_MCA_btl", "self", 0);
                setenv("OMPI_MCA_pml", "ob1", 0);
                // Keep Open MPI's plugins loaded until exit: what they keep allocated is then attributed to them
                // (and suppressed: tools/sanitizers/lsan.supp) instead of to an unloaded, unknown module.
                setenv("OMPI_MCA_mca_base_component_disable_dlclose", "1", 0);
                setenv("PMIX_MCA_mca_base_component_disable_dlclose", "1", 0);
            }
            int provided = 0;
#if defined(__SANITIZE_ADDRESS__)
            // Open MPI keeps blocks allocated in its start-up until its plugins are unloaded at MPI_Finalize; they
            // then show as leaks from an unknown module, which no suppression can name (docs/sanitizers.md).
            __lsan::ScopedDisabler notOurs;
#endif
            if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS)
                throw Error(
                    "the multigrid preconditioner could not initialise MPI (hypre needs it); use the Jacobi "
                    "preconditioner instead");
            std::atexit(finalizeMpi);
        }
        HYPRE_Init();
    });
}

void check(HYPRE_Int code, const char* what) {
    if (code == 0) return;
    char message[256] = {0};
    HYPRE_DescribeError(code, message);
    HYPRE_ClearAllErrors();
    throw Error(std::string("hypre failed in ") + what + ": " + message);
}

double* localData(HYPRE_ParVector v) { return hypre_VectorData(hypre_ParVectorLocalVector(reinterpret_cast<hypre_ParVector*>(v))); }

std::size_t csrBytes(hypre_ParCSRMatrix* M) {
    if (!M) return 0;
    std::size_t bytes = 0;
    for (hypre_CSRMatrix* part : {hypre_ParCSRMatrixDiag(M), hypre_ParCSRMatrixOffd(M)}) {
        if (!part) continue;
        bytes += std::size_t(hypre_CSRMatrixNumNonzeros(part)) * (sizeof(HYPRE_Real) + sizeof(HYPRE_Int)) +
                 std::size_t(hypre_CSRMatrixNumRows(part) + 1) * sizeof(HYPRE_Int);
    }
    return bytes;
}

std::size_t nonzeros(hypre_ParCSRMatrix* M) {
    std::size_t n = 0;
    for (hypre_CSRMatrix* part : {hypre_ParCSRMatrixDiag(M), hypre_ParCSRMatrixOffd(M)})
        if (part) n += std::size_t(hypre_CSRMatrixNumNonzeros(part));
    return n;
}

}  // namespace

struct BoomerAmg::Impl {
    std::size_t n = 0;
    HYPRE_IJMatrix ijA = nullptr;
    HYPRE_ParCSRMatrix A = nullptr;
    HYPRE_IJVector ijB = nullptr, ijX = nullptr;
    HYPRE_ParVector b = nullptr, x = nullptr;
    HYPRE_Solver amg = nullptr;

    ~Impl() {
        std::lock_guard<std::mutex> lock(hypreLock());
        if (amg) HYPRE_BoomerAMGDestroy(amg);
        if (ijX) HYPRE_IJVectorDestroy(ijX);
        if (ijB) HYPRE_IJVectorDestroy(ijB);
        if (ijA) HYPRE_IJMatrixDestroy(ijA);
    }
    hypre_ParAMGData* data() const { return reinterpret_cast<hypre_ParAMGData*>(amg); }
};

BoomerAmg::BoomerAmg(const SparseMatrixF& M, const BoomerAmgOptions& options) : impl_(std::make_unique<Impl>()) {
    setUp<SparseMatrixF>(M, nullptr, options);
}

BoomerAmg::BoomerAmg(SparseMatrixF&& M, const BoomerAmgOptions& options) : impl_(std::make_unique<Impl>()) {
    setUp<SparseMatrixF>(M, &M, options);
}

BoomerAmg::BoomerAmg(const SparseMatrixD& M, const BoomerAmgOptions& options) : impl_(std::make_unique<Impl>()) {
    setUp<SparseMatrixD>(M, nullptr, options);
}

template <class Matrix>
void BoomerAmg::setUp(const Matrix& M, Matrix* release, const BoomerAmgOptions& options) {
    if (!(options.strongThreshold > 0 && options.strongThreshold < 1))
        throw ParameterError("BoomerAmgOptions::strongThreshold must lie in (0, 1)", {"BoomerAmgOptions::strongThreshold"});
    if (options.maxInterpolationEntries < 1)
        throw ParameterError("BoomerAmgOptions::maxInterpolationEntries must be ≥ 1", {"BoomerAmgOptions::maxInterpolationEntries"});
    if (options.aggressiveLevels < 0)
        throw ParameterError("BoomerAmgOptions::aggressiveLevels must be ≥ 0", {"BoomerAmgOptions::aggressiveLevels"});
    if (M.rows() == 0 || M.rows() != M.cols()) throw ParameterError("the multigrid preconditioner needs a square, non-empty matrix");
    if (!M.isCompressed()) throw ParameterError("the multigrid preconditioner needs a compressed matrix");
    ensureMpi();
    std::lock_guard<std::mutex> lock(hypreLock());
    Impl& m = *impl_;
    m.n = std::size_t(M.rows());
    const HYPRE_BigInt last = HYPRE_BigInt(m.n) - 1;

    // === The matrix, copied row block by row block (its float entries widened exactly to double)
    check(HYPRE_IJMatrixCreate(MPI_COMM_SELF, 0, last, 0, last, &m.ijA), "IJMatrixCreate");
    check(HYPRE_IJMatrixSetObjectType(m.ijA, HYPRE_PARCSR), "IJMatrixSetObjectType");
    {
        // Exact sizes of the diagonal block (all of it: one process) and of the empty off-process block: hypre then
        // writes the entries straight into its compressed rows, without its auxiliary per-row copy (measured: the
        // set-up's peak fell from 1 145 to N bytes per voxel, docs/memory.md).
        std::vector<HYPRE_Int> sizes(m.n), none(m.n, 0);
        for (std::size_t i = 0; i < m.n; ++i) sizes[i] = HYPRE_Int(M.outerIndexPtr()[i + 1] - M.outerIndexPtr()[i]);
        check(HYPRE_IJMatrixSetDiagOffdSizes(m.ijA, sizes.data(), none.data()), "IJMatrixSetDiagOffdSizes");
    }
    check(HYPRE_IJMatrixInitialize(m.ijA), "IJMatrixInitialize");
    constexpr std::size_t kBlock = 1 << 16;
    std::vector<HYPRE_BigInt> rows, cols;
    std::vector<HYPRE_Int> counts;
    std::vector<HYPRE_Real> values;
    for (std::size_t begin = 0; begin < m.n; begin += kBlock) {
        const std::size_t end = std::min(m.n, begin + kBlock);
        const auto* outer = M.outerIndexPtr();
        rows.clear();
        counts.clear();
        for (std::size_t i = begin; i < end; ++i) {
            rows.push_back(HYPRE_BigInt(i));
            counts.push_back(HYPRE_Int(outer[i + 1] - outer[i]));
        }
        cols.assign(M.innerIndexPtr() + outer[begin], M.innerIndexPtr() + outer[end]);
        values.assign(M.valuePtr() + outer[begin], M.valuePtr() + outer[end]);
        HYPRE_Int nrows = HYPRE_Int(end - begin);
        check(HYPRE_IJMatrixSetValues(m.ijA, nrows, counts.data(), rows.data(), cols.data(), values.data()), "IJMatrixSetValues");
    }
    check(HYPRE_IJMatrixAssemble(m.ijA), "IJMatrixAssemble");
    check(HYPRE_IJMatrixGetObject(m.ijA, reinterpret_cast<void**>(&m.A)), "IJMatrixGetObject");
    std::vector<HYPRE_BigInt>().swap(rows);
    std::vector<HYPRE_BigInt>().swap(cols);
    std::vector<HYPRE_Int>().swap(counts);
    std::vector<HYPRE_Real>().swap(values);
    if (release) *release = Matrix();

    // === Right-hand side and solution vectors of the V-cycle
    for (auto [ij, par] : {std::pair{&m.ijB, &m.b}, std::pair{&m.ijX, &m.x}}) {
        check(HYPRE_IJVectorCreate(MPI_COMM_SELF, 0, last, ij), "IJVectorCreate");
        check(HYPRE_IJVectorSetObjectType(*ij, HYPRE_PARCSR), "IJVectorSetObjectType");
        check(HYPRE_IJVectorInitialize(*ij), "IJVectorInitialize");
        check(HYPRE_IJVectorAssemble(*ij), "IJVectorAssemble");
        check(HYPRE_IJVectorGetObject(*ij, reinterpret_cast<void**>(par)), "IJVectorGetObject");
    }

    // === The hierarchy: one V-cycle per apply, symmetric smoothing, no convergence test (tolerance 0)
    check(HYPRE_BoomerAMGCreate(&m.amg), "BoomerAMGCreate");
    HYPRE_BoomerAMGSetPrintLevel(m.amg, 0);
    HYPRE_BoomerAMGSetMaxIter(m.amg, 1);
    HYPRE_BoomerAMGSetTol(m.amg, 0.0);
    HYPRE_BoomerAMGSetCoarsenType(m.amg, 10);  // HMIS
    HYPRE_BoomerAMGSetInterpType(m.amg, 6);    // extended+i
    HYPRE_BoomerAMGSetPMaxElmts(m.amg, options.maxInterpolationEntries);
    HYPRE_BoomerAMGSetStrongThreshold(m.amg, options.strongThreshold);
    HYPRE_BoomerAMGSetAggNumLevels(m.amg, options.aggressiveLevels);
    HYPRE_BoomerAMGSetCycleRelaxType(m.amg, 13, 1);  // ℓ1-Gauss–Seidel forward on the way down,
    HYPRE_BoomerAMGSetCycleRelaxType(m.amg, 14, 2);  // backward on the way up: a symmetric V-cycle
    HYPRE_BoomerAMGSetCycleRelaxType(m.amg, 9, 3);   // coarsest level: Gaussian elimination
    HYPRE_BoomerAMGSetNumSweeps(m.amg, 1);
    HYPRE_BoomerAMGSetRelaxOrder(m.amg, 0);  // lexicographic: the same sweep for any thread count
    check(HYPRE_BoomerAMGSetup(m.amg, m.A, m.b, m.x), "BoomerAMGSetup");
}

BoomerAmg::~BoomerAmg() = default;

void BoomerAmg::apply(const float* r, float* z) const { applyAs(*impl_, r, z); }
void BoomerAmg::apply(const double* r, double* z) const { applyAs(*impl_, r, z); }

template <class T>
void BoomerAmg::applyAs(Impl& m, const T* r, T* z) {
    std::lock_guard<std::mutex> lock(hypreLock());
    double* b = localData(m.b);
    double* x = localData(m.x);
    for (std::size_t i = 0; i < m.n; ++i) {
        b[i] = double(r[i]);
        x[i] = 0.0;
    }
    check(HYPRE_BoomerAMGSolve(m.amg, m.A, m.b, m.x), "BoomerAMGSolve");
    for (std::size_t i = 0; i < m.n; ++i) z[i] = T(x[i]);
}

int BoomerAmg::levels() const { return hypre_ParAMGDataNumLevels(impl_->data()); }

double BoomerAmg::operatorComplexity() const {
    hypre_ParAMGData* d = impl_->data();
    hypre_ParCSRMatrix** A = hypre_ParAMGDataAArray(d);
    double total = 0;
    for (int l = 0; l < levels(); ++l) total += double(nonzeros(A[l]));
    return total / double(nonzeros(A[0]));
}

std::size_t BoomerAmg::memoryBytes() const {
    hypre_ParAMGData* d = impl_->data();
    hypre_ParCSRMatrix** A = hypre_ParAMGDataAArray(d);
    hypre_ParCSRMatrix** P = hypre_ParAMGDataPArray(d);
    std::size_t bytes = 0;
    for (int l = 0; l < levels(); ++l) {
        bytes += csrBytes(A[l]);
        if (l + 1 < levels()) bytes += csrBytes(P[l]);
        // Per level: the right-hand side, solution and temporary vectors, the ℓ1 norms, the C/F markers.
        const std::size_t rows = std::size_t(hypre_CSRMatrixNumRows(hypre_ParCSRMatrixDiag(A[l])));
        bytes += rows * (4 * sizeof(HYPRE_Real) + sizeof(HYPRE_Int));
    }
    return bytes + 2 * impl_->n * sizeof(HYPRE_Real);  // the apply's own b and x
}

// Measured: the green stage's peak over its baseline, less the operator, the PCG and the right-hand side counted
// above, 436 bytes per voxel on the bunny (σ_rel 1, h 0.06 and 0.04: 0.77 M and 2.6 M voxels; docs/memory.md): the
// assembled L while hypre copies it, then hypre's matrix and hierarchy.
const double kMultigridBytesPerVoxel = 440;

double multigridBytes(std::size_t n) { return kMultigridBytesPerVoxel * double(n); }

}  // namespace gpisvdb
