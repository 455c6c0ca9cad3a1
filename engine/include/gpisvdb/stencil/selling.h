#pragma once
// Selling's decomposition (Fehrenbach–Mirebeau 2014; docs/math.md#selling): any symmetric positive (semi-)definite
// T = Σ_k λ_k e_k e_kᵀ with λ_k ≥ 0 and integer offsets e_k, from an obtuse superbase. In 3D: at most 6 terms;
// in 2D: at most 3.
#include <array>
#include <Eigen/Core>

#include "gpisvdb/core/types.h"

namespace gpisvdb {

struct SellingOptions {
    int maxFlips = 100000;      ///< cap on superbase flips (termination guard; reached only for degenerate T)
    double dropRelative = 1e3;  ///< weights below dropRelative·ε·tr T are dropped (ε: double precision)
};

struct Selling3 {
    int count = 0;                            ///< terms kept (≤ 6)
    std::array<double, 6> weight{};           ///< λ_k ≥ 0
    std::array<Eigen::Vector3i, 6> offset{};  ///< e_k ∈ Z³
    int flips = 0;                            ///< superbase flips performed
    bool capped = false;                      ///< true if maxFlips was reached (weights clamped at 0)
    /// Stencil width max_k ‖e_k‖₁ (0 for T = 0).
    int width() const;
    /// Σ λ_k e_k e_kᵀ.
    Mat3d reconstruct() const;
};

struct Selling2 {
    int count = 0;
    std::array<double, 3> weight{};
    std::array<Eigen::Vector2i, 3> offset{};
    int flips = 0;
    bool capped = false;
    int width() const;
    Eigen::Matrix2d reconstruct() const;
};

Selling3 selling(const Mat3d& T, const SellingOptions& options = {});
Selling2 selling(const Eigen::Matrix2d& T, const SellingOptions& options = {});

}  // namespace gpisvdb
