#!/usr/bin/env python3
"""Makes the reference-agreement test's data (tests/data/, read by tests/test_reference.cpp): a small .gdp
of our own and what the paper's implementation (GPGP) computes on it, so that CI checks the agreement without GPGP.

  1. A unit-cube-sized icosphere (level 2, 320 triangles, radius 0.7: GPGP's Barnes–Hut root is [−1, 1]³), written
     as OBJ and turned into Gaussian dipoles by `gpisvdb convert --sigma 0.5` (the soup's App. B noise).
  2. GPGP's driver (bench/reference/gpgp_driver.cpp, built by bench/reference.py) on that .gdp with its defaults
     except β = 100 (its Barnes–Hut then sums nearly every dipole exactly: the test compares the models, not the two
     trees' approximations), dumping every band voxel: position, μ, T, its field's mean.
  3. Every `--stride`-th voxel of the dump, in the dump's order, and GPGP's parameters (s = reg·lfs, h, β, QMC points).

Usage: python3 bench/reference_testdata.py [--driver build/reference/driver/gpgp_driver] [--exe build/bin/gpisvdb]
"""
import argparse, json, math, os, subprocess, tempfile

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--driver", default="build/reference/driver/gpgp_driver", help="GPGP's driver, built by bench/reference.py")
ap.add_argument("--exe", default="build/bin/gpisvdb")
ap.add_argument("--stride", type=int, default=40, help="keep every N-th voxel of the reference's band")
ap.add_argument("--out", default="tests/data")
args = ap.parse_args()


def icosphere(level, radius):
    t = (1 + math.sqrt(5)) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7),
         (9, 8, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    for _ in range(level):
        middle, faces = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                m = [(p + q) / 2 for p, q in zip(v[a], v[b])]
                n = math.sqrt(sum(x * x for x in m))
                v.append(tuple(x / n for x in m))
                middle[key] = len(v) - 1
            return middle[key]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = faces
    return [tuple(radius * x for x in p) for p in v], f


os.makedirs(args.out, exist_ok=True)
gdp = os.path.join(args.out, "icosphere_320.gdp")
with tempfile.TemporaryDirectory() as tmp:
    obj = os.path.join(tmp, "icosphere.obj")
    vertices, faces = icosphere(2, 0.7)
    with open(obj, "w") as f:
        f.writelines("v %r %r %r\n" % p for p in vertices)
        f.writelines("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in faces)
    convert = [args.exe, "convert", obj, "--sigma", "0.5", "-o", gdp]
    subprocess.run(convert, check=True)
    driver = [args.driver, "--input", gdp, "--beta", "100", "--no-green", "--no-fmm", "--no-eigen", "--dump",
              os.path.join(tmp, "gpgp")]
    out = subprocess.run(driver, check=True, capture_output=True, text=True).stdout
    result = json.loads(out.split("RESULT ", 1)[1])
    rows = open(os.path.join(tmp, "gpgp_voxels.csv")).read().splitlines()
kept = [rows[0]] + rows[1::args.stride]
with open(os.path.join(args.out, "icosphere_320_gpgp_voxels.csv"), "w") as f:
    f.write("\n".join(kept) + "\n")
parameters = {"made_by": "python3 bench/reference_testdata.py --stride %d" % args.stride,
              "commands": [" ".join(["gpisvdb"] + convert[1:]).replace(obj, "icosphere.obj"),
                           " ".join(["gpgp_driver"] + driver[1:]).replace(os.path.join(tmp, "gpgp"), "gpgp")],
              "reference": "GPGP (github.com/baptiste-genest/GPGP, commit 57e58b7), headless through bench/reference/",
              "smoothing": result["smoothing"], "h": result["dx"], "beta": result["beta"], "qmc": result["qmc"],
              "iso": result["iso"], "voxels": result["voxels"], "kept": len(kept) - 1, "mass": result["mass"]}
json.dump(parameters, open(os.path.join(args.out, "icosphere_320_gpgp.json"), "w"), indent=1)
print("wrote", args.out, "(%d of %d voxels)" % (len(kept) - 1, result["voxels"]))
