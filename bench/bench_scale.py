#!/usr/bin/env python3
"""Large runs on one machine (issue 18): the bunny's band at σ_rel 1 on a ladder of voxel sizes (≈ 1 M, 13 M and
110 M band voxels), each through `gpisvdb geodesic` (band, .vdb, fast marching, a shortest path) and, up to
--green-max-voxels, `gpisvdb green` (band, .vdb, the Green's function with the default preconditioner: hypre's
multigrid when scale.json was last written, the aggregation multigrid since). Records each
command's stage times, peak resident set, memory estimates and file size in bench/results/scale.json and draws
docs/images/bench_scale.png.

Usage: bench/bench_scale.py [--voxel-sizes 0.05,0.0235,0.0115] [--green-max-voxels 2e7] [--max-memory 21G]
           [--binary build/bin/gpisvdb] [--out bench/results/scale.json] [--work DIR] [--plot-only]
The 110 M-voxel step needs ≈ 19.5 GB of memory, ≈ 5 GB of disk and ≈ 11 minutes on 2 cores; a Green's function at
that size (--green-max-voxels 2e8) another ≈ 12 minutes and ≈ 18.5 GB (bench/results/scale_green_1e8.json).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

INPUT = "data/bunny.obj"
SOURCE = "0.5,6,1"
TARGET = "1.301895,0.122622,2.550061"  # a vertex of the bunny, across the body from the source


def run(cmd):
    print("+ " + " ".join(cmd), flush=True)
    start = time.monotonic()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.monotonic() - start


def record(report_path, vdb_path, wall):
    with open(report_path) as f:
        r = json.load(f)
    band, mem = r["band"], r["memory"]
    out = {"voxels": band["voxels"], "evaluated_voxels": band["evaluated_voxels"],
           "estimated_voxels": band["estimated_voxels"], "band_stage_seconds": band["stage_seconds"],
           "timings_s": r["timings_s"], "wall_s": wall, "peak_rss_bytes": mem["peak_rss_bytes"],
           "band_estimated_peak_bytes": mem["estimated_peak_bytes"], "band_bytes_per_voxel": mem["band_bytes_per_voxel"],
           "stages": mem.get("stages", {}), "vdb_bytes": os.path.getsize(vdb_path)}
    if "solver" in r:
        out["solver"] = {k: r["solver"].get(k) for k in ("preconditioner", "iterations", "relative_residual", "multigrid")}
    if "geodesic" in r:
        g = r["geodesic"]
        out["geodesic"] = {"reached": g["reached"], "unreached": g["unreached"],
                           "paths": [{k: p[k] for k in ("distance", "length", "points", "reached_source")} for p in g["paths"]]}
    return out


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax_t, ax_m) = plt.subplots(1, 2, figsize=(11, 4.2))
    geo = [s for s in data["steps"] if "geodesic" in s]
    green = [s for s in data["steps"] if "green" in s]
    n = [s["geodesic"]["voxels"] for s in geo]
    ax_t.plot(n, [s["geodesic"]["timings_s"]["band"] for s in geo], "o-", label="band (BFS, model, Kac–Rice)")
    ax_t.plot(n, [s["geodesic"]["timings_s"]["solve"] for s in geo], "s-", label="geodesic (fast marching, path)")
    if green:
        ax_t.plot([s["green"]["voxels"] for s in green], [s["green"]["timings_s"]["solve"] for s in green], "^-",
                  label="Green's function (multigrid PCG)")
    ax_t.set_xscale("log"), ax_t.set_yscale("log")
    ax_t.set_xlabel("band voxels"), ax_t.set_ylabel("seconds (2 threads)")
    ax_t.legend(fontsize=8), ax_t.grid(True, which="both", alpha=0.3)
    ax_m.plot(n, [s["geodesic"]["peak_rss_bytes"] / 1e9 for s in geo], "s-", label="geodesic command, peak")
    if green:
        ax_m.plot([s["green"]["voxels"] for s in green], [s["green"]["peak_rss_bytes"] / 1e9 for s in green], "^-",
                  label="green command, peak")
    ax_m.plot(n, [s["geodesic"]["band_estimated_peak_bytes"] / 1e9 for s in geo], "o--", label="band stage, estimated")
    ax_m.axhline(20, color="grey", ls=":", label="20 GB")
    ax_m.set_xscale("log"), ax_m.set_yscale("log")
    ax_m.set_xlabel("band voxels"), ax_m.set_ylabel("GB resident")
    ax_m.legend(fontsize=8), ax_m.grid(True, which="both", alpha=0.3)
    fig.suptitle("Bunny, σ_rel 1, voxel sizes " + ", ".join(str(s["voxel_size"]) for s in data["steps"]) +
                 " (bench/bench_scale.py)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--voxel-sizes", default="0.05,0.0235,0.0115")
    ap.add_argument("--green-max-voxels", type=float, default=2e7)
    ap.add_argument("--max-memory", default="21G")
    ap.add_argument("--binary", default="build/bin/gpisvdb")
    ap.add_argument("--out", default="bench/results/scale.json")
    ap.add_argument("--plot", default="docs/images/bench_scale.png")
    ap.add_argument("--work", default="")
    ap.add_argument("--plot-only", action="store_true")
    a = ap.parse_args()
    if a.plot_only:
        with open(a.out) as f:
            plot(json.load(f), a.plot)
        return
    if not os.access(a.binary, os.X_OK):
        sys.exit(f"bench_scale: {a.binary} is not an executable (tools/build first)")
    work = a.work or tempfile.mkdtemp(prefix="gpisvdb_scale_")
    data = {"command": " ".join(sys.argv), "input": INPUT, "sigma_rel": 1.0, "steps": []}
    for h in [float(x) for x in a.voxel_sizes.split(",")]:
        step = {"voxel_size": h}
        common = [INPUT, "--sigma", "1", "--voxel-size", str(h), "--source", SOURCE, "--quiet", "--max-memory", a.max_memory]
        vdb, rep = os.path.join(work, "geodesic.vdb"), os.path.join(work, "geodesic.json")
        wall = run([a.binary, "geodesic"] + common + ["--target", TARGET, "--paths", os.path.join(work, "path.json"),
                                                      "-o", vdb, "--report", rep])
        step["geodesic"] = record(rep, vdb, wall)
        os.remove(vdb)
        if step["geodesic"]["voxels"] <= a.green_max_voxels:
            vdb, rep = os.path.join(work, "green.vdb"), os.path.join(work, "green.json")
            wall = run([a.binary, "green"] + common + ["-o", vdb, "--report", rep])
            step["green"] = record(rep, vdb, wall)
            os.remove(vdb)
        data["steps"].append(step)
        print(json.dumps({"voxel_size": h, "voxels": step["geodesic"]["voxels"],
                          "geodesic_total_s": step["geodesic"]["timings_s"]["total"],
                          "geodesic_peak_GB": step["geodesic"]["peak_rss_bytes"] / 1e9,
                          "green_solve_s": step.get("green", {}).get("timings_s", {}).get("solve")}), flush=True)
        tmp = a.out + ".tmp"
        with open(tmp, "w") as f:
            json.dump(data, f, indent=1)
        os.replace(tmp, a.out)
    plot(data, a.plot)


if __name__ == "__main__":
    main()
