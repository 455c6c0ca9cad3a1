#!/usr/bin/env python3
"""What the occupancy fog grid costs (docs/benchmarks.md#occupancy): `gpisvdb band` on the bunny at its default
settings with the grid (--fog-name density, the default) and without it (--fog-name ""), alternated, medians of the
wall time and the file sizes; and the NanoVDB file of the same band. Writes bench/results/occupancy.json."""
import argparse, json, os, statistics, subprocess, tempfile, time

ap = argparse.ArgumentParser()
ap.add_argument("--out", default="bench/results/occupancy.json")
ap.add_argument("--exe", default="build/bin/gpisvdb")
ap.add_argument("--input", default="data/bunny.obj")
ap.add_argument("--repeat", type=int, default=3)
args = ap.parse_args()

variants = {"with_occupancy": [], "without_occupancy": ["--fog-name", ""]}
times = {k: [] for k in variants}
writes = {k: [] for k in variants}  # the report's total less model and band: the .vdb's grids made and written
sizes, reports = {}, {}
with tempfile.TemporaryDirectory() as tmp:
    for _ in range(args.repeat):
        for name, extra in variants.items():  # side by side: the machine's load touches both alike
            path, report = os.path.join(tmp, name + ".vdb"), os.path.join(tmp, name + ".json")
            t0 = time.monotonic()
            subprocess.run([args.exe, "band", args.input, "-o", path, "--report", report, "--quiet"] + extra, check=True)
            times[name].append(time.monotonic() - t0)
            sizes[name] = os.path.getsize(path)
            reports[name] = json.load(open(report))
            t = reports[name]["timings_s"]
            writes[name].append(t["total"] - t["model"] - t["band"])
    nvdb = os.path.join(tmp, "band.nvdb")
    subprocess.run([args.exe, "band", args.input, "-o", nvdb, "--quiet"], check=True)
    sizes["nanovdb"] = os.path.getsize(nvdb)

band = reports["with_occupancy"]["band"]
out = {
    "command": "python3 bench/occupancy.py --repeat %d --out %s" % (args.repeat, args.out),
    "input": args.input,
    "band_voxels": band["voxels"],
    "voxel_size": reports["with_occupancy"]["parameters"]["voxel_size"],
    "wall_seconds": {k: {"median": statistics.median(v), "runs": v} for k, v in times.items()},
    "time_ratio": statistics.median(times["with_occupancy"]) / statistics.median(times["without_occupancy"]),
    "write_seconds": {k: {"median": statistics.median(v), "runs": v} for k, v in writes.items()},
    "file_bytes": sizes,
    "file_ratio": sizes["with_occupancy"] / sizes["without_occupancy"],
}
with open(args.out + ".tmp", "w") as f:
    json.dump(out, f, indent=2)
    f.write("\n")
os.replace(args.out + ".tmp", args.out)
print("occupancy: %d band voxels; time x%.3f, writing %.2f s against %.2f s, file x%.3f; NanoVDB %.1f MB against %.1f MB" %
      (out["band_voxels"], out["time_ratio"], out["write_seconds"]["with_occupancy"]["median"],
       out["write_seconds"]["without_occupancy"]["median"], out["file_ratio"], sizes["nanovdb"] / 1e6,
       sizes["with_occupancy"] / 1e6))
