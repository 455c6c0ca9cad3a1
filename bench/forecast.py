#!/usr/bin/env python3
"""How well `gpisvdb info` forecasts the default band (docs/band.md#forecast): for each input, `info --report` and then
`band --report` with the same flags, side by side; the forecast's voxel size, band voxels, peak memory and time
against the band's own (time: the band command's wall clock, process start to exit).

Usage: python3 bench/forecast.py [--gpisvdb build/bin/gpisvdb] [--out bench/results/forecast.json] [--clouds 10000,100000]
The sphere clouds come from bench/sphere_clouds.py (generated into bench/results/clouds when missing).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

INPUTS = ["data/bunny.obj", "data/elephant.off", "data/elephant-with-holes.off", "data/kitten.xyz",
          "data/sphere_20k_normal.xyz"]


def run(cmd):
    print("+", " ".join(cmd), flush=True)
    start = time.monotonic()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.monotonic() - start


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gpisvdb", default="build/bin/gpisvdb")
    ap.add_argument("--out", default="bench/results/forecast.json")
    ap.add_argument("--clouds", default="10000,100000", help="sphere clouds (sigma 0.01) to add; empty: none")
    args = ap.parse_args()
    inputs = list(INPUTS)
    if args.clouds:
        sizes = args.clouds.split(",")
        paths = [f"bench/results/clouds/sphere_{n}.xyz" for n in sizes]
        missing = [n for n, p in zip(sizes, paths) if not os.path.exists(p)]
        if missing:
            subprocess.run([sys.executable, "bench/sphere_clouds.py", "--sizes", ",".join(missing)], check=True)
        inputs += paths
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        info_json, band_json, vdb = (os.path.join(tmp, n) for n in ("info.json", "band.json", "band.vdb"))
        for path in inputs:
            info_seconds = run([args.gpisvdb, "info", path, "--report", info_json])
            band_seconds = run([args.gpisvdb, "band", path, "-o", vdb, "--report", band_json, "--quiet"])
            f = json.load(open(info_json))["forecast"]
            b = json.load(open(band_json))
            row = {"input": path, "samples": b["input"]["samples"], "info_seconds": info_seconds,
                   "voxel_size": {"forecast": f["voxel_size"], "band": b["parameters"]["voxel_size"]},
                   "voxels": {"forecast": f["voxels"], "band": b["band"]["voxels"]},
                   "peak_bytes": {"forecast": f["peak_bytes"], "band": b["memory"]["peak_rss_bytes"]},
                   "seconds": {"forecast": f["seconds"], "band": band_seconds},
                   "mass": b["band"]["mass"], "smoothing": b["parameters"]["smoothing"],
                   "smoothing_set_by": b["parameters"]["smoothing_set_by"],
                   "seconds_parts": {"forecast": {k: f[k] for k in ("read_seconds", "model_seconds",
                                                                     "resolution_seconds", "band_seconds",
                                                                     "write_seconds")},
                                     "band": b["timings_s"]}}
            for k in ("voxels", "peak_bytes", "seconds"):
                row[k]["ratio"] = row[k]["forecast"] / row[k]["band"]
            rows.append(row)
            print(f"  {path}: voxels x{row['voxels']['ratio']:.2f}, peak x{row['peak_bytes']['ratio']:.2f}, "
                  f"time x{row['seconds']['ratio']:.2f} ({row['seconds']['forecast']:.1f} s forecast, "
                  f"{band_seconds:.1f} s measured)", flush=True)
    machine = {"nproc": os.cpu_count()}
    json.dump({"machine": machine, "date": time.strftime("%Y-%m-%d"),
               "command": "python3 bench/forecast.py " + " ".join(sys.argv[1:]), "runs": rows},
              open(args.out, "w"), indent=1)
    print(args.out)


if __name__ == "__main__":
    main()
