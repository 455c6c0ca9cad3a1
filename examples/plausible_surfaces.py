#!/usr/bin/env python3
"""Plausible surfaces of the bunny at three noise levels (docs/uncertainty.md#plausible-surfaces).

For each sigma (relative to the mean edge length l) the bunny's GPIS gives its band, its mean surface gamma = 1/2 and
n draws of the surface (band.surfaces, as `gpisvdb surfaces`). Prints each draw's area against the expected area
sum mu h^3, and, when matplotlib is installed (Debian: python3-matplotlib), draws OUT/plausible_surfaces.png: per
sigma, the section of the mean surface (black) and of every draw (colours) by the plane z = 0.

    PYTHONPATH=build/python python3 examples/plausible_surfaces.py [OUT] [--draws N]
"""
import argparse
import pathlib

import numpy as np

import gpisvdb

ROOT = pathlib.Path(__file__).resolve().parents[1]
parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("out", nargs="?", default="surfaces-output")
parser.add_argument("--draws", type=int, default=8)
args = parser.parse_args()
out = pathlib.Path(args.out)
out.mkdir(parents=True, exist_ok=True)
SIGMAS, SLICE_Z = (0.5, 1.0, 2.0), 0.0


def section(V, F, z):
    """The segments where the plane at height z cuts the triangles: (m, 2, 2) x, y end points."""
    d = V[F, 2] - z  # (t, 3) signed heights of each triangle's corners
    segments = []
    for tri, h in zip(F, d):
        ends = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            if (h[a] < 0) != (h[b] < 0):
                t = h[a] / (h[a] - h[b])
                ends.append(V[tri[a], :2] + t * (V[tri[b], :2] - V[tri[a], :2]))
        if len(ends) == 2:
            segments.append(ends)
    return np.array(segments).reshape(-1, 2, 2)


def area(V, F):
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()


results = []
for sigma in SIGMAS:
    model = gpisvdb.Model.from_file(str(ROOT / "data" / "bunny.obj"), sigma=sigma)
    band = gpisvdb.band(model)
    mean = band.mean_surface()
    draws = band.surfaces(args.draws, seed=1)
    areas = [area(V, F) for V, F in draws]
    print("sigma %.1f l: %d voxels, expected area %.2f, mean surface %.2f, draws %.2f +- %.2f (%d draws)"
          % (sigma, len(band), band.mass, area(mean[0], mean[1]), np.mean(areas), np.std(areas, ddof=1), len(draws)))
    results.append((sigma, section(mean[0], mean[1], SLICE_Z), [section(V, F, SLICE_Z) for V, F in draws]))

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
except ImportError:
    print("matplotlib is not installed: no picture")
else:
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 4.4))
    colours = plt.get_cmap("tab10")
    for ax, (sigma, mean_section, draw_sections) in zip(axes, results):
        for k, s in enumerate(draw_sections):
            ax.add_collection(LineCollection(s, colors=[colours(k % 10)], linewidths=0.8, alpha=0.8))
        ax.add_collection(LineCollection(mean_section, colors="black", linewidths=1.6))
        ax.autoscale()
        ax.set_aspect("equal")
        ax.set_title("sigma = %g l: mean (black), %d draws" % (sigma, len(draw_sections)))
        ax.set_xlabel("x")
        ax.set_ylabel("y")
    fig.suptitle("Plausible surfaces of the bunny, section z = %g" % SLICE_Z)
    fig.tight_layout()
    fig.savefig(out / "plausible_surfaces.png", dpi=110)
    print("wrote", out / "plausible_surfaces.png")
