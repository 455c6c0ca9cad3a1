#!/usr/bin/env python3
"""Band construction of two gpisvdb builds, run side by side: median seconds per stage and their ratio.

The machines are shared and noisy, so the two binaries alternate run by run (baseline, candidate, baseline, ...)
and each figure is a median over --repeat runs. Both binaries build the bunny's band at its default voxel size
(or --voxel-size), so the voxel sets must agree; the band's mass of each is recorded to show it.

Usage: bench/compare_band.py --baseline OLD/gpisvdb --candidate build/bin/gpisvdb [--label-baseline TEXT]
           [--label-candidate TEXT] [--sigmas 0.25,0.5,1] [--threads 1,2] [--repeat 3] [--input data/bunny.obj]
           [--out bench/results/band_compare.json]
The baseline is typically a worktree of the previous commit:
  git worktree add /tmp/base HEAD~1 && cmake -S /tmp/base -B /tmp/base/build -DCMAKE_BUILD_TYPE=Release &&
  cmake --build /tmp/base/build --target gpisvdb
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile


def run_band(binary, input_path, sigma, threads, voxel_size, workdir):
    report = os.path.join(workdir, "report.json")
    cmd = [binary, "band", input_path, "-o", os.path.join(workdir, "band.vdb"), "--sigma", str(sigma),
           "--threads", str(threads), "--quiet", "--report", report]
    if voxel_size:
        cmd += ["--voxel-size", str(voxel_size)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    with open(report) as f:
        r = json.load(f)
    band = r["band"]
    stages = band["stage_seconds"]
    return {"band_seconds": r["timings_s"]["band"], "model": stages["model"], "kac_rice": stages["kac_rice"],
            "search": stages["search"], "finish": stages["finish"], "voxels": band["voxels"],
            "evaluated": band["evaluated_voxels"], "mass": band["mass"], "voxel_size": band["voxel_size"],
            "peak_rss_bytes": r["memory"]["peak_rss_bytes"]}


def median_of(runs, key):
    return statistics.median(run[key] for run in runs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True)
    ap.add_argument("--candidate", required=True)
    ap.add_argument("--label-baseline", default="baseline")
    ap.add_argument("--label-candidate", default="candidate")
    ap.add_argument("--sigmas", default="0.25,0.5,1")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--voxel-size", type=float, default=0.0)
    ap.add_argument("--input", default="data/bunny.obj")
    ap.add_argument("--out", default="bench/results/band_compare.json")
    a = ap.parse_args()
    for b in (a.baseline, a.candidate):
        if not os.access(b, os.X_OK):
            sys.exit(f"compare_band: {b} is not an executable")
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for sigma in [float(s) for s in a.sigmas.split(",")]:
            for threads in [int(t) for t in a.threads.split(",")]:
                runs = {"baseline": [], "candidate": []}
                for _ in range(a.repeat):
                    for which, binary in (("baseline", a.baseline), ("candidate", a.candidate)):
                        runs[which].append(run_band(binary, a.input, sigma, threads, a.voxel_size, work))
                row = {"sigma_rel": sigma, "threads": threads, "repeat": a.repeat}
                for which in ("baseline", "candidate"):
                    rr = runs[which]
                    row[which] = {k: median_of(rr, k) for k in ("band_seconds", "model", "kac_rice", "search", "finish",
                                                                  "peak_rss_bytes")}
                    row[which].update({k: rr[0][k] for k in ("voxels", "evaluated", "mass", "voxel_size")})
                    row[which]["voxels_per_s"] = row[which]["voxels"] / row[which]["band_seconds"]
                row["speedup_band"] = row["baseline"]["band_seconds"] / row["candidate"]["band_seconds"]
                row["speedup_model"] = row["baseline"]["model"] / row["candidate"]["model"]
                row["mass_relative_difference"] = abs(row["candidate"]["mass"] / row["baseline"]["mass"] - 1)
                print(f"sigma_rel {sigma} threads {threads}: band {row['baseline']['band_seconds']:.2f} s -> "
                      f"{row['candidate']['band_seconds']:.2f} s (x{row['speedup_band']:.2f}), model x{row['speedup_model']:.2f}, "
                      f"{row['candidate']['voxels_per_s']:.0f} voxels/s, mass diff {row['mass_relative_difference']:.1e}",
                      flush=True)
                rows.append(row)
    out = {"command": " ".join(sys.argv), "baseline": a.label_baseline, "candidate": a.label_candidate,
           "input": a.input, "rows": rows}
    tmp = a.out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(out, f, indent=1)
    os.replace(tmp, a.out)


if __name__ == "__main__":
    main()
