#include "gpisvdb/tasks/hodge.h"

#include <cmath>
#include <Eigen/Eigenvalues>

#include "gpisvdb/core/errors.h"
#include "gpisvdb/ops/first_order.h"

namespace gpisvdb {

namespace {

Mat3d tensorOf(const Band& band, std::size_t i) {
    const auto& t = band.T[i];
    Mat3d T;
    T << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
    return T;
}

Vec3d at(const std::vector<float>& v, std::size_t i) { return {v[3 * i], v[3 * i + 1], v[3 * i + 2]}; }

/// ‖h³ μ ⊙ x‖ in double: the norm of M x.
double massWeightedNorm(const Band& band, const std::vector<float>& x) {
    const double h3 = std::pow(band.voxelSize, 3);
    double s = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double v = h3 * double(band.mu[i]) * double(x[i]);
        s += v * v;
    }
    return std::sqrt(s);
}

/// Face-connected components of the band (the kernel of the Neumann G is the functions constant on each):
/// a component label per voxel, in 0 … count − 1.
std::vector<int> faceComponents(const Band& band, int& count) {
    const std::size_t n = band.size();
    std::vector<int> parent(n);
    for (std::size_t i = 0; i < n; ++i) parent[i] = int(i);
    auto find = [&](int i) {
        while (parent[std::size_t(i)] != i) i = parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
        return i;
    };
    auto acc = band.index->getConstAccessor();
    for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            openvdb::Coord y = band.coord[i];
            y[c] += 1;
            const int j = acc.getValue(y);
            if (j < 0) continue;
            const int a = find(int(i)), b = find(j);
            if (a != b) parent[std::size_t(std::max(a, b))] = std::min(a, b);
        }
    std::vector<int> label(n, -1), rootLabel(n, -1);
    count = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const int r = find(int(i));
        if (rootLabel[std::size_t(r)] < 0) rootLabel[std::size_t(r)] = count++;
        label[i] = rootLabel[std::size_t(r)];
    }
    return label;
}

/// Removes from b its mean over each component, in double: b = Gᵀ w has zero sum per component in exact
/// arithmetic, but the rounding left there is a kernel component the CG can never reduce. (A float b keeps one
/// of ≈ 1e-8 of its norm after rounding the projection: below float's floor, not below a refined tolerance.)
template <class T>
void projectOntoRange(std::vector<T>& b, const std::vector<int>& label, int count) {
    std::vector<double> sum(std::size_t(count), 0.0), size(std::size_t(count), 0.0);
    for (std::size_t i = 0; i < b.size(); ++i) {
        sum[std::size_t(label[i])] += b[i];
        size[std::size_t(label[i])] += 1;
    }
    for (std::size_t i = 0; i < b.size(); ++i) b[i] = T(double(b[i]) - sum[std::size_t(label[i])] / size[std::size_t(label[i])]);
}

}  // namespace

double sInnerProduct(const Band& band, const std::vector<float>& a, const std::vector<float>& b) {
    if (a.size() != 3 * band.size() || b.size() != 3 * band.size())
        throw Error("sInnerProduct: the fields have the wrong length for this band");
    const double h3 = std::pow(band.voxelSize, 3);
    double s = 0;
    for (std::size_t i = 0; i < band.size(); ++i) {
        // T is PSD with a small normal eigenvalue at low σ: floor the spectrum so that S stays finite.
        Eigen::SelfAdjointEigenSolver<Mat3d> eig(tensorOf(band, i));
        const Vec3d lambda = eig.eigenvalues().cwiseMax(1e-6 * std::max(eig.eigenvalues().maxCoeff(), 1e-300));
        const Mat3d Tinv = eig.eigenvectors() * lambda.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
        const double mu = band.mu[i];
        s += h3 * mu * mu * at(a, i).dot(Tinv * at(b, i));
    }
    return s;
}

double hodgeBytes(std::size_t n, const HodgeOptions& options, bool includeFallback) {
    const PcgOptions& so = options.solver;
    const bool refines = so.refinement == Refinement::Always ||
                         (so.refinement == Refinement::Automatic && (so.tolerance < kFloatPcgReach || includeFallback));
    const double held = 4 + 4 + 4 + 12 + (options.boundary == Boundary::Neumann ? 4 : 0);  // D_φ V, rhs, ψ, flux, labels
    // Float: the solve (PCG 20) or the end (G_φ ψ 12, V_free 12, D_φ V_free 4), whichever is larger
    double phase = std::max(20.0, 28.0);
    // Refined: the double flux (24) stays from the refinement on; during it rhs and ψ in double (16) and the
    // double PCG (20 + 24); at the end ψ in double (8) and the parts (28)
    if (refines) phase = 24 + std::max(16.0 + 44.0, 8.0 + 28.0);
    return (held + phase) * double(n);
}

HodgeResult hodgeDecomposition(const Band& band, const std::vector<float>& V, const HodgeOptions& options, const Progress& progress) {
    const std::size_t n = band.size();
    if (V.size() != 3 * n) throw Error("hodge: the vector field has the wrong length for this band");
    for (float v : V)
        if (!std::isfinite(v)) throw InputError("hodge: the vector field holds NaN or infinite values");
    HodgeResult r;

    // === Right-hand side Gᵀ (M ⊗ I) V = M D_φ V
    std::vector<float> divV;
    divPhi(band, V, divV, options.boundary);
    const double h3 = std::pow(band.voxelSize, 3);
    std::vector<float> rhs(n);
    for (std::size_t i = 0; i < n; ++i) rhs[i] = float(h3 * double(band.mu[i]) * double(divV[i]));
    int components = 0;
    std::vector<int> label;
    if (options.boundary == Boundary::Neumann) {
        label = faceComponents(band, components);
        projectOntoRange(rhs, label, components);
    }

    // === Solve K ψ = M D_φ V (K = Gᵀ BlockDiag(h³ T) G: SPD for Dirichlet; for Neumann semi-definite, with the
    //     right-hand side in its range): the float PCG where it reaches the tolerance, else refinement in double
    //     (solve/pcg.h) on a right-hand side and a ψ held in double.
    const NaiveLaplacianOperator K(band, options.boundary);
    r.potential.assign(n, 0.0f);
    const double rhsNorm = massWeightedNorm(band, divV);
    const PcgOptions& so = options.solver;
    const bool refineFromStart =
        so.refinement == Refinement::Always || (so.refinement == Refinement::Automatic && so.tolerance < kFloatPcgReach);
    bool refine = rhsNorm > 0 && refineFromStart;
    if (rhsNorm > 0 && !refineFromStart) {
        PcgOptions plain = so;
        plain.refinement = Refinement::Off;
        r.solver = solvePcg(K, rhs, r.potential, plain, progress);
        // Stalled above the tolerance (float's floor, not the cap): continue in double from this ψ.
        refine = !r.solver.converged && r.solver.iterations < so.maxIterations && so.refinement != Refinement::Off;
    } else if (rhsNorm == 0) {
        r.solver.converged = true;
    }
    std::vector<double> psi;
    if (refine) {
        // The right-hand side again, rounded once and projected in double: the float one's rounding leaves a kernel
        // component (see projectOntoRange) that would stop the refinement near 1e-8.
        std::vector<double> rhsD(n);
        for (std::size_t i = 0; i < n; ++i) rhsD[i] = h3 * double(band.mu[i]) * double(divV[i]);
        if (options.boundary == Boundary::Neumann) projectOntoRange(rhsD, label, components);
        psi.assign(r.potential.begin(), r.potential.end());
        PcgOptions o = so;
        o.refinement = Refinement::Always;
        o.maxIterations = so.maxIterations - r.solver.iterations;  // ≥ 1: the plain solve stopped short of the cap
        PcgResult refined = solvePcg(K, rhsD, psi, o, progress);
        refined.iterations += r.solver.iterations;
        refined.restarts += r.solver.restarts;
        r.solver = refined;
        for (std::size_t i = 0; i < n; ++i) r.potential[i] = float(psi[i]);
    }

    // === Parts: V_grad = G_φ ψ, V_free = V − V_grad (from ψ in double when refined: rounded once, at the end)
    if (refine) gradPhi(band, psi, r.gradient, options.boundary);
    else gradPhi(band, r.potential, r.gradient, options.boundary);
    r.free.resize(3 * n);
    for (std::size_t k = 0; k < 3 * n; ++k) r.free[k] = V[k] - r.gradient[k];

    // === Checks: D_φ V_free ≈ 0 and S-orthogonality (App. E)
    std::vector<float> divFree;
    divPhi(band, r.free, divFree, options.boundary);
    r.divergenceResidual = rhsNorm > 0 ? massWeightedNorm(band, divFree) / rhsNorm : 0.0;
    const double gg = sInnerProduct(band, r.gradient, r.gradient), ff = sInnerProduct(band, r.free, r.free);
    r.sInnerProduct = gg > 0 && ff > 0 ? sInnerProduct(band, r.gradient, r.free) / std::sqrt(gg * ff) : 0.0;
    return r;
}

std::vector<float> hodgePreset(const Band& band, HodgePreset preset) {
    const std::size_t n = band.size();
    Vec3d centre = Vec3d::Zero();
    double mass = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const openvdb::Coord& k = band.coord[i];
        centre += double(band.mu[i]) * band.voxelSize * Vec3d(k.x(), k.y(), k.z());
        mass += band.mu[i];
    }
    if (mass > 0) centre /= mass;
    std::vector<float> V(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        const openvdb::Coord& k = band.coord[i];
        const Vec3d x = band.voxelSize * Vec3d(k.x(), k.y(), k.z()) - centre;
        Vec3d v = Vec3d::Zero();
        if (preset != HodgePreset::Gradient) v += Vec3d(-x.y(), x.x(), 0.0);
        if (preset != HodgePreset::Rotation) v += tensorOf(band, i).col(2) / double(band.mu[i]);
        for (int c = 0; c < 3; ++c) V[3 * i + std::size_t(c)] = float(v[c]);
    }
    return V;
}

}  // namespace gpisvdb
