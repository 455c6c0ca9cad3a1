#!/usr/bin/env python3
"""Every band command on scans at the default settings (issue 38 item 1; docs/benchmarks.md#scan-commands): band,
green, geodesic (one source, one target) and spectrum -k 10 on clouds of N points with their own sigma in the 7th
column, defaults otherwise; each command's wall clock, peak RSS, band voxels, voxel size and h / w_mu.
Shapes: `sphere`, the unit sphere with sigma 0.01 (bench/sphere_clouds.py; source and target at the poles), and
`elephant`, data/elephant.off sampled by area with sigma 0.005 (bench/mesh_clouds.py; source and target the cloud's
points of largest and smallest y).

Usage: python3 bench/scan_commands.py [--gpisvdb build/bin/gpisvdb] [--shape sphere|elephant] [--sizes 10000,100000]
       [--commands band,green,geodesic,spectrum] [--out bench/results/scan_commands.json]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

SHAPES = {
    "sphere": [sys.executable, "bench/sphere_clouds.py"],
    "elephant": [sys.executable, "bench/mesh_clouds.py", "--mesh", "data/elephant.off"],
}


def commands(path, shape):
    """The commands' own flags: the source and target on the shape."""
    if shape == "sphere":
        source, target = "0,0,1", "0,0,-1"
    else:
        import numpy as np
        points = np.loadtxt(path, usecols=(0, 1, 2))
        source, target = (",".join(f"{c:.7g}" for c in points[i]) for i in (points[:, 1].argmax(), points[:, 1].argmin()))
    return {"band": [], "green": ["--source", source], "geodesic": ["--source", source, "--target", target],
            "spectrum": ["-k", "10"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gpisvdb", default="build/bin/gpisvdb")
    ap.add_argument("--shape", default="sphere", choices=sorted(SHAPES))
    ap.add_argument("--sizes", default="10000,100000")
    ap.add_argument("--commands", default="band,green,geodesic,spectrum", help="which of the four to run")
    ap.add_argument("--out", default="bench/results/scan_commands.json")
    args = ap.parse_args()
    wanted = args.commands.split(",")
    unknown = sorted(set(wanted) - {"band", "green", "geodesic", "spectrum"})
    if unknown:
        ap.error(f"--commands: {','.join(unknown)} not in {{band,green,geodesic,spectrum}}")
    sizes = args.sizes.split(",")
    paths = [f"bench/results/clouds/{args.shape}_{n}.xyz" for n in sizes]
    missing = [n for n, p in zip(sizes, paths) if not os.path.exists(p)]
    if missing:
        subprocess.run(SHAPES[args.shape] + ["--sizes", ",".join(missing)], check=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        report, vdb = os.path.join(tmp, "report.json"), os.path.join(tmp, "out.vdb")
        for n, path in zip(sizes, paths):
            for name, flags in commands(path, args.shape).items():
                if name not in wanted:
                    continue
                cmd = [args.gpisvdb, name, path, "-o", vdb, "--report", report, "--quiet"] + flags
                print("+", " ".join(cmd), flush=True)
                start = time.monotonic()
                subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                seconds = time.monotonic() - start
                r = json.load(open(report))
                row = {"shape": args.shape, "samples": int(n), "command": name, "flags": flags, "seconds": seconds,
                       "length_scale": r["input"]["length_scale"], "mu_width": r["parameters"]["mu_width"],
                       "smoothing": r["parameters"]["smoothing"], "model_samples": r["input"].get("model_samples"),
                       "mass": r["band"]["mass"],
                       "peak_rss_bytes": r["memory"]["peak_rss_bytes"], "band_voxels": r["band"]["voxels"],
                       "voxel_size": r["parameters"]["voxel_size"], "timings_s": r.get("timings_s", {})}
                if name == "spectrum":
                    row["spectrum"] = r.get("spectrum")
                    row["voxel_values"] = r["parameters"].get("voxel_values")
                if name == "geodesic":
                    row["paths"] = r["geodesic"]["paths"]
                rows.append(row)
                print(f"  {name} on {n} points: {seconds:.1f} s, {row['peak_rss_bytes'] / 1e9:.2f} GB, "
                      f"{row['band_voxels']} voxels", flush=True)
    json.dump({"machine": {"nproc": os.cpu_count()}, "date": time.strftime("%Y-%m-%d"),
               "command": "python3 bench/scan_commands.py " + " ".join(sys.argv[1:]), "runs": rows},
              open(args.out, "w"), indent=1)
    print(args.out)


if __name__ == "__main__":
    main()
