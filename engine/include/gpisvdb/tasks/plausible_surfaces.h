#pragma once
// Plausible surfaces: draws of the winding-number GPIS (docs/uncertainty.md#plausible-surfaces).
//
// The model is linear in the input's noise ε = (δp_i, δw_i), δp_i ~ N(0, v_i I), δw_i ~ N(0, Σ'_i), independent
// across samples (docs/model.md). One draw of ε gives the field
//   φ_ε(x) = γ(x) + J ε = γ(x) + (1/4π) Σ_i [ ∇ρ(y_i)·δw_i − δp_iᵀ D²ρ(y_i) w_i ],   y_i = x − p_i,
// a Gaussian field whose mean is γ and whose variance is the model's c₀₀ (paper Eq. 7, first row). Its level set
// {φ_ε = u} is one plausible surface; the expected area of those surfaces is ∫ μ (Kac–Rice, paper Eq. 11).
//
// J ε is summed over a k-d tree of the samples (Barnes–Hut): a node of radius r about its centre c stands in for its
// samples beyond β r with the sums Σ δw_i and Σ δp_i w_iᵀ at c (their zeroth-order term). A node errs by a share
// r/d of its part; the parts fall off as the kernel's derivatives, so the total error shrinks like β⁻³ (measured,
// and tested against the direct sum).
#include <cstdint>
#include <memory>
#include <openvdb/openvdb.h>
#include <vector>

#include "gpisvdb/band/band.h"
#include "gpisvdb/core/progress.h"
#include "gpisvdb/input/samples.h"

namespace gpisvdb {

struct SurfaceDrawOptions {
    int count = 8;              ///< draws n (1 … 10 000)
    std::uint64_t seed = 1;     ///< draw k's noise is a function of (seed, k, sample index) alone
    int firstDraw = 0;          ///< index of the first draw: draws firstDraw … firstDraw + count − 1 (≥ 0)
    double openingRatio = 6.0;  ///< β (> 1): a node stands in for its samples beyond β × its radius (accuracy:
                                ///< docs/uncertainty.md#plausible-surfaces)
    int leafSize = 16;          ///< most samples in a leaf (≥ 1)
};

/// The perturbation J ε of each draw at any point, over a tree built once (the draws' noise is drawn then).
class SurfaceDraws {
public:
    /// `s`: the kernel's smoothing, world units (> 0), the winding model's own (LoadedModel::smoothing).
    /// Throws ParameterError on a bad option, Error on empty samples.
    SurfaceDraws(const Samples& samples, double s, const SurfaceDrawOptions& options = {});
    ~SurfaceDraws();
    SurfaceDraws(SurfaceDraws&&) noexcept;

    int count() const;
    /// J ε_k at x (world units) for each draw k, by the tree.
    std::vector<double> perturbation(const Vec3d& x) const;
    /// The same by the direct sum over every sample (the reference, O(n) per point).
    std::vector<double> perturbationExact(const Vec3d& x) const;
    /// γ + J ε_k at the band's voxel centres: values[k][i] for draw firstDraw + k and voxel i (the band's `mean`
    /// channel as γ). Parallel over voxels; the result does not depend on the thread count.
    std::vector<std::vector<float>> onBand(const Band& band, const Progress& progress = {}) const;
    /// The same at the listed voxels only (linear indices into the band): values[k][j] for voxel voxels[j], equal to
    /// the whole band's values there (a section's lines need a slice of the band, not all of it).
    std::vector<std::vector<float>> onBand(const Band& band, const std::vector<std::size_t>& voxels, const Progress& progress = {}) const;

    /// Bytes the draws hold beyond the samples: the noise (2 × 3 floats per sample and draw) and the tree's
    /// nodes (12 doubles per node and draw, at most 4 n / leafSize nodes), for n samples.
    static double bytes(std::size_t samples, const SurfaceDrawOptions& options);

private:
    template <class VoxelOf>
    std::vector<std::vector<float>> onVoxels(const Band& band, std::size_t count, VoxelOf voxelOf, const Progress& progress) const;
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// A draw's field over the band as a float grid (the band's transform and voxels), ready for meanSurface(grid, u).
openvdb::FloatGrid::Ptr drawGrid(const Band& band, const std::vector<float>& values);
/// The same over the listed voxels only (values[j] at voxel voxels[j], as onBand(band, voxels) gives them).
openvdb::FloatGrid::Ptr drawGrid(const Band& band, const std::vector<std::size_t>& voxels, const std::vector<float>& values);

}  // namespace gpisvdb
