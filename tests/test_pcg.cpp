#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <Eigen/SparseCholesky>
#include <tbb/global_control.h>

#include "allocation_counter.h"
#include "band_fixtures.h"
#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/first_order.h"
#include "gpisvdb/ops/laplacian.h"
#include "gpisvdb/solve/pcg.h"

using namespace gpisvdb;

namespace {

Eigen::VectorXd asDouble(const std::vector<float>& v) { return Eigen::Map<const Eigen::VectorXf>(v.data(), long(v.size())).cast<double>(); }

/// L⁻¹ b by a sparse LDLᵀ of L assembled in double (the operator the matrix-free L applies), factorised once per
/// band (≈ 3 s on the torus band) and shared by the test cases that compare against it.
Eigen::VectorXd directSolve(const Band& band, const std::vector<float>& b) {
    static const Band* factored = nullptr;
    static Eigen::SimplicialLDLT<SparseMatrixD> ldlt;
    if (factored != &band) {
        ldlt.compute(assembleLaplacianDouble(band));
        REQUIRE(ldlt.info() == Eigen::Success);
        factored = &band;
    }
    return ldlt.solve(asDouble(b));
}

/// ‖b − L x‖ / ‖b‖ with L straight from the stencils (paper Eq. 24), all in double: the operator the matrix-free
/// L applies (the assembled one rounds its entries to float, which moves this residual by ~1e-6 here). x and b
/// in float or double; independent of the operators' own code.
template <class X, class B>
double stencilResidual(const Band& band, const std::vector<X>& x, const std::vector<B>& b) {
    std::vector<double> r(b.begin(), b.end());
    auto acc = band.index->getConstAccessor();
    for (std::size_t i = 0; i < band.size(); ++i) {
        const VoxelStencil& st = band.stencil[i];
        for (int k = 0; k < st.count; ++k) {
            const double w = 0.5 * band.voxelSize * double(st.weight[k]);
            const openvdb::Coord e(st.offset[k][0], st.offset[k][1], st.offset[k][2]);
            for (const openvdb::Coord& y : {band.coord[i] + e, band.coord[i] - e}) {
                const int j = acc.getValue(y);
                const double d = w * ((j < 0 ? 0.0 : double(x[std::size_t(j)])) - double(x[i]));
                r[i] += d;  // r = b − L x: L x gains −d at i and +d at j
                if (j >= 0) r[std::size_t(j)] -= d;
            }
        }
    }
    double num = 0, den = 0;
    for (std::size_t i = 0; i < r.size(); ++i) num += r[i] * r[i], den += double(b[i]) * double(b[i]);
    return std::sqrt(num / den);
}

PcgOptions options(double tolerance, Refinement refinement = Refinement::Automatic, int maxIterations = 50000) {
    PcgOptions o;
    o.tolerance = tolerance;
    o.maxIterations = maxIterations;
    o.refinement = refinement;
    return o;
}

}  // namespace

TEST_CASE("pcg: reaches the tolerance and agrees with a sparse Cholesky solve, matrix-free and assembled", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF A = assembleLaplacian(band);
    const LaplacianOperator L(band);
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 3] = float(band.mu[band.size() / 3]);
    const Eigen::SparseMatrix<double> Ad = A.cast<double>();
    const Eigen::VectorXd bd = asDouble(b);
    const Eigen::VectorXd exact = directSolve(band, b);
    // L is an M-matrix (positive stencil weights, rows leaving the band strictly dominant) and the torus band is
    // connected, so L⁻¹ > 0 entrywise: this Green's function is positive everywhere (its minimum is 1.4e-3 of its
    // maximum here).
    REQUIRE(exact.minCoeff() > 1e-4 * exact.maxCoeff());
    const AssembledOperator assembled(A);
    for (const SymmetricOperator* op : {static_cast<const SymmetricOperator*>(&L), static_cast<const SymmetricOperator*>(&assembled)}) {
        std::vector<float> x;
        const PcgResult r = solvePcg(*op, b, x, {1e-6, 20000});
        INFO(band.size() << " voxels, " << r.iterations << " iterations, residual " << r.relativeResidual);
        REQUIRE(r.converged);
        CHECK(r.relativeResidual <= 1e-6);
        // The true residual, recomputed in double, is at the tolerance too (float storage costs ~1e-7).
        const Eigen::VectorXd xd = asDouble(x);
        CHECK((bd - Ad * xd).norm() <= 1e-5 * bd.norm());
        // Against the direct solve: the residual's tolerance 1e-6, times twenty (measured 1.0e-6 matrix-free,
        // 1.2e-6 assembled).
        CHECK((xd - exact).norm() <= 2e-5 * exact.norm());
        // Positive at every voxel, like L⁻¹ (a PCG stopped early leaves zeros far from the source).
        CHECK(xd.minCoeff() > 0);
    }
}

TEST_CASE("pcg: incomplete Cholesky reaches the same solution in fewer iterations", "[pcg]") {
    const Band& band = test::torusGapBand();
    const SparseMatrixF A = assembleLaplacian(band);
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 2] = 1.0f;
    std::vector<float> xj, xi;
    PcgOptions o;
    const PcgResult rj = solvePcg(LaplacianOperator(band), b, xj, o);
    o.preconditioner = Preconditioner::IncompleteCholesky;
    const PcgResult ri = solvePcg(A, b, xi, o);
    REQUIRE(rj.converged);
    REQUIRE(ri.converged);
    CHECK(ri.iterations < rj.iterations);
    // Both against the direct solve, to the residual's tolerance 1e-6 times twenty (measured 1.3e-6 Jacobi,
    // 2.1e-6 IC), and positive at every voxel like L⁻¹ (see the first test case).
    const Eigen::VectorXd exact = directSolve(band, b);
    for (const std::vector<float>* x : {&xj, &xi}) {
        INFO((x == &xj ? "Jacobi" : "incomplete Cholesky"));
        const Eigen::VectorXd xd = asDouble(*x);
        CHECK((xd - exact).norm() <= 2e-5 * exact.norm());
        CHECK(xd.minCoeff() > 0);
    }
}

TEST_CASE("pcg: a solve allocates nothing of size N beyond the solver's work vectors", "[pcg]") {
    const Band& band = test::torusGapBand();
    const std::size_t n = band.size();
    const SparseMatrixF A = assembleLaplacian(band);
    const LaplacianOperator L(band);
    const AssembledOperator assembled(A);
    std::vector<float> b(n, 0.0f), x(n, 0.0f);
    b[n / 4] = 1.0f;
    struct Case {
        const char* name;
        const SymmetricOperator* op;
        Preconditioner pc;
    };
    for (const Case& c :
         {Case{"matrix-free, Jacobi", &L, Preconditioner::Jacobi}, Case{"assembled, Jacobi", &assembled, Preconditioner::Jacobi},
          Case{"assembled, incomplete Cholesky", &assembled, Preconditioner::IncompleteCholesky}}) {
        INFO(c.name);
        PcgOptions o;
        o.preconditioner = c.pc;
        const PcgSolver solver(*c.op, o);  // work vectors and preconditioner: allocated here
        std::fill(x.begin(), x.end(), 0.0f);
        PcgResult r;
        std::size_t large = 0;
        {
            const test::CountLargeAllocations counter(n * sizeof(float) / 4);  // anything of a quarter of N floats
            r = solver.solve(b, x);
            large = counter.count();
        }
        CHECK(r.converged);
        CHECK(r.iterations > 10);
        CHECK(large == 0);
        // The work vectors themselves: four of N floats plus the preconditioner.
        CHECK(solver.memoryBytes() >= 4 * n * sizeof(float));
    }
}

TEST_CASE("pcg: identical iterates for 1 and 2 threads", "[pcg]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    std::vector<float> b(band.size(), 0.0f);
    for (std::size_t i = 0; i < b.size(); i += 97) b[i] = 1.0f;
    std::vector<float> x1, x2;
    PcgResult r1, r2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        r1 = solvePcg(L, b, x1);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        r2 = solvePcg(L, b, x2);
    }
    CHECK(r1.iterations == r2.iterations);
    CHECK(x1 == x2);
}

TEST_CASE("pcg: reports an unconverged solve at the iteration cap", "[pcg]") {
    const Band& band = test::torusGapBand();
    std::vector<float> b(band.size(), 1.0f), x;
    const PcgResult r = solvePcg(LaplacianOperator(band), b, x, {1e-6, 5});
    CHECK(!r.converged);
    CHECK(r.iterations == 5);
    // The reported residual is the true one, recomputed from the stencils: far from the tolerance after 5 iterations.
    const double truth = stencilResidual(band, x, b);
    CHECK(r.relativeResidual == Approx(truth).epsilon(0.05));
    CHECK(truth > 1e-2);
}

TEST_CASE("pcg: the reported residual is the true one, below float's reach the float PCG alone says it did not converge", "[pcg]") {
    // The recursively updated residual drifts below the true one in float storage; restarts from the true one
    // recover the tolerance where float can reach it (measured floor ≈ 4e-7 on this band).
    const Band& band = test::torusGapBand();
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 2] = 1.0f;
    for (double tol : {1e-5, 1e-6, 1e-9}) {
        std::vector<float> x;
        const PcgResult r = solvePcg(LaplacianOperator(band), b, x, options(tol, Refinement::Off));
        const double truth = stencilResidual(band, x, b);
        INFO("tolerance " << tol << ": " << r.iterations << " iterations, " << r.restarts << " restarts, residual " << r.relativeResidual);
        CHECK(r.relativeResidual == Approx(truth).epsilon(0.05));
        CHECK(r.converged == (tol >= 1e-6));
        CHECK(r.converged == (r.relativeResidual <= tol));
        CHECK(r.iterations < 50000);  // stagnation ends the solve, not the cap
    }
}

TEST_CASE("pcg: a zero right-hand side gives zero, bad options and inputs are refused", "[pcg]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    std::vector<float> x(band.size(), 1.0f);
    const PcgResult r = solvePcg(L, std::vector<float>(band.size(), 0.0f), x);
    CHECK(r.converged);
    CHECK(std::all_of(x.begin(), x.end(), [](float v) { return v == 0.0f; }));  // every entry, not only the largest
    const std::vector<float> ones(band.size(), 1.0f);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {0.0, 10}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {-1.0, 10}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {std::nan(""), 10}), ParameterError);
    CHECK_THROWS_AS(solvePcg(L, ones, x, {1e-6, 0}), ParameterError);
    // IC and multigrid need the operator's entries: the naive first-order Laplacian cannot be assembled.
    const NaiveLaplacianOperator naive(band);
    for (Preconditioner pc : {Preconditioner::IncompleteCholesky, Preconditioner::Multigrid}) {
        PcgOptions o;
        o.preconditioner = pc;
        CHECK_THROWS_AS(solvePcg(naive, ones, x, o), ParameterError);
    }
    CHECK_THROWS_AS(solvePcg(L, std::vector<float>(3, 1.0f), x), Error);
    std::vector<float> bad = ones;
    bad[7] = std::nanf("");
    CHECK_THROWS_AS(solvePcg(L, bad, x), Error);
}

// === Mixed-precision iterative refinement (solve/pcg.h): tolerances below float's floor

namespace {

std::vector<float> unitSource(const Band& band) {
    std::vector<float> b(band.size(), 0.0f);
    b[band.size() / 2] = 1.0f;
    return b;
}

}  // namespace

TEST_CASE("pcg: the double apply is the float apply's matrix, summed without rounding", "[pcg]") {
    const Band& band = test::torusGapBand();
    const std::size_t n = band.size();
    const std::vector<float> u = test::randomField(n, 7), v = test::randomField(n, 8);
    const std::vector<double> ud(u.begin(), u.end()), vd(v.begin(), v.end());
    const SparseMatrixF A = assembleLaplacian(band);
    const SparseMatrixD Ad = assembleLaplacianDouble(band);
    const LaplacianOperator L(band);
    const AssembledOperator assembled(A);
    const NaiveLaplacianOperator K(band, Boundary::Neumann);
    const Eigen::VectorXd reference = Ad * Eigen::Map<const Eigen::VectorXd>(ud.data(), long(n));
    std::vector<double> out, outV;
    std::vector<float> outF;
    // Matrix-free L: the double-assembled matrix (same weights, same sums) to double's rounding, where the float
    // apply differs by float's (≈ 6e-8 relative per entry).
    L.apply(ud, out);
    const double scale = reference.norm();
    CHECK((Eigen::Map<const Eigen::VectorXd>(out.data(), long(n)) - reference).norm() <= 1e-13 * scale);
    L.apply(u, outF);
    const double floatError = (asDouble(outF) - reference).norm();
    CHECK(floatError > 1e-9 * scale);
    CHECK(floatError <= 1e-6 * scale);
    // The assembled operator: its float entries, applied in double, to float's rounding of those entries.
    assembled.apply(ud, out);
    CHECK((Eigen::Map<const Eigen::VectorXd>(out.data(), long(n)) - reference).norm() <= 1e-6 * scale);
    // K (Neumann): symmetric in double to double's rounding, uᵀ K v = vᵀ K u, and equal to its float apply to
    // float's rounding (that one rounds its flux h³ T G u to float too).
    K.apply(ud, out);
    K.apply(vd, outV);
    double uKv = 0, vKu = 0, norm = 0;
    for (std::size_t i = 0; i < n; ++i) uKv += ud[i] * outV[i], vKu += vd[i] * out[i], norm += std::abs(ud[i] * outV[i]);
    CHECK(std::abs(uKv - vKu) <= 1e-13 * norm);
    K.apply(u, outF);
    const Eigen::VectorXd Ku = Eigen::Map<const Eigen::VectorXd>(out.data(), long(n));
    CHECK((asDouble(outF) - Ku).norm() <= 1e-5 * Ku.norm());
}

TEST_CASE("pcg: reaches 1e-8 and 1e-10 by iterative refinement where float stalls", "[pcg]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    const std::vector<float> b = unitSource(band);
    const std::vector<double> bd(b.begin(), b.end());
    // Float alone stalls above 1e-7 on this band (the floor measured ≈ 4e-7).
    {
        std::vector<float> x;
        const PcgResult r = solvePcg(L, b, x, options(1e-8, Refinement::Off));
        INFO("float alone: " << r.iterations << " iterations, residual " << r.relativeResidual);
        CHECK(!r.converged);
        CHECK(r.refinements == 0);
        CHECK(stencilResidual(band, x, b) > 1e-7);
    }
    for (double tol : {1e-8, 1e-10}) {
        // Double API: the solution as refined; its true residual recomputed from the stencils in double.
        std::vector<double> x;
        const PcgResult r = solvePcg(L, bd, x, options(tol));
        const double truth = stencilResidual(band, x, bd);
        INFO("tolerance " << tol << ": " << r.refinements << " refinements, " << r.iterations << " iterations (" << r.innerIterations
                          << " inner), residual " << r.relativeResidual << ", recomputed " << truth << ", float-rounded "
                          << r.floatResidual);
        REQUIRE(r.converged);
        CHECK(r.refinements >= 2);
        CHECK(r.innerIterations == r.iterations);  // refined from the start: every iteration is an inner one
        CHECK(truth <= tol);
        CHECK(truth == Approx(r.relativeResidual).epsilon(1e-3));
        // Float rounding of the solution alone leaves it far above the tolerance: the reason for the double API.
        std::vector<float> rounded(x.begin(), x.end());
        CHECK(r.floatResidual == Approx(stencilResidual(band, rounded, b)).epsilon(1e-3));
        CHECK(r.floatResidual > 10 * tol);
        // Float API: the same refinement, the result rounded to float, the double solution's residual reported.
        std::vector<float> xf;
        const PcgResult rf = solvePcg(L, b, xf, options(tol));
        CHECK(rf.converged);
        CHECK(rf.relativeResidual == r.relativeResidual);
        CHECK(xf == rounded);
        CHECK(rf.floatResidual == Approx(stencilResidual(band, xf, b)).epsilon(1e-3));
    }
}

TEST_CASE("pcg: a refined solution equals a double-precision sparse LDLT solve within the tolerance's error", "[pcg]") {
    const Band& band = test::torusGapBand();
    const std::vector<float> b = unitSource(band);
    const std::vector<double> bd(b.begin(), b.end());
    const Eigen::VectorXd exact = directSolve(band, b);
    const SparseMatrixF A = assembleLaplacian(band);
    const AssembledOperator assembled(A);
    const LaplacianOperator L(band);
    double last = 1;
    for (double tol : {1e-8, 1e-10}) {
        std::vector<double> x;
        const PcgResult r = solvePcg(L, bd, x, options(tol));
        REQUIRE(r.converged);
        const double error = (Eigen::Map<const Eigen::VectorXd>(x.data(), long(x.size())) - exact).norm() / exact.norm();
        INFO("tolerance " << tol << ": relative error " << error);
        // ‖x − x*‖/‖x*‖ ≤ κ(L) · residual; measured 3.9e-8 at 1e-8 (residual reached 4.9e-9) and 9.5e-11 at 1e-10
        // (5.2e-11): 20× the tolerance leaves room without hiding a solution that is off by float's 1e-7.
        CHECK(error <= 20 * tol);
        CHECK(error < last);
        last = error;
    }
    // The incomplete Cholesky preconditioner refines too (its inner solves on the assembled operator, whose float
    // entries differ from L's weights by float's rounding: a relative 1e-7 apart, so against the direct solve of
    // L only to that).
    std::vector<double> x;
    PcgOptions o = options(1e-10);
    o.preconditioner = Preconditioner::IncompleteCholesky;
    const PcgResult r = solvePcg(assembled, bd, x, o);
    CHECK(r.converged);
    CHECK(r.refinements >= 2);
    CHECK((Eigen::Map<const Eigen::VectorXd>(x.data(), long(x.size())) - exact).norm() <= 1e-5 * exact.norm());
}

TEST_CASE("pcg: at float-reachable tolerances the float path runs, bit-identical to refinement switched off", "[pcg]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    const std::vector<float> b = unitSource(band);
    for (double tol : {1e-5, 1e-6}) {
        std::vector<float> automatic, off, always;
        const PcgResult ra = solvePcg(L, b, automatic, options(tol));
        const PcgResult ro = solvePcg(L, b, off, options(tol, Refinement::Off));
        CHECK(ra.refinements == 0);
        CHECK(ra.iterations == ro.iterations);
        CHECK(ra.relativeResidual == ro.relativeResidual);
        CHECK(automatic == off);
        // Refinement forced at such a tolerance reaches it too (at least one outer step).
        const PcgResult rr = solvePcg(L, b, always, options(tol, Refinement::Always));
        CHECK(rr.converged);
        CHECK(rr.refinements >= 1);
        CHECK(stencilResidual(band, always, b) <= 2 * tol);
    }
}

TEST_CASE("pcg: refined solves are identical for 1 and 2 threads", "[pcg]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    std::vector<double> b(band.size(), 0.0);
    for (std::size_t i = 0; i < b.size(); i += 97) b[i] = 1.0;
    std::vector<double> x1, x2;
    PcgResult r1, r2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        r1 = solvePcg(L, b, x1, options(1e-10));
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        r2 = solvePcg(L, b, x2, options(1e-10));
    }
    CHECK(r1.converged);
    CHECK(r1.iterations == r2.iterations);
    CHECK(r1.refinements == r2.refinements);
    CHECK(r1.relativeResidual == r2.relativeResidual);
    CHECK(x1 == x2);
}

TEST_CASE("pcg: a second refined solve allocates nothing of size N, and tolerances below 1e-12 are refused", "[pcg]") {
    const Band& band = test::torusGapBand();
    const std::size_t n = band.size();
    const LaplacianOperator L(band);
    const std::vector<float> b = unitSource(band);
    const PcgSolver solver(L, options(1e-9));
    std::vector<float> x;
    const std::size_t before = solver.memoryBytes();
    REQUIRE(solver.solve(b, x).converged);
    // r in double, the inner right-hand side and solution in float, x in double: 24 bytes per unknown more.
    CHECK(solver.memoryBytes() == before + 24 * n);
    std::fill(x.begin(), x.end(), 0.0f);
    std::size_t large = 0;
    PcgResult r;
    {
        const test::CountLargeAllocations counter(n * sizeof(float) / 4);
        r = solver.solve(b, x);
        large = counter.count();
    }
    CHECK(r.converged);
    CHECK(r.refinements >= 2);
    CHECK(large == 0);
    std::vector<float> y;
    CHECK_THROWS_AS(solvePcg(L, b, y, options(1e-13)), ParameterError);
    CHECK_NOTHROW(PcgSolver(L, options(1e-12)));
}

// === The multigrid preconditioner (solve/boomer_amg.h: one BoomerAMG V-cycle)

namespace {

/// The torus band at h 0.03: ≈ 2e5 voxels, above kMultigridMinUnknowns (built once).
const Band& fineTorusBand() {
    static const Band band = test::bandOf(torus(48, 16), 1.0, 0.03);
    return band;
}

PcgOptions multigridOptions(double tolerance) {
    PcgOptions o = options(tolerance);
    o.preconditioner = Preconditioner::Multigrid;
    return o;
}

}  // namespace

TEST_CASE("pcg: the multigrid and Jacobi preconditioners reach the same solution, matrix-free and assembled", "[pcg][multigrid]") {
    const Band& band = test::torusGapBand();
    const std::vector<float> b = unitSource(band);
    const Eigen::VectorXd exact = directSolve(band, b);
    std::vector<float> xj;
    PcgOptions jacobi = options(1e-6);
    jacobi.preconditioner = Preconditioner::Jacobi;
    const PcgResult rj = solvePcg(LaplacianOperator(band), b, xj, jacobi);
    REQUIRE(rj.converged);
    const SparseMatrixF A = assembleLaplacian(band);
    const LaplacianOperator matrixFree(band);
    const AssembledOperator assembled(A);
    for (const SymmetricOperator* op :
         {static_cast<const SymmetricOperator*>(&matrixFree), static_cast<const SymmetricOperator*>(&assembled)}) {
        const PcgSolver solver(*op, multigridOptions(1e-6));
        REQUIRE(solver.preconditioner() == Preconditioner::Multigrid);
        REQUIRE(solver.multigrid());
        std::vector<float> x;
        const PcgResult r = solver.solve(b, x);
        INFO(band.size() << " voxels: Jacobi " << rj.iterations << " iterations, multigrid " << r.iterations << " ("
                         << solver.multigrid()->levels() << " levels, operator complexity " << solver.multigrid()->operatorComplexity()
                         << ")");
        REQUIRE(r.converged);
        // The reported residual is the true one: from the stencils for the matrix-free L, of the float entries for
        // the assembled one (they differ by ~1e-6: the first test case).
        const double truth =
            op == &matrixFree ? stencilResidual(band, x, b) : (A.cast<double>() * asDouble(x) - asDouble(b)).norm() / asDouble(b).norm();
        CHECK(r.relativeResidual == Approx(truth).epsilon(0.05));
        // A V-cycle does far more than a Jacobi sweep: here 8× fewer iterations at least (measured 12 against 180).
        CHECK(8 * r.iterations <= rj.iterations);
        // Both solutions against the direct solve, to the residual's tolerance times twenty, and against each other.
        const Eigen::VectorXd xd = asDouble(x);
        CHECK((xd - exact).norm() <= 2e-5 * exact.norm());
        CHECK((xd - asDouble(xj)).norm() <= 4e-5 * exact.norm());
        CHECK(xd.minCoeff() > 0);  // L⁻¹ > 0 entrywise (first test case)
        CHECK(solver.multigrid()->levels() >= 2);
        CHECK(solver.multigrid()->operatorComplexity() >= 1.0);
        CHECK(solver.multigrid()->operatorComplexity() < 3.0);
        // Beyond Jacobi's work vectors, the hierarchy: at least hypre's copy of L (12 bytes per entry).
        CHECK(solver.memoryBytes() >= std::size_t(A.nonZeros()) * 12);
    }
}

TEST_CASE("pcg: multigrid iterations stay nearly flat on nested bands while Jacobi's grow", "[pcg][multigrid]") {
    // The bunny-like study of bench_solve --part multigrid at test scale: a torus band at h, h/2 and h/4 (each about
    // 4× the voxels of the last; a thin band's count grows like h⁻² to h⁻³). Issue 18 asks for ≤ 1.5× iterations per
    // 8× voxels; the growth per 8× is (iterations ratio)^(log 8 / log(voxel ratio)).
    const TriangleSoup ring = torus(48, 16);
    std::vector<std::size_t> voxels;
    std::vector<int> multigrid, jacobi;
    const Band coarse = test::bandOf(ring, 1.0, 0.12), middle = test::bandOf(ring, 1.0, 0.06);
    for (const Band* bandPtr : {&coarse, &middle, &fineTorusBand()}) {
        const Band& band = *bandPtr;
        const double h = band.voxelSize;
        const std::vector<float> b = unitSource(band);
        const LaplacianOperator L(band);
        std::vector<float> x;
        const PcgResult rm = solvePcg(L, b, x, multigridOptions(1e-6));
        PcgOptions o = options(1e-6);
        o.preconditioner = Preconditioner::Jacobi;
        x.clear();
        const PcgResult rj = solvePcg(L, b, x, o);
        REQUIRE(rm.converged);
        REQUIRE(rj.converged);
        voxels.push_back(band.size());
        multigrid.push_back(rm.iterations);
        jacobi.push_back(rj.iterations);
        UNSCOPED_INFO("h " << h << ": " << band.size() << " voxels, multigrid " << rm.iterations << ", Jacobi " << rj.iterations);
    }
    for (std::size_t k = 1; k < voxels.size(); ++k) {
        const double exponent = std::log(8.0) / std::log(double(voxels[k]) / double(voxels[k - 1]));
        CHECK(double(voxels[k]) > 2.5 * double(voxels[k - 1]));
        CHECK(std::pow(double(multigrid[k]) / double(multigrid[k - 1]), exponent) <= 1.5);
        // Jacobi's count grows like the band's diameter in voxels: the contrast that makes the test mean something.
        CHECK(std::pow(double(jacobi[k]) / double(jacobi[k - 1]), exponent) >= 1.5);
    }
}

TEST_CASE("pcg: multigrid solves are identical for 1 and 2 threads, and reach 1e-10 by refinement", "[pcg][multigrid]") {
    const Band& band = test::torusGapBand();
    const LaplacianOperator L(band);
    const std::vector<float> b = unitSource(band);
    std::vector<float> x1, x2;
    PcgResult r1, r2;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        r1 = solvePcg(L, b, x1, multigridOptions(1e-6));
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        r2 = solvePcg(L, b, x2, multigridOptions(1e-6));
    }
    CHECK(r1.iterations == r2.iterations);
    CHECK(x1 == x2);
    // Below float's reach the refinement's inner solves are multigrid-preconditioned too.
    std::vector<double> bd(b.begin(), b.end()), x;
    const PcgResult r = solvePcg(L, bd, x, multigridOptions(1e-10));
    INFO(r.iterations << " iterations in " << r.refinements << " refinements, residual " << r.relativeResidual);
    CHECK(r.converged);
    CHECK(r.refinements >= 1);
    CHECK(stencilResidual(band, x, bd) <= 1e-10);
}

TEST_CASE("pcg: the automatic preconditioner is Jacobi on small or unassemblable operators, aggregation on large bands",
          "[pcg][multigrid]") {
    const Band& band = test::torusGapBand();
    REQUIRE(band.size() < kMultigridMinUnknowns);
    const LaplacianOperator L(band);
    CHECK(resolvePreconditioner(Preconditioner::Automatic, L) == Preconditioner::Jacobi);
    CHECK(PcgSolver(L).preconditioner() == Preconditioner::Jacobi);
    CHECK(resolvePreconditioner(Preconditioner::Multigrid, L) == Preconditioner::Multigrid);
    const Band& large = fineTorusBand();
    REQUIRE(large.size() >= kMultigridMinUnknowns);
    const LaplacianOperator Llarge(large);
    CHECK(resolvePreconditioner(Preconditioner::Automatic, Llarge) == Preconditioner::Aggregation);
    CHECK(resolvePreconditioner(Preconditioner::Automatic, AssembledOperator(assembleLaplacian(large))) == Preconditioner::Multigrid);
    CHECK(resolvePreconditioner(Preconditioner::Automatic, NaiveLaplacianOperator(large)) == Preconditioner::Jacobi);
}

TEST_CASE("pcg: bad multigrid options are refused", "[pcg][multigrid]") {
    const Band& band = test::sphereBand();
    const LaplacianOperator L(band);
    for (auto set : std::initializer_list<void (*)(BoomerAmgOptions&)>{
             [](BoomerAmgOptions& o) { o.strongThreshold = 0; }, [](BoomerAmgOptions& o) { o.strongThreshold = 1; },
             [](BoomerAmgOptions& o) { o.strongThreshold = std::nan(""); }, [](BoomerAmgOptions& o) { o.maxInterpolationEntries = 0; },
             [](BoomerAmgOptions& o) { o.aggressiveLevels = -1; }}) {
        PcgOptions o = multigridOptions(1e-6);
        set(o.multigrid);
        CHECK_THROWS_AS(PcgSolver(L, o), ParameterError);
    }
    CHECK_THROWS_AS(BoomerAmg(SparseMatrixF(0, 0)), ParameterError);
    CHECK_THROWS_AS(BoomerAmg(SparseMatrixF(3, 4)), ParameterError);
}
