#include "gpisvdb/mpi/slepc_spectrum.h"

#include <slepceps.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/mpi/petsc_laplacian.h"

namespace gpisvdb::mpi {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// The PETSc and SLEPc objects of one solve, destroyed with it.
struct Objects {
    Mat M = nullptr;
    EPS eps = nullptr;
    Vec u = nullptr, Lu = nullptr, Mu = nullptr;
    ~Objects() {
        if (eps) EPSDestroy(&eps);
        if (M) MatDestroy(&M);
        for (Vec* v : {&u, &Lu, &Mu})
            if (*v) VecDestroy(v);
    }
};

struct Extreme {
    double magnitude;
    std::int64_t index;
    double value;
};

}  // namespace

DistributedSpectrum spectrumSlepc(const Ranks& ranks, const DistributedBand& d, const EigenOptions& options, const Progress& progress) {
    const Band& band = d.local;
    const std::size_t n = band.size();
    together(ranks, [&] {
        if (options.count < 1 || std::size_t(options.count) >= d.globalSize)
            throw ParameterError(
                "the eigenpair count k (EigenOptions::count) must be in [1, N) with N = " + std::to_string(d.globalSize) + " band voxels",
                {"EigenOptions::count"});
        if (!(options.tolerance > 0))
            throw ParameterError("the eigen tolerance (EigenOptions::tolerance) must be > 0", {"EigenOptions::tolerance"});
    });
    DistributedSpectrum s;
    s.method = options.method == EigenMethod::Automatic
                   ? (d.globalSize <= kFactorMaxVoxels ? EigenMethod::ShiftInvert : EigenMethod::Lobpcg)
                   : options.method;

    // === L and M = h³ diag(μ)
    auto t = Clock::now();
    const PetscLaplacian L = assembleLaplacianPetsc(ranks, d);
    s.ghosts = L.ghosts;
    Objects o;
    checkPetsc(
        MatCreateAIJ(ranks.comm, PetscInt(n), PetscInt(n), PetscInt(d.globalSize), PetscInt(d.globalSize), 1, nullptr, 0, nullptr, &o.M),
        "MatCreateAIJ");
    const double h3 = band.voxelSize * band.voxelSize * band.voxelSize;
    for (std::size_t i = 0; i < n; ++i)
        checkPetsc(MatSetValue(o.M, PetscInt(d.offset + i), PetscInt(d.offset + i), h3 * double(band.mu[i]), INSERT_VALUES), "MatSetValue");
    checkPetsc(MatAssemblyBegin(o.M, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    checkPetsc(MatAssemblyEnd(o.M, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
    s.assembleSeconds = since(t);

    // === The eigen solver: generalized Hermitian, the smallest λ
    t = Clock::now();
    checkPetsc(EPSCreate(ranks.comm, &o.eps), "EPSCreate");
    checkPetsc(EPSSetOptionsPrefix(o.eps, "spectrum_"), "EPSSetOptionsPrefix");
    checkPetsc(EPSSetOperators(o.eps, L.L.get(), o.M), "EPSSetOperators");
    checkPetsc(EPSSetProblemType(o.eps, EPS_GHEP), "EPSSetProblemType");
    checkPetsc(EPSSetDimensions(o.eps, options.count, options.subspace > 0 ? options.subspace : PETSC_DEFAULT, PETSC_DEFAULT),
               "EPSSetDimensions");
    checkPetsc(EPSSetTolerances(o.eps, options.tolerance, options.maxRestarts), "EPSSetTolerances");
    ST st = nullptr;
    KSP ksp = nullptr;
    PC pc = nullptr;
    checkPetsc(EPSGetST(o.eps, &st), "EPSGetST");
    checkPetsc(STGetKSP(st, &ksp), "STGetKSP");
    checkPetsc(KSPGetPC(ksp, &pc), "KSPGetPC");
    if (s.method == EigenMethod::Lobpcg) {
        // LOBPCG: the smallest λ directly; the preconditioner one BoomerAMG V-cycle on L
        checkPetsc(EPSSetType(o.eps, EPSLOBPCG), "EPSSetType");
        checkPetsc(EPSSetWhichEigenpairs(o.eps, EPS_SMALLEST_REAL), "EPSSetWhichEigenpairs");
        checkPetsc(STSetType(st, STPRECOND), "STSetType");
        checkPetsc(KSPSetType(ksp, KSPPREONLY), "KSPSetType");
        checkPetsc(PCSetType(pc, PCHYPRE), "PCSetType");
        checkPetsc(PCHYPRESetType(pc, "boomeramg"), "PCHYPRESetType");
    } else {
        // Krylov–Schur on (L − σ M)⁻¹ M with σ = 0: the smallest λ are the largest 1/λ; L factored by MUMPS
        checkPetsc(EPSSetType(o.eps, EPSKRYLOVSCHUR), "EPSSetType");
        checkPetsc(EPSSetWhichEigenpairs(o.eps, EPS_TARGET_MAGNITUDE), "EPSSetWhichEigenpairs");
        checkPetsc(EPSSetTarget(o.eps, 0.0), "EPSSetTarget");
        checkPetsc(STSetType(st, STSINVERT), "STSetType");
        checkPetsc(KSPSetType(ksp, KSPPREONLY), "KSPSetType");
        checkPetsc(PCSetType(pc, PCCHOLESKY), "PCSetType");
        checkPetsc(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
    }
    checkPetsc(EPSSetStoppingTestFunction(
                   o.eps,
                   [](EPS eps, PetscInt its, PetscInt max_it, PetscInt nconv, PetscInt nev, EPSConvergedReason* reason,
                      void* context) -> PetscErrorCode {
                       const auto* p = static_cast<const Progress*>(context);
                       if (p->interrupted && p->interrupted()) return PETSC_ERR_USER;
                       return EPSStoppingBasic(eps, its, max_it, nconv, nev, reason, nullptr);
                   },
                   const_cast<Progress*>(&progress), nullptr),
               "EPSSetStoppingTestFunction");
    checkPetsc(EPSSetFromOptions(o.eps), "EPSSetFromOptions");
    const PetscErrorCode solved = EPSSolve(o.eps);
    if (solved == PETSC_ERR_USER) throw Cancelled();
    checkPetsc(solved, "EPSSolve");
    PetscInt converged = 0, iterations = 0;
    checkPetsc(EPSGetConverged(o.eps, &converged), "EPSGetConverged");
    checkPetsc(EPSGetIterationNumber(o.eps, &iterations), "EPSGetIterationNumber");
    s.iterations = int(iterations);
    s.solveSeconds = since(t);
    together(ranks, [&] {
        if (converged < options.count)
            throw Error("SLEPc found " + std::to_string(converged) + " of the " + std::to_string(options.count) + " eigenpairs within " +
                            std::to_string(options.maxRestarts) +
                            " iterations: raise the iteration cap (EigenOptions::maxRestarts) or loosen the tolerance "
                            "(EigenOptions::tolerance)",
                        {"EigenOptions::maxRestarts", "EigenOptions::tolerance"});
    });

    // === The pairs, ascending; each vector M-normalised with the one-process sign, then checked in double
    std::vector<std::pair<double, PetscInt>> order;
    for (PetscInt i = 0; i < converged; ++i) {
        PetscScalar value = 0;
        checkPetsc(EPSGetEigenvalue(o.eps, i, &value, nullptr), "EPSGetEigenvalue");
        order.emplace_back(double(value), i);
    }
    std::sort(order.begin(), order.end());
    const int k = options.count;
    s.values.resize(k);
    s.residuals.resize(k);
    s.local.assign(std::size_t(k), {});
    checkPetsc(MatCreateVecs(L.L.get(), &o.u, &o.Lu), "MatCreateVecs");
    checkPetsc(VecDuplicate(o.u, &o.Mu), "VecDuplicate");
    std::vector<Vec> basis;
    for (int i = 0; i < k; ++i) {
        s.values(i) = order[std::size_t(i)].first;
        checkPetsc(EPSGetEigenvector(o.eps, order[std::size_t(i)].second, o.u, nullptr), "EPSGetEigenvector");
        // M-norm, and the sign: the largest |entry| (lowest linear index on ties) positive
        checkPetsc(MatMult(o.M, o.u, o.Mu), "MatMult");
        PetscScalar norm2 = 0;
        checkPetsc(VecDot(o.u, o.Mu, &norm2), "VecDot");
        const PetscScalar* x = nullptr;
        checkPetsc(VecGetArrayRead(o.u, &x), "VecGetArrayRead");
        Extreme mine{-1, -1, 0};
        for (std::size_t j = 0; j < n; ++j)
            if (std::abs(x[j]) > mine.magnitude) mine = {std::abs(x[j]), std::int64_t(d.offset + j), x[j]};
        checkPetsc(VecRestoreArrayRead(o.u, &x), "VecRestoreArrayRead");
        Extreme best{-1, -1, 0};
        for (const Extreme& e : allGather(ranks, std::vector<Extreme>{mine}))  // rank order: ties to the lowest index
            if (e.magnitude > best.magnitude) best = e;
        checkPetsc(VecScale(o.u, (best.value < 0 ? -1.0 : 1.0) / std::sqrt(double(norm2))), "VecScale");
        // Residual ‖L u − λ M u‖ / (|λ| ‖M u‖)
        checkPetsc(MatMult(L.L.get(), o.u, o.Lu), "MatMult");
        checkPetsc(MatMult(o.M, o.u, o.Mu), "MatMult");
        PetscReal mu = 0, r = 0;
        checkPetsc(VecNorm(o.Mu, NORM_2, &mu), "VecNorm");
        checkPetsc(VecAXPY(o.Lu, -s.values(i), o.Mu), "VecAXPY");
        checkPetsc(VecNorm(o.Lu, NORM_2, &r), "VecNorm");
        s.residuals(i) = double(r) / (std::abs(s.values(i)) * double(mu));
        checkPetsc(VecGetArrayRead(o.u, &x), "VecGetArrayRead");
        s.local[std::size_t(i)].assign(x, x + n);
        checkPetsc(VecRestoreArrayRead(o.u, &x), "VecRestoreArrayRead");
        Vec keep = nullptr;
        checkPetsc(VecDuplicate(o.u, &keep), "VecDuplicate");
        checkPetsc(VecCopy(o.u, keep), "VecCopy");
        basis.push_back(keep);
    }
    // UᵀMU − I
    for (int i = 0; i < k; ++i) {
        checkPetsc(MatMult(o.M, basis[std::size_t(i)], o.Mu), "MatMult");
        for (int j = 0; j <= i; ++j) {
            PetscScalar g = 0;
            checkPetsc(VecDot(basis[std::size_t(j)], o.Mu, &g), "VecDot");
            s.orthonormalityError = std::max(s.orthonormalityError, std::abs(double(g) - (i == j ? 1.0 : 0.0)));
        }
    }
    for (Vec& v : basis) VecDestroy(&v);
    return s;
}

}  // namespace gpisvdb::mpi
