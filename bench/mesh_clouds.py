#!/usr/bin/env python3
"""Scan-like clouds of a mesh of data/ (docs/benchmarks.md#scan-commands): N points drawn uniformly by area on its
triangles (fixed seed), each with its triangle's outward normal and a position std in the 7th column (a scan's own
noise, world units) — what a denser scan of the same object gives.

Usage: python3 bench/mesh_clouds.py [--mesh data/elephant.off] [--sizes 10000,100000,1000000] [--sigma 0.005] [--out DIR]
Writes DIR/NAME_N.xyz for each N, NAME the mesh's file name without extension (default DIR: bench/results/clouds,
not tracked).
"""
import argparse
import os

import numpy as np


def read_off(path):
    tokens = open(path).read().split()
    if tokens[0] != "OFF":
        raise SystemExit(f"{path}: not an OFF file")
    nv, nf = int(tokens[1]), int(tokens[2])
    v = np.array(tokens[4:4 + 3 * nv], float).reshape(nv, 3)
    rows = np.array(tokens[4 + 3 * nv:], int).reshape(nf, -1)
    if np.any(rows[:, 0] != 3):
        raise SystemExit(f"{path}: only triangles are drawn from")
    return v, rows[:, 1:4]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="data/elephant.off")
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--sigma", type=float, default=0.005)
    ap.add_argument("--out", default="bench/results/clouds")
    args = ap.parse_args()
    v, f = read_off(args.mesh)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = np.cross(b - a, c - a)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    keep = area > 0
    a, b, c, cross, area = a[keep], b[keep], c[keep], cross[keep], area[keep]
    normal = cross / np.linalg.norm(cross, axis=1)[:, None]
    name = os.path.splitext(os.path.basename(args.mesh))[0]
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(1)
    for n in (int(s) for s in args.sizes.split(",")):
        t = rng.choice(len(area), size=n, p=area / area.sum())
        r1, r2 = rng.random(n), rng.random(n)
        flip = r1 + r2 > 1
        r1[flip], r2[flip] = 1 - r1[flip], 1 - r2[flip]
        p = a[t] + r1[:, None] * (b[t] - a[t]) + r2[:, None] * (c[t] - a[t])
        rows = np.hstack([p, normal[t], np.full((n, 1), args.sigma)])
        path = os.path.join(args.out, f"{name}_{n}.xyz")
        np.savetxt(path, rows, fmt="%.7g")
        print(path)


if __name__ == "__main__":
    main()
