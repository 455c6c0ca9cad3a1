#pragma once
// The density of a sum of up to three centred uniform variables and a centred Gaussian (docs/math.md#voxel-kac-rice):
// the profile of a cube's cross-sections (a box spline) blurred by the value's noise. It is what turns the plane
// φ₀ + g·y = u inside a voxel into the voxel's share of the expected surface.
#include <cstddef>

namespace gpisvdb {

/// Density at x of U_a + U_b + U_c + N(0, s²), U_w uniform on [−w/2, w/2] (widths ≥ 0, s ≥ 0; all in the units of
/// x). A width below 1e-4 of the sum's standard deviation counts as 0 (its effect on the density is below 1e-8
/// relative, and keeping it would cost more than that to cancellation). Returns 0 for x beyond the support's 8 s; a
/// degenerate sum (every width 0 and s = 0) has no density and returns 0.
double boxGaussianDensity(double x, double a, double b, double c, double s);

/// boxGaussianDensity at n points x[i] with widths (a[i], b[i], c[i]) that share one s, erf and exp taken in SIMD
/// lanes (the values agree with boxGaussianDensity's to rounding): the voxel Kac–Rice's inner loop.
void boxGaussianDensities(std::size_t n, const double* x, const double* a, const double* b, const double* c, double s, double* out);

/// The same by a plain sum over a fine midpoint grid of the uniforms (n³ points): the reference the tests use.
double boxGaussianDensityReference(double x, double a, double b, double c, double s, int n = 200);

}  // namespace gpisvdb
