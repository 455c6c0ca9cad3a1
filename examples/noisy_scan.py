#!/usr/bin/env python3
"""A noisy scan in, the surface density mu and a geodesic out (docs/python.md, "Walkthrough").

A scanner saw one side of a torus well and the other side less well: the points there are noisier and each carries its
own uncertainty. gpisvdb turns the points into a GPIS, builds its narrow band, and measures a geodesic across; the
path keeps to where the surface is certain. Writes OUT/scan.vdb (grids mu, ..., geodesic) and, when matplotlib is
installed (Debian: python3-matplotlib), OUT/scan.png.

    PYTHONPATH=build/python python3 examples/noisy_scan.py [OUT]
"""
import pathlib
import sys

import numpy as np

import gpisvdb

out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "scan-output")
out.mkdir(parents=True, exist_ok=True)

# === A scan of a torus (radii 1 and 0.4): 3000 points, uniform over its area, with normals; noise std 0.005 for
#     x < 0 and 0.02 for x > 0 (world units).
rng = np.random.default_rng(0)
R, r = 1.0, 0.4
u, v = rng.uniform(0, 2 * np.pi, (2, 12000))
keep = rng.uniform(0, R + r, 12000) < R + r * np.cos(v)  # area element (R + r cos v): rejection sampling
u, v = u[keep][:3000], v[keep][:3000]
normals = np.c_[np.cos(u) * np.cos(v), np.sin(u) * np.cos(v), np.sin(v)]
points = np.c_[(R + r * np.cos(v)) * np.cos(u), (R + r * np.cos(v)) * np.sin(u), r * np.sin(v)]
noise = np.where(points[:, 0] < 0, 0.005, 0.02)  # world units, one std per point
points += noise[:, None] * rng.standard_normal(points.shape)

# === The GPIS and its band: the uncertainty per point is the scan's; the kernel smoothing relative to the spacing.
model = gpisvdb.Model.from_cloud(points, normals, sigma=noise)
band = gpisvdb.band(model, voxel_size=0.04)
print(f"{model}\n{band}: expected area {band.mass:.3f} (a torus of these radii: {4 * np.pi ** 2 * R * r:.3f})")

# === mu: largest where the scan is precise (x < 0), spread thinner where it is noisy.
left, right = band.world[:, 0] < 0, band.world[:, 0] > 0
print(f"max mu: {band.mu[left].max():.1f} (precise side), {band.mu[right].max():.1f} (noisy side), per world unit")

# === A geodesic from one side of the torus to the other.
g = band.geodesic(sources=[-1.4, 0.0, 0.0], targets=[1.4, 0.0, 0.0])
(path,) = g["paths"]
print(f"geodesic: {len(path)} points, length {g['path_length'][0]:.3f} world units, U = {g['path_distance'][0]:.3f}")

distance = np.where(np.isfinite(g["distance"]), g["distance"], 0.0)
band.write_vdb(str(out / "scan.vdb"), channels={"geodesic": distance})
print(f"wrote {out / 'scan.vdb'}")

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit(0)
# A slab |z| < h through the band, coloured by mu, with the path on top.
slab = np.abs(band.world[:, 2]) < band.voxel_size
fig, ax = plt.subplots(figsize=(6, 5))
s = ax.scatter(band.world[slab, 0], band.world[slab, 1], c=band.mu[slab], s=4, cmap="viridis")
ax.plot(path[:, 0], path[:, 1], "r-", lw=2, label="geodesic")
ax.set_aspect("equal")
ax.set_title("mu (world units$^{-1}$) in the plane z = 0; noisy side x > 0")
fig.colorbar(s)
ax.legend()
fig.savefig(out / "scan.png", dpi=120)
print(f"wrote {out / 'scan.png'}")
