#!/usr/bin/env python3
"""The eigen solvers' band-voxel budget (docs/spectrum.md#budget): `gpisvdb spectrum -k K --max-voxels B` on one
sphere cloud of bench/sphere_clouds.py (sigma 0.01 in its 7th column) for each budget B, defaults otherwise; per run
the band voxels, h / w_mu, the wall clock, the peak RSS, the eigenvalues and their differences from the lowest
(on the unit sphere lambda - lambda_0 -> l(l+1)/r^2: 3 pairs near 2, then 5 near 6).

Usage: python3 bench/eigen_budget.py [--gpisvdb build/bin/gpisvdb] [--samples 10000] [-k 10]
                                     [--budgets 100000,200000,300000,400000,800000,1600000]
                                     [--out bench/results/eigen_budget.json]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gpisvdb", default="build/bin/gpisvdb")
    ap.add_argument("--samples", default="10000")
    ap.add_argument("-k", default="10")
    ap.add_argument("--budgets", default="100000,200000,300000,400000,800000,1600000")
    ap.add_argument("--out", default="bench/results/eigen_budget.json")
    args = ap.parse_args()
    path = f"bench/results/clouds/sphere_{args.samples}.xyz"
    if not os.path.exists(path):
        subprocess.run([sys.executable, "bench/sphere_clouds.py", "--sizes", args.samples], check=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        report, vdb = os.path.join(tmp, "report.json"), os.path.join(tmp, "out.vdb")
        for budget in args.budgets.split(","):
            cmd = [args.gpisvdb, "spectrum", path, "-k", args.k, "--max-voxels", budget, "-o", vdb, "--report", report,
                   "--quiet"]
            print("+", " ".join(cmd), flush=True)
            start = time.monotonic()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            seconds = time.monotonic() - start
            r = json.load(open(report))
            p, values = r["parameters"], r["spectrum"]["eigenvalues"]
            row = {"budget": float(budget), "band_voxels": r["band"]["voxels"], "voxel_size": p["voxel_size"],
                   "h_over_w_mu": p["voxel_size"] / p["mu_width"], "mass": r["band"]["mass"], "seconds": seconds,
                   "peak_rss_bytes": r["memory"]["peak_rss_bytes"], "timings_s": r.get("timings_s", {}),
                   "eigenvalues": values, "gaps": [v - values[0] for v in values[1:]]}
            rows.append(row)
            print(f"  {row['band_voxels']} voxels (h = {row['h_over_w_mu']:.2f} w_mu): {seconds:.1f} s, "
                  f"lambda_0 {values[0]:.3f}, gaps {', '.join(f'{g:.3f}' for g in row['gaps'])}", flush=True)
    json.dump({"machine": {"nproc": os.cpu_count()}, "date": time.strftime("%Y-%m-%d"),
               "command": "python3 bench/eigen_budget.py " + " ".join(sys.argv[1:]), "input": path, "runs": rows},
              open(args.out, "w"), indent=1)
    print(args.out)


if __name__ == "__main__":
    main()
