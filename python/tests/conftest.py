"""Shared inputs of the Python tests: a small noisy sphere (a triangle soup) as arrays and as a file, and the
command-line program to compare with. Bands are kept small (a few thousand voxels) so the set runs in seconds."""
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXE = os.environ.get("GPISVDB_EXE", str(ROOT / "build" / "bin" / "gpisvdb"))
DATA = pathlib.Path(os.environ.get("GPISVDB_DATA_DIR", str(ROOT / "data")))

# The parameters every comparison uses, as keywords and as the command line's flags.
SIGMA, SMOOTHING, VOXEL = 0.5, 0.4, 0.09
FLAGS = ["--sigma", str(SIGMA), "--smoothing", str(SMOOTHING), "--voxel-size", str(VOXEL), "--quiet"]


def icosphere(subdivisions=2, seed=1, noise=0.01):
    """A unit sphere from a subdivided octahedron, vertices jittered (a noisy scan): V (n, 3) float64, F (m, 3)."""
    V = [np.array(v, float) for v in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]]
    F = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    for _ in range(subdivisions):
        mid, nf = {}, []

        def middle(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                m = V[a] + V[b]
                V.append(m / np.linalg.norm(m))
                mid[key] = len(V) - 1
            return mid[key]

        for a, b, c in F:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = nf
    V = np.array(V)
    V += noise * np.random.default_rng(seed).standard_normal(V.shape)
    return V, np.array(F, dtype=np.int64)


def write_obj(path, V, F):
    with open(path, "w") as f:
        for v in V:
            f.write("v %.17g %.17g %.17g\n" % tuple(v))
        for t in F:
            f.write("f %d %d %d\n" % tuple(t + 1))


def run_cli(*args):
    """Runs the command line; fails the test with its stderr on a non-zero exit."""
    r = subprocess.run([EXE, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r


@pytest.fixture(scope="session")
def sphere():
    return icosphere()


@pytest.fixture(scope="session")
def sphere_obj(sphere, tmp_path_factory):
    path = tmp_path_factory.mktemp("input") / "sphere.obj"
    write_obj(path, *sphere)
    return path


@pytest.fixture(scope="session")
def model(sphere):
    import gpisvdb
    return gpisvdb.Model(*sphere, sigma=SIGMA, smoothing=SMOOTHING)


@pytest.fixture(scope="session")
def band(model):
    import gpisvdb
    return gpisvdb.band(model, voxel_size=VOXEL)


def read_grid(path, name):
    """A grid of a .vdb as a dense array and the index of its [0, 0, 0] (pyopenvdb, Debian's python3-openvdb)."""
    import pyopenvdb
    grid = pyopenvdb.read(str(path), name)
    lo, hi = grid.evalActiveVoxelBoundingBox()
    shape = tuple(h - l + 1 for l, h in zip(lo, hi))
    if grid.valueTypeName.startswith("vec3"):
        shape += (3,)
    dense = np.zeros(shape, dtype=np.float32)
    dense.fill(np.nan)
    grid.copyToArray(dense, ijk=lo)
    return dense, np.array(lo)


def at_coords(dense, lo, coords):
    """Values of a dense grid at the band's index coordinates."""
    k = coords - lo
    return dense[k[:, 0], k[:, 1], k[:, 2]]
