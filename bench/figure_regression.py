#!/usr/bin/python3
"""The regression figure of docs/spectrum.md (paper Fig. 9 in miniature): a unit sphere whose cap above z = 0.6 is
missing, exact data on the equator, and a slice y = 0 of mu, the posterior mean and the posterior variance, all
from `gpisvdb regress` and read back from its .vdb with pyopenvdb.

Usage: bench/figure_regression.py [--exe build/bin/gpisvdb] [--out docs/images/regression_sphere.png]
(needs Debian's python3-matplotlib and python3-openvdb; runs in about 30 s)
"""
import argparse
import math
import os
import subprocess
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyopenvdb as vdb  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--exe", default="build/bin/gpisvdb")
parser.add_argument("--out", default="docs/images/regression_sphere.png")
args = parser.parse_args()

work = tempfile.mkdtemp(prefix="gpisvdb_figure_")
# === A latitude-longitude unit sphere with its poles on the y axis (off the slice y = 0), without the triangles
# whose centre lies above z = 0.6, as an OBJ soup
rings, segments = 40, 80
vertices = []
for i in range(rings + 1):
    theta = math.pi * i / rings
    for j in range(segments):
        phi = 2 * math.pi * j / segments
        vertices.append((math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi)))
faces = []
for i in range(rings):
    for j in range(segments):
        a, b = i * segments + j, i * segments + (j + 1) % segments
        c, d = a + segments, b + segments
        faces += ([(a, b, c)] if i > 0 else []) + ([(b, d, c)] if i < rings - 1 else [])
obj = os.path.join(work, "cut_sphere.obj")
with open(obj, "w") as f:
    for v in vertices:
        f.write("v %.9f %.9f %.9f\n" % v)
    for face in faces:
        if sum(vertices[k][2] for k in face) / 3 <= 0.6:
            f.write("f %d %d %d\n" % tuple(k + 1 for k in face))
# === Exact data on the equator: value x + y / 2
csv = os.path.join(work, "equator.csv")
with open(csv, "w") as f:
    f.write("x,y,z,value\n")
    for j in range(12):
        phi = 2 * math.pi * j / 12
        f.write("%.9f,%.9f,0,%.9f\n" % (math.cos(phi), math.sin(phi), math.cos(phi) + 0.5 * math.sin(phi)))
out = os.path.join(work, "regression.vdb")
subprocess.run([args.exe, "regress", obj, "--data", csv, "-k", "80", "--sigma", "1", "--voxel-size", "0.04", "-o", out,
                "--quiet"], check=True)

# === The slice y = 0 of three grids, as images (white: outside the band)
fig, axes = plt.subplots(1, 3, figsize=(13, 4.4), dpi=110)
for ax, name, title, cmap, log in zip(axes, ["mu", "regression_mean", "regression_variance"],
                                      ["density $\\mu$", "posterior mean", "posterior variance (log)"],
                                      ["viridis", "coolwarm", "magma"], [True, False, True]):
    grid = vdb.read(out, name)
    h = grid.transform.voxelSize()[0]
    cells = {}
    for item in grid.citerOnValues():
        x, y, z = item.min
        if item.count == 1 and y == 0:
            cells[x, z] = item.value
    x0, x1 = min(k[0] for k in cells), max(k[0] for k in cells)
    z0, z1 = min(k[1] for k in cells), max(k[1] for k in cells)
    image = np.full((z1 - z0 + 1, x1 - x0 + 1), np.nan)
    for (x, z), v in cells.items():
        image[z - z0, x - x0] = v
    norm = matplotlib.colors.LogNorm(vmin=max(np.nanmin(image), np.nanmax(image) * 1e-4), vmax=np.nanmax(image)) if log else None
    im = ax.imshow(image, origin="lower", extent=((x0 - 0.5) * h, (x1 + 0.5) * h, (z0 - 0.5) * h, (z1 + 0.5) * h),
                   cmap=cmap, norm=norm, interpolation="nearest")
    ax.set_title(title)
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    fig.colorbar(im, ax=ax, shrink=0.8)
for ax in axes[1:]:
    ax.scatter([1, -1], [0, 0], c="k", s=25, marker="x", label="data (on the equator)")
axes[1].legend(loc="lower center", fontsize=8)
fig.suptitle("Unit sphere, cap above z = 0.6 missing, exact data on the equator (slice y = 0; gpisvdb regress, k = 80, nu = 3/2)")
fig.tight_layout()
os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
fig.savefig(args.out)
print("wrote", args.out)
