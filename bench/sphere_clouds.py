#!/usr/bin/env python3
"""Unit-sphere clouds for the scan benchmarks (docs/benchmarks.md#coarse-voxels): N random points (fixed seed),
radial normals, and a per-point position std in the 7th column (a scan's own noise, world units).

Usage: python3 bench/sphere_clouds.py [--sizes 10000,100000,1000000] [--sigma 0.01] [--out DIR]
Writes DIR/sphere_N.xyz for each N (default DIR: bench/results/clouds, not tracked).
"""
import argparse
import os

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--sigma", type=float, default=0.01)
    ap.add_argument("--out", default="bench/results/clouds")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(1)
    for n in (int(s) for s in args.sizes.split(",")):
        p = rng.normal(size=(n, 3))
        p /= np.linalg.norm(p, axis=1)[:, None]
        rows = np.hstack([p, p, np.full((n, 1), args.sigma)])
        path = os.path.join(args.out, f"sphere_{n}.xyz")
        np.savetxt(path, rows, fmt="%.7g")
        print(path)


if __name__ == "__main__":
    main()
