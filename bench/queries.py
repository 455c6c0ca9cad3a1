#!/usr/bin/env python3
"""Query throughput (docs/benchmarks.md#queries): `gpisvdb query data/bunny.obj` with 2000 rays (from a sphere of
radius 12 around the bunny toward points near its centre, length 16), 100 000 points, and a mesh (an icosphere of
radius 0.3, 320 triangles, 0.14 above the mean surface of the bunny's back) with 1000 draws; medians of the runs' query stage (the run's
wall time less the same command on one ray, point or triangle far away). Writes bench/results/queries.json."""
import argparse, json, os, statistics, subprocess, tempfile, time

import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--out", default="bench/results/queries.json")
ap.add_argument("--exe", default="build/bin/gpisvdb")
ap.add_argument("--input", default="data/bunny.obj")
ap.add_argument("--sigma", default="1")
ap.add_argument("--repeat", type=int, default=3)
args = ap.parse_args()

rng = np.random.default_rng(1)
centre = np.array([0.0, 4.5, 0.0])


def unit(n):
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


def icosphere_obj(path, radius, offset):
    """A subdivided icosahedron (2 levels, 320 triangles) as an OBJ."""
    t = (1 + 5 ** 0.5) / 2
    V = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    F = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
         (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(2):
        mid, nf = {}, []
        for a, b, c in F:
            ids = []
            for i, j in ((a, b), (b, c), (c, a)):
                key = (min(i, j), max(i, j))
                if key not in mid:
                    m = V[i] + V[j]
                    V.append(m / np.linalg.norm(m))
                    mid[key] = len(V) - 1
                ids.append(mid[key])
            ab, bc, ca = ids
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        F = nf
    with open(path, "w") as f:
        for v in V:
            f.write("v %.9g %.9g %.9g\n" % tuple(offset + radius * v))
        for a, b, c in F:
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))
    return len(F)


with tempfile.TemporaryDirectory() as tmp:
    rays = os.path.join(tmp, "rays.csv")
    origins = centre + 12 * unit(2000)
    targets = centre + 2 * unit(2000)
    np.savetxt(rays, np.c_[origins, targets - origins, np.full(2000, 16.0)], delimiter=",")
    one_ray = os.path.join(tmp, "one_ray.csv")
    np.savetxt(one_ray, [[0, 40, 0, 0, 1, 0, 1]], delimiter=",")
    points = os.path.join(tmp, "points.xyz")
    np.savetxt(points, centre + rng.uniform(-6, 6, (100000, 3)))
    one_point = os.path.join(tmp, "one_point.xyz")
    np.savetxt(one_point, [[0, 40, 0]])
    mesh = os.path.join(tmp, "mesh.obj")
    triangles = icosphere_obj(mesh, 0.3, np.array([0.5, 6.45, 0.0]))  # 0.14 above the back: an uncertain contact
    one_triangle = os.path.join(tmp, "far.obj")
    with open(one_triangle, "w") as f:
        f.write("v 0 40 0\nv 0.1 40 0\nv 0 40.1 0\nf 1 2 3\n")
    cases = {"rays": (["--rays", rays], ["--rays", one_ray], 2000), "points": (["--points", points], ["--points", one_point], 100000),
             "mesh": (["--mesh", mesh], ["--mesh", one_triangle], triangles)}
    runs = {k: [] for k in cases}
    reports = {}
    for _ in range(args.repeat):
        for name, (full, empty, _) in cases.items():  # side by side: the machine's load touches both alike
            walls = []
            for flags in (full, empty):
                report = os.path.join(tmp, name + ".json")
                t0 = time.monotonic()
                subprocess.run([args.exe, "query", args.input, "--sigma", args.sigma, *flags, "-o", os.path.join(tmp, "out.csv"),
                                "--report", report, "--quiet"], check=True)
                walls.append(time.monotonic() - t0)
                if flags is full:
                    reports[name] = json.load(open(report))
            runs[name].append(walls[0] - walls[1])

out = {"command": "python3 bench/queries.py --repeat %d --out %s" % (args.repeat, args.out), "input": args.input,
       "sigma_rel": float(args.sigma), "queries": {}}
for name, (_, _, count) in cases.items():
    seconds = statistics.median(runs[name])
    out["queries"][name] = {"count": count, "seconds": {"median": seconds, "runs": runs[name]}, "per_second": count / seconds,
                            "report": reports[name]["query"]}
with open(args.out + ".tmp", "w") as f:
    json.dump(out, f, indent=2)
    f.write("\n")
os.replace(args.out + ".tmp", args.out)
q = out["queries"]
print("queries: %.0f rays/s, %.0f points/s, mesh of %d triangles (%d points, 1000 draws) in %.2f s: P(collision) %.3f +- %.3f" %
      (q["rays"]["per_second"], q["points"]["per_second"], q["mesh"]["count"], q["mesh"]["report"]["points"],
       q["mesh"]["seconds"]["median"], q["mesh"]["report"]["p_collision"], q["mesh"]["report"]["standard_error"]))
