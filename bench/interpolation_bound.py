#!/usr/bin/env python3
"""What interpolating the model from a coarser lattice would cost in accuracy (issue 17's lever "γ, ∇γ and C
interpolated from a coarser lattice", docs/benchmarks.md#near-field-floor).

Across a plane, the regularised winding number's Gaussians have closed profiles in the signed distance d (units of
the smoothing s): γ = Φ(d), its normal derivative ∝ φ(d), the variance under normal position noise ∝ φ(d)². A plane
is the smoothest surface there is, so the error of interpolating these profiles is a lower bound on what a lattice
of spacing H would give on a real surface. For each H/s: the worst error, over offsets, of cubic interpolation
through the 4 nearest lattice values (what a value-only lattice allows: the model gives no derivatives of ∇γ or of
the covariance) and of cubic Hermite interpolation of γ from its values and derivatives, each over its profile's
peak. The bunny's default voxel sizes come from bench/results/band.json (the throughput rows); a lattice twice as
coarse (H = 2h) is the least that would save evaluations. Writes bench/results/interpolation_bound.json (or --out).
"""
import argparse, json, math, os

ap = argparse.ArgumentParser()
ap.add_argument("--band", default="bench/results/band.json")
ap.add_argument("--smoothing", type=float, default=0.15308297930399983,
                help="s in world units: the bunny's, as `gpisvdb band data/bunny.obj --report` reports it")
ap.add_argument("--out", default="bench/results/interpolation_bound.json")
args = ap.parse_args()

SQRT2PI = math.sqrt(2 * math.pi)
PROFILES = {  # name: (f, f', peak of |f|)
    "gamma": (lambda x: 0.5 * (1 + math.erf(x / math.sqrt(2))), lambda x: math.exp(-x * x / 2) / SQRT2PI, 1.0),
    "gradient": (lambda x: math.exp(-x * x / 2) / SQRT2PI, lambda x: -x * math.exp(-x * x / 2) / SQRT2PI, 1 / SQRT2PI),
    "variance": (lambda x: math.exp(-x * x) / (2 * math.pi), lambda x: -2 * x * math.exp(-x * x) / (2 * math.pi),
                 1 / (2 * math.pi)),
}


def worst_error(f, df, peak, H, hermite):
    """max |interpolant − f| / peak over d in [−6, 6], every offset of the lattice against the plane."""
    worst = 0.0
    for shift in range(8):
        x0 = -6 + H * shift / 8
        k = 0
        while x0 + (k + 2) * H <= 6:
            a, b = x0 + k * H, x0 + (k + 1) * H
            for j in range(1, 20):
                t = j / 20
                x = a + t * H
                if hermite:  # values and derivatives at the two ends
                    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
                    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
                    p = h00 * f(a) + h10 * H * df(a) + h01 * f(b) + h11 * H * df(b)
                else:  # Lagrange through a − H, a, b, b + H
                    nodes = [a - H, a, b, b + H]
                    p = 0.0
                    for i, xi in enumerate(nodes):
                        li = 1.0
                        for m, xm in enumerate(nodes):
                            if m != i:
                                li *= (x - xm) / (xi - xm)
                        p += f(xi) * li
                worst = max(worst, abs(p - f(x)) / peak)
            k += 1
    return worst


rows = []
for H in (0.2, 0.3, 0.4, 0.6, 0.8, 1.2, 1.6):
    row = {"H_over_s": H}
    for name, (f, df, peak) in PROFILES.items():
        row["cubic_" + name] = worst_error(f, df, peak, H, hermite=False)
    row["hermite_gamma"] = worst_error(*PROFILES["gamma"], H, hermite=True)
    rows.append(row)

defaults = []
try:
    with open(args.band) as fh:
        for r in json.load(fh).get("throughput", []):
            H = 2 * r["h"] / args.smoothing
            defaults.append({"sigma_rel": r["sigma_rel"], "h": r["h"], "coarse_H_over_s": H,
                             "cubic_gradient": worst_error(*PROFILES["gradient"], H, hermite=False),
                             "cubic_variance": worst_error(*PROFILES["variance"], H, hermite=False)})
except (OSError, ValueError, KeyError) as e:
    print("interpolation_bound.py: no default voxel sizes (%s)" % e)

for r in rows:
    print("H/s %.1f: cubic γ %.1e, ∇γ %.1e, variance %.1e; Hermite γ %.1e" % (
        r["H_over_s"], r["cubic_gamma"], r["cubic_gradient"], r["cubic_variance"], r["hermite_gamma"]))
for r in defaults:
    print("bunny σ_rel %g: h %.4f, H = 2h = %.2f s: cubic ∇γ %.1e, variance %.1e" % (
        r["sigma_rel"], r["h"], r["coarse_H_over_s"], r["cubic_gradient"], r["cubic_variance"]))
out = {"command": "python3 bench/interpolation_bound.py --out " + args.out, "smoothing": args.smoothing,
       "profiles": rows, "bunny_default_2h": defaults}
with open(args.out + ".tmp", "w") as fh:
    json.dump(out, fh, indent=2)
    fh.write("\n")
os.replace(args.out + ".tmp", args.out)
