#!/usr/bin/env python3
"""The band's floor at the documented accuracy (docs/benchmarks.md#near-field-floor): the one-thread CPU time per band
voxel of the exact near field (the packets' `nearField`, out of line for this, with its float erf and exp) and of the
Kac–Rice QMC sums, from `perf record` of `gpisvdb band` on the bunny at its default voxel size. Issue 17's target,
0.5 M band voxels/s on 2 cores, leaves 4 µs of one core per band voxel for everything.

Needs perf (Debian: linux-perf). Writes bench/results/near_field_floor.json (or --out); medians over --repeat runs.
"""
import argparse, json, os, re, statistics, subprocess, tempfile

ap = argparse.ArgumentParser()
ap.add_argument("--exe", default="build/bin/gpisvdb")
ap.add_argument("--input", default="data/bunny.obj")
ap.add_argument("--sigmas", default="0.25,0.5,1")
ap.add_argument("--repeat", type=int, default=3)
ap.add_argument("--out", default="bench/results/near_field_floor.json")
args = ap.parse_args()

PARTS = {  # share of the profile: which symbols
    "near_field": lambda s: "nearField" in s or "v_erff" in s or "v_expf" in s,  # the float variants: near field only
    "qmc_sums": lambda s: "qmcSums" in s,
    "traversal_rest": lambda s: "PacketTraversal::run" in s,
}


def one_run(sigma, tmp):
    data, report = os.path.join(tmp, "perf.data"), os.path.join(tmp, "report.json")
    subprocess.run(["perf", "record", "-q", "-F", "1000", "-o", data, args.exe, "band", args.input, "--sigma", sigma,
                    "--threads", "1", "--quiet", "-o", os.path.join(tmp, "band.vdb"), "--report", report], check=True)
    text = subprocess.run(["perf", "report", "-i", data, "--no-children", "--sort", "symbol", "-n", "--stdio"],
                          capture_output=True, text=True, check=True).stdout
    samples = {k: 0 for k in PARTS}
    total = 0
    for line in text.splitlines():
        m = re.match(r"\s+[\d.]+%\s+(\d+)\s+\[\.\]\s+(.*)$", line)
        if not m:
            continue
        n, symbol = int(m.group(1)), m.group(2)
        total += n
        for k, match in PARTS.items():
            if match(symbol):
                samples[k] += n
    band = json.load(open(report))["band"]
    voxels, evaluated = band["voxels"], band["evaluated_voxels"]
    row = {"voxels": voxels, "evaluated": evaluated, "cpu_us_per_band_voxel": total / 1000 / voxels * 1e6}
    for k, n in samples.items():
        row[k + "_share"] = n / total
        row[k + "_us_per_band_voxel"] = n / 1000 / voxels * 1e6
    row["near_field_us_per_evaluated_voxel"] = samples["near_field"] / 1000 / evaluated * 1e6
    return row


rows = []
with tempfile.TemporaryDirectory() as tmp:
    for sigma in args.sigmas.split(","):
        runs = [one_run(sigma, tmp) for _ in range(args.repeat)]
        row = {"sigma_rel": float(sigma), "runs": len(runs)}
        for k in runs[0]:
            row[k] = statistics.median(r[k] for r in runs)
        rows.append(row)
        print("σ_rel %s: near field %.2f µs per band voxel (%.0f %%; %.2f per evaluated), QMC %.2f, all %.2f µs, "
              "1 thread" % (sigma, row["near_field_us_per_band_voxel"], 100 * row["near_field_share"],
                            row["near_field_us_per_evaluated_voxel"], row["qmc_sums_us_per_band_voxel"],
                            row["cpu_us_per_band_voxel"]))
out = {"command": "python3 bench/near_field_floor.py --repeat %d --out %s" % (args.repeat, args.out),
       "budget_us_per_band_voxel": 4.0, "rows": rows}
with open(args.out + ".tmp", "w") as f:
    json.dump(out, f, indent=2)
    f.write("\n")
os.replace(args.out + ".tmp", args.out)
