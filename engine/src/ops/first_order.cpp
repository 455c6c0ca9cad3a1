#include "gpisvdb/ops/first_order.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "gpisvdb/core/errors.h"

namespace gpisvdb {

namespace {

using openvdb::Coord;
const Coord kAxis[3] = {Coord(1, 0, 0), Coord(0, 1, 0), Coord(0, 0, 1)};

/// body(i, accessor) over all voxels, in parallel.
template <class Body>
void forEachVoxel(const Band& band, const Body& body) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, band.size(), 1024), [&](const tbb::blocked_range<std::size_t>& r) {
        auto acc = band.index->getConstAccessor();
        for (std::size_t i = r.begin(); i != r.end(); ++i) body(i, acc);
    });
}

/// T_i as a 3×3 matrix (double).
Mat3d tensor(const Band& band, std::size_t i) {
    const auto& t = band.T[i];
    Mat3d T;
    T << t[0], t[3], t[4], t[3], t[1], t[5], t[4], t[5], t[2];
    return T;
}

void checkSize(std::size_t got, std::size_t want, const char* what) {
    if (got != want) throw Error(std::string(what) + ": the input has the wrong length for this band");
}

/// (G u)_i in double (u float or double).
template <class T, class Acc>
Vec3d forwardDifference(const Band& band, const T* u, std::size_t i, Acc& acc, Boundary bc) {
    const double inv = 1.0 / band.voxelSize;
    Vec3d g;
    for (int c = 0; c < 3; ++c) {
        const int j = acc.getValue(band.coord[i] + kAxis[c]);
        if (j < 0) g[c] = bc == Boundary::Neumann ? 0.0 : -double(u[i]) * inv;
        else g[c] = (double(u[j]) - double(u[i])) * inv;
    }
    return g;
}

/// (Gᵀ v)_i = Σ_c (v_{i − e_c, c} − v_{i, c}) / h, with v read through `at(j, c)`; with Neumann boundaries the rows
/// G dropped (differences leaving the band) drop out too.
template <class Acc, class At>
double transposeDifference(const Band& band, std::size_t i, Acc& acc, const At& at, Boundary bc) {
    double s = 0;
    for (int c = 0; c < 3; ++c) {
        const int j = acc.getValue(band.coord[i] - kAxis[c]);
        if (j >= 0) s += at(std::size_t(j), c);
        if (bc == Boundary::Dirichlet || acc.getValue(band.coord[i] + kAxis[c]) >= 0) s -= at(i, c);
    }
    return s / band.voxelSize;
}

}  // namespace

void gradient(const Band& band, const std::vector<float>& u, std::vector<float>& out, Boundary bc) {
    checkSize(u.size(), band.size(), "gradient");
    out.resize(3 * band.size());
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        const Vec3d g = forwardDifference(band, u.data(), i, acc, bc);
        for (int c = 0; c < 3; ++c) out[3 * i + std::size_t(c)] = float(g[c]);
    });
}

void gradientTranspose(const Band& band, const std::vector<float>& v, std::vector<float>& out, Boundary bc) {
    checkSize(v.size(), 3 * band.size(), "gradientTranspose");
    out.resize(band.size());
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        out[i] = float(transposeDifference(
            band, i, acc, [&](std::size_t j, int c) { return double(v[3 * j + std::size_t(c)]); }, bc));
    });
}

void gradPhi(const Band& band, const std::vector<float>& u, std::vector<float>& out, Boundary bc) {
    checkSize(u.size(), band.size(), "gradPhi");
    out.resize(3 * band.size());
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        const Vec3d g = tensor(band, i) * forwardDifference(band, u.data(), i, acc, bc) / double(band.mu[i]);
        for (int c = 0; c < 3; ++c) out[3 * i + std::size_t(c)] = float(g[c]);
    });
}

void gradPhi(const Band& band, const std::vector<double>& u, std::vector<float>& out, Boundary bc) {
    checkSize(u.size(), band.size(), "gradPhi");
    out.resize(3 * band.size());
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        const Vec3d g = tensor(band, i) * forwardDifference(band, u.data(), i, acc, bc) / double(band.mu[i]);
        for (int c = 0; c < 3; ++c) out[3 * i + std::size_t(c)] = float(g[c]);
    });
}

void divPhi(const Band& band, const std::vector<float>& V, std::vector<float>& out, Boundary bc) {
    checkSize(V.size(), 3 * band.size(), "divPhi");
    out.resize(band.size());
    // (D_φ V)_i = (1/μ_i) Σ_c (μ_{i−e_c} V_{i−e_c,c} − μ_i V_{i,c}) / h: the h³ of M cancels.
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        const double s = transposeDifference(
            band, i, acc, [&](std::size_t j, int c) { return double(band.mu[j]) * double(V[3 * j + std::size_t(c)]); }, bc);
        out[i] = float(s / double(band.mu[i]));
    });
}

// === Assembled forms

SparseMatrixF assembleGradient(const Band& band, Boundary bc) {
    const std::size_t n = band.size();
    const float inv = float(1.0 / band.voxelSize);
    std::vector<Eigen::Triplet<float, int>> t;
    t.reserve(6 * n);
    auto acc = band.index->getConstAccessor();
    for (std::size_t i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            const int row = int(3 * i) + c;
            const int j = acc.getValue(band.coord[i] + kAxis[c]);
            if (j >= 0 || bc == Boundary::Dirichlet) t.emplace_back(row, int(i), -inv);
            if (j >= 0) t.emplace_back(row, j, inv);
        }
    SparseMatrixF G(int(3 * n), int(n));
    G.setFromTriplets(t.begin(), t.end());
    G.makeCompressed();
    return G;
}

namespace {
/// BlockDiag(s_i · T_i), 3N × 3N.
SparseMatrixF blockDiagonalT(const Band& band, const std::vector<double>& scale) {
    std::vector<Eigen::Triplet<float, int>> t;
    t.reserve(9 * band.size());
    for (std::size_t i = 0; i < band.size(); ++i) {
        const Mat3d T = scale[i] * tensor(band, i);
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b) t.emplace_back(int(3 * i) + a, int(3 * i) + b, float(T(a, b)));
    }
    SparseMatrixF B(int(3 * band.size()), int(3 * band.size()));
    B.setFromTriplets(t.begin(), t.end());
    return B;
}
}  // namespace

SparseMatrixF assembleGradPhi(const Band& band) {
    std::vector<double> inverseMu(band.size());
    for (std::size_t i = 0; i < band.size(); ++i) inverseMu[i] = 1.0 / double(band.mu[i]);
    SparseMatrixF Gphi = blockDiagonalT(band, inverseMu) * assembleGradient(band);
    Gphi.makeCompressed();
    return Gphi;
}

SparseMatrixF assembleDivPhi(const Band& band) {
    const std::size_t n = band.size();
    const SparseMatrixF Gt = SparseMatrixF(assembleGradient(band).transpose());
    Eigen::VectorXf muRows(static_cast<Eigen::Index>(n)), muCols(static_cast<Eigen::Index>(3 * n));
    for (std::size_t i = 0; i < n; ++i) {
        muRows[long(i)] = 1.0f / band.mu[i];
        for (int c = 0; c < 3; ++c) muCols[long(3 * i) + c] = band.mu[i];
    }
    SparseMatrixF D = muRows.asDiagonal() * Gt * muCols.asDiagonal();
    D.makeCompressed();
    return D;
}

SparseMatrixF assembleNaiveLaplacian(const Band& band) {
    SparseMatrixF A = assembleDivPhi(band) * assembleGradPhi(band);
    A.makeCompressed();
    return A;
}

// === K = Gᵀ BlockDiag(h³ T) G, matrix-free

NaiveLaplacianOperator::NaiveLaplacianOperator(const Band& band, Boundary bc) : band_(band), bc_(bc), flux_(3 * band.size()) {}

void NaiveLaplacianOperator::apply(const float* u, float* out) const {
    const Band& band = band_;
    const double h3 = band.voxelSize * band.voxelSize * band.voxelSize;
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        const Vec3d f = h3 * (tensor(band, i) * forwardDifference(band, u, i, acc, bc_));
        for (int c = 0; c < 3; ++c) flux_[3 * i + std::size_t(c)] = float(f[c]);
    });
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        out[i] = float(transposeDifference(
            band, i, acc, [&](std::size_t j, int c) { return double(flux_[3 * j + std::size_t(c)]); }, bc_));
    });
}

void NaiveLaplacianOperator::apply(const double* u, double* out) const {
    // The float apply rounds the flux h³ T G u to float between its two halves; the residual of iterative
    // refinement must not, so the flux is kept in double here (3N doubles, allocated at the first call).
    const Band& band = band_;
    const double h3 = band.voxelSize * band.voxelSize * band.voxelSize;
    fluxDouble_.resize(3 * band.size());
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        const Vec3d f = h3 * (tensor(band, i) * forwardDifference(band, u, i, acc, bc_));
        for (int c = 0; c < 3; ++c) fluxDouble_[3 * i + std::size_t(c)] = f[c];
    });
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        out[i] = transposeDifference(
            band, i, acc, [&](std::size_t j, int c) { return fluxDouble_[3 * j + std::size_t(c)]; }, bc_);
    });
}

void NaiveLaplacianOperator::diagonal(float* out) const {
    // K_ii = h³/h² (Σ_cd T_i,cd + Σ_c T_{i−e_c},cc): G's column i holds −1/h in the three rows of voxel i (with
    // Neumann boundaries, only in rows c whose neighbour i + e_c is in the band) and +1/h in row c of voxel i − e_c.
    const Band& band = band_;
    forEachVoxel(band, [&](std::size_t i, auto& acc) {
        const Mat3d T = tensor(band, i);
        Vec3d own = Vec3d::Ones();
        if (bc_ == Boundary::Neumann)
            for (int c = 0; c < 3; ++c) own[c] = acc.getValue(band.coord[i] + kAxis[c]) >= 0 ? 1.0 : 0.0;
        double s = own.dot(T * own);
        for (int c = 0; c < 3; ++c) {
            const int j = acc.getValue(band.coord[i] - kAxis[c]);
            if (j >= 0) s += double(band.T[std::size_t(j)][std::size_t(c)]);
        }
        out[i] = float(band.voxelSize * s);
    });
}

}  // namespace gpisvdb
