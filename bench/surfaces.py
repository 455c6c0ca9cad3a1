#!/usr/bin/env python3
"""What plausible surfaces cost (docs/benchmarks.md#plausible-surfaces): `gpisvdb surfaces` on the bunny at its default
band with n = 1, 8 and 32 draws, and `gpisvdb band` alone on the same input, alternated (the machine's load touches
all alike); medians of the report's stage times, the draws' time per band build, and the stage's memory estimate
against its measured peak. Writes bench/results/surfaces.json."""
import argparse, json, os, statistics, subprocess, tempfile

ap = argparse.ArgumentParser()
ap.add_argument("--out", default="bench/results/surfaces.json")
ap.add_argument("--exe", default="build/bin/gpisvdb")
ap.add_argument("--input", default="data/bunny.obj")
ap.add_argument("--draws", default="1,8,32")
ap.add_argument("--repeat", type=int, default=3)
args = ap.parse_args()

counts = [int(n) for n in args.draws.split(",")]
runs = {n: [] for n in counts}
bands = []
with tempfile.TemporaryDirectory() as tmp:
    report = os.path.join(tmp, "report.json")
    for _ in range(args.repeat):
        subprocess.run([args.exe, "band", args.input, "-o", os.path.join(tmp, "band.vdb"), "--report", report, "--quiet"],
                       check=True)
        bands.append(json.load(open(report)))
        for n in counts:
            subprocess.run([args.exe, "surfaces", args.input, "-n", str(n), "-o", os.path.join(tmp, "draws"),
                            "--report", report, "--quiet"], check=True)
            runs[n].append(json.load(open(report)))


def median(reports, *path):
    values = []
    for r in reports:
        for key in path:
            r = r[key]
        values.append(r)
    return statistics.median(values)


band_seconds = median(bands, "timings_s", "band")
out = {
    "command": "python3 bench/surfaces.py --draws %s --repeat %d --out %s" % (args.draws, args.repeat, args.out),
    "input": args.input,
    "band_voxels": bands[0]["band"]["voxels"],
    "voxel_size": bands[0]["parameters"]["voxel_size"],
    "band_seconds": {"median": band_seconds, "runs": [r["timings_s"]["band"] for r in bands]},
    "draws": [],
}
for n in counts:
    draws, meshes = median(runs[n], "timings_s", "draws"), median(runs[n], "timings_s", "meshes")
    stage = runs[n][-1]["memory"]["stages"]["surfaces"]
    surfaces = runs[n][-1]["surfaces"]
    out["draws"].append({
        "n": n,
        "draws_seconds": {"median": draws, "runs": [r["timings_s"]["draws"] for r in runs[n]]},
        "meshes_seconds": {"median": meshes, "runs": [r["timings_s"]["meshes"] for r in runs[n]]},
        "draws_per_band_build": draws / band_seconds,
        "mean_area": surfaces["mean_area"], "area_std": surfaces["area_std"], "expected_area": surfaces["expected_area"],
        "memory_estimate_error": stage["estimate_error"],
    })
with open(args.out + ".tmp", "w") as f:
    json.dump(out, f, indent=2)
    f.write("\n")
os.replace(args.out + ".tmp", args.out)
print("surfaces: %d band voxels, band %.2f s; " % (out["band_voxels"], band_seconds) +
      ", ".join("n = %d: draws %.2f s (%.2f band builds), meshes %.2f s" %
                (d["n"], d["draws_seconds"]["median"], d["draws_per_band_build"], d["meshes_seconds"]["median"])
                for d in out["draws"]))
