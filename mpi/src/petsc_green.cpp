#include "gpisvdb/mpi/petsc_green.h"

#include <petscksp.h>

#include <chrono>
#include <cmath>
#include <limits>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/mpi/petsc_laplacian.h"

namespace gpisvdb::mpi {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct NearestCandidate {
    double distance2;
    std::int64_t index;
};

/// The PETSc objects of one solve, destroyed with it.
struct Solve {
    Vec b = nullptr, x = nullptr, r = nullptr;
    KSP ksp = nullptr;
    ~Solve() {
        if (ksp) KSPDestroy(&ksp);
        for (Vec* v : {&b, &x, &r})
            if (*v) VecDestroy(v);
    }
};

/// Stops the Krylov loop when the caller's interrupter asks (the command line's Ctrl-C).
PetscErrorCode monitor(KSP, PetscInt, PetscReal, void* context) {
    const auto* progress = static_cast<const Progress*>(context);
    return progress->interrupted && progress->interrupted() ? PETSC_ERR_USER : 0;
}

void setOption(const char* name, const char* value) { checkPetsc(PetscOptionsSetValue(nullptr, name, value), name); }

}  // namespace

std::size_t nearestBandVoxel(const Ranks& ranks, const DistributedBand& d, const Vec3d& point) {
    if (!point.allFinite()) throw ParameterError("a source or target point must be three finite numbers");
    const Band& band = d.local;
    const double h = band.voxelSize;
    NearestCandidate best{std::numeric_limits<double>::infinity(), -1};
    for (std::size_t i = 0; i < band.size(); ++i) {
        const Vec3d x = h * Vec3d(band.coord[i].x(), band.coord[i].y(), band.coord[i].z());
        const double d2 = (x - point).squaredNorm();
        if (d2 < best.distance2) best = {d2, std::int64_t(d.offset + i)};
    }
    NearestCandidate all{std::numeric_limits<double>::infinity(), -1};
    for (const NearestCandidate& c : allGather(ranks, std::vector<NearestCandidate>{best}))  // rank order: ties to the lowest index
        if (c.index >= 0 && c.distance2 < all.distance2) all = c;
    if (all.index < 0) throw InputError("the band is empty");
    return std::size_t(all.index);
}

DistributedGreen greensFunctionPetsc(const Ranks& ranks, const DistributedBand& d, const Vec3d& source, const PcgOptions& options,
                                     const Progress& progress) {
    DistributedGreen g;
    together(ranks, [&] {
        if (options.preconditioner == Preconditioner::IncompleteCholesky)
            throw ParameterError(
                "the incomplete Cholesky preconditioner (PcgOptions::preconditioner) has no distributed "
                "form: use multigrid or jacobi",
                {"PcgOptions::preconditioner"});
        if (!(options.tolerance > 0) || options.maxIterations < 1)
            throw ParameterError(
                "the PCG needs a tolerance (PcgOptions::tolerance) > 0 and an iteration cap "
                "(PcgOptions::maxIterations) >= 1",
                {"PcgOptions::tolerance", "PcgOptions::maxIterations"});
    });
    g.preconditioner = options.preconditioner == Preconditioner::Automatic
                           ? (d.globalSize >= kMultigridMinUnknowns ? Preconditioner::Multigrid : Preconditioner::Jacobi)
                           : options.preconditioner;
    g.sourceIndex = nearestBandVoxel(ranks, d, source);

    // === L, then the right-hand side e_y (paper Alg. 1: M δ_y = e_y)
    auto t = Clock::now();
    const PetscLaplacian L = assembleLaplacianPetsc(ranks, d);
    g.ghosts = L.ghosts;
    g.assembleSeconds = since(t);
    Solve s;
    checkPetsc(MatCreateVecs(L.L.get(), &s.x, &s.b), "MatCreateVecs");
    checkPetsc(VecDuplicate(s.b, &s.r), "VecDuplicate");
    checkPetsc(VecSet(s.b, 0.0), "VecSet");
    checkPetsc(VecSet(s.x, 0.0), "VecSet");
    if (g.sourceIndex >= d.offset && g.sourceIndex < d.offset + d.local.size())
        checkPetsc(VecSetValue(s.b, PetscInt(g.sourceIndex), 1.0, INSERT_VALUES), "VecSetValue");
    checkPetsc(VecAssemblyBegin(s.b), "VecAssemblyBegin");
    checkPetsc(VecAssemblyEnd(s.b), "VecAssemblyEnd");

    // === CG, preconditioned as the one-process solver is (solve/boomer_amg.h), stopping on the true residual norm
    t = Clock::now();
    checkPetsc(KSPCreate(ranks.comm, &s.ksp), "KSPCreate");
    checkPetsc(KSPSetOptionsPrefix(s.ksp, "green_"), "KSPSetOptionsPrefix");
    checkPetsc(KSPSetOperators(s.ksp, L.L.get(), L.L.get()), "KSPSetOperators");
    checkPetsc(KSPSetType(s.ksp, KSPCG), "KSPSetType");
    checkPetsc(KSPSetNormType(s.ksp, KSP_NORM_UNPRECONDITIONED), "KSPSetNormType");
    checkPetsc(KSPSetTolerances(s.ksp, options.tolerance, 0.0, PETSC_DEFAULT, options.maxIterations), "KSPSetTolerances");
    PC pc = nullptr;
    checkPetsc(KSPGetPC(s.ksp, &pc), "KSPGetPC");
    if (g.preconditioner == Preconditioner::Multigrid) {
        checkPetsc(PCSetType(pc, PCHYPRE), "PCSetType");
        checkPetsc(PCHYPRESetType(pc, "boomeramg"), "PCHYPRESetType");
        // The one-process multigrid's settings, unless PETSC_OPTIONS sets them
        const BoomerAmgOptions& amg = options.multigrid;
        const std::string theta = std::to_string(amg.strongThreshold), pmax = std::to_string(amg.maxInterpolationEntries),
                          aggressive = std::to_string(amg.aggressiveLevels);
        const std::pair<const char*, std::string> defaults[] = {{"-green_pc_hypre_boomeramg_coarsen_type", "HMIS"},
                                                                {"-green_pc_hypre_boomeramg_interp_type", "ext+i"},
                                                                {"-green_pc_hypre_boomeramg_P_max", pmax},
                                                                {"-green_pc_hypre_boomeramg_strong_threshold", theta},
                                                                {"-green_pc_hypre_boomeramg_agg_nl", aggressive},
                                                                {"-green_pc_hypre_boomeramg_relax_type_down", "l1-Gauss-Seidel"},
                                                                {"-green_pc_hypre_boomeramg_relax_type_up", "backward-l1-Gauss-Seidel"},
                                                                {"-green_pc_hypre_boomeramg_relax_type_coarse", "Gaussian-elimination"}};
        for (const auto& [name, value] : defaults) {
            PetscBool set = PETSC_FALSE;
            checkPetsc(PetscOptionsHasName(nullptr, nullptr, name, &set), "PetscOptionsHasName");
            if (!set) setOption(name, value.c_str());
        }
    } else {
        checkPetsc(PCSetType(pc, PCJACOBI), "PCSetType");
    }
    checkPetsc(KSPMonitorSet(s.ksp, monitor, const_cast<Progress*>(&progress), nullptr), "KSPMonitorSet");
    checkPetsc(KSPSetFromOptions(s.ksp), "KSPSetFromOptions");
    checkPetsc(KSPSetUp(s.ksp), "KSPSetUp");
    g.setupSeconds = since(t);
    t = Clock::now();
    const PetscErrorCode solved = KSPSolve(s.ksp, s.b, s.x);
    if (solved == PETSC_ERR_USER) throw Cancelled();
    checkPetsc(solved, "KSPSolve");
    g.solveSeconds = since(t);
    PetscInt iterations = 0;
    checkPetsc(KSPGetIterationNumber(s.ksp, &iterations), "KSPGetIterationNumber");
    g.iterations = int(iterations);

    // === The true residual, in double
    checkPetsc(MatMult(L.L.get(), s.x, s.r), "MatMult");
    checkPetsc(VecAYPX(s.r, -1.0, s.b), "VecAYPX");
    PetscReal rn = 0, bn = 0;
    checkPetsc(VecNorm(s.r, NORM_2, &rn), "VecNorm");
    checkPetsc(VecNorm(s.b, NORM_2, &bn), "VecNorm");
    g.relativeResidual = double(rn / bn);
    g.converged = g.relativeResidual <= options.tolerance * (1 + 1e-9);
    const PetscScalar* x = nullptr;
    checkPetsc(VecGetArrayRead(s.x, &x), "VecGetArrayRead");
    g.local.assign(x, x + d.local.size());
    checkPetsc(VecRestoreArrayRead(s.x, &x), "VecRestoreArrayRead");
    return g;
}

}  // namespace gpisvdb::mpi
