#!/usr/bin/env python3
"""Traces what is left between the paper implementation's (GPGP's) μ and ours at test size (docs/reference.md#agreement).

On the reference-agreement test's input (tests/data/icosphere_320.gdp, GPGP at β = 100 so that its Barnes–Hut sums
nearly every dipole exactly), GPGP's driver runs as the checkout computes and with each of its choices that the
prepared copy can switch (bench/reference/prepare_gpgp.py: GPGP_EXACT_D3, GPGP_NO_FLOOR), at two QMC counts; ours
is our model in reference mode (the direct sum, its s, its level, its voxel centres) through the Python module.
Each row: μ's difference at every voxel GPGP does not clip, as a fraction of its largest μ (worst, 99th percentile,
median), and Σ μ ours / its.

Usage: PYTHONPATH=build/python python3 bench/reference_mu_trace.py [--driver build/reference/driver/gpgp_driver]
       [--out bench/results/reference_mu_trace.json]
Build the driver first with `python3 bench/reference.py --gpgp PATH --agreement-only` (it prepares and builds the copy).
"""
import argparse, json, os, platform, subprocess, tempfile

import numpy as np

import gpisvdb

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--driver", default="build/reference/driver/gpgp_driver")
ap.add_argument("--gdp", default="tests/data/icosphere_320.gdp")
ap.add_argument("--out", default="bench/results/reference_mu_trace.json")
args = ap.parse_args()
if not os.access(args.driver, os.X_OK):
    ap.error(f"no GPGP driver at {args.driver}: build it with `python3 bench/reference.py --gpgp PATH --agreement-only`")
if not os.path.isfile(args.gdp):
    ap.error(f"no such file: {args.gdp}")

CLIP = 20  # GPGP clips μ at 20 and scales T to a Frobenius norm of at most 20 (StochasticCalculus::max_mu)
VARIANTS = [("as the checkout", {}, 512), ("exact third derivative", {"GPGP_EXACT_D3": "1"}, 512),
            ("no variance floor", {"GPGP_NO_FLOOR": "1"}, 512),
            ("exact third derivative, no variance floor", {"GPGP_EXACT_D3": "1", "GPGP_NO_FLOOR": "1"}, 512),
            ("exact third derivative, no variance floor", {"GPGP_EXACT_D3": "1", "GPGP_NO_FLOOR": "1"}, 4096)]
OUR_QMC = [512, 16384]


def read_gdp_positions(path):
    tokens = " ".join(line.split("#")[0] for line in open(path)).split()
    count = int(tokens[1])  # "3 N": the dimension, then the dipoles
    return np.array(tokens[2:], float).reshape(count, 42)[:, :3]


def gpgp(env, qmc, tmp):
    dump = os.path.join(tmp, "gpgp")
    cmd = [args.driver, "--input", args.gdp, "--beta", "100", "--qmc", str(qmc), "--no-green", "--no-fmm", "--no-eigen",
           "--dump", dump]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=dict(os.environ, **env)).stdout
    result = json.loads(out.split("RESULT ", 1)[1])
    return result, np.genfromtxt(dump + "_voxels.csv", delimiter=",", names=True)


def our_model(smoothing):
    """Ours in reference mode: the direct sum at GPGP's s, and its level (the field's mean at the dipoles)."""
    length_scale = gpisvdb.Model.from_file(args.gdp, exact=True).length_scale
    model = gpisvdb.Model.from_file(args.gdp, exact=True, smoothing=smoothing / length_scale)
    return model, float(model.evaluate(read_gdp_positions(args.gdp), qmc=1)["mean"].mean())


rows = []
model = None
with tempfile.TemporaryDirectory() as tmp:
    for name, env, qmc in VARIANTS:
        result, v = gpgp(env, qmc, tmp)
        if model is None:  # GPGP's s is reg · lfs whatever the variant
            model, iso, smoothing = *our_model(result["smoothing"]), result["smoothing"]
        assert result["smoothing"] == smoothing, "GPGP's smoothing changed between variants"
        x = np.stack([v["x"], v["y"], v["z"]], 1)
        t = np.stack([v["T00"], v["T01"], v["T02"], v["T11"], v["T12"], v["T22"]], 1)
        t_norm = np.sqrt(t[:, 0] ** 2 + t[:, 3] ** 2 + t[:, 5] ** 2 + 2 * (t[:, 1] ** 2 + t[:, 2] ** 2 + t[:, 4] ** 2))
        free = (v["mu"] < CLIP * (1 - 1e-6)) & (t_norm < CLIP * (1 - 1e-6))
        peak = float(v["mu"].max())
        row = {"gpgp": name, "gpgp_env": env, "gpgp_qmc": qmc, "voxels": int(len(x)), "unclipped": int(free.sum()),
               "gpgp_mass": result["mass"], "ours": []}
        for q in OUR_QMC:
            mu = model.evaluate(x, iso=iso, qmc=q)["mu"]
            d = np.abs(mu - v["mu"])[free] / peak
            row["ours"].append({"qmc": q, "worst": float(d.max()), "p99": float(np.percentile(d, 99)),
                                "median": float(np.median(d)), "sum_ratio": float(mu[free].sum() / v["mu"][free].sum())})
        rows.append(row)
        o = row["ours"][0]
        print("%-44s qmc %5d: worst %.4f %%, p99 %.4f %%, median %.5f %% of the peak; sum ours/its %.5f" % (
            name, qmc, 100 * o["worst"], 100 * o["p99"], 100 * o["median"], o["sum_ratio"]))
json.dump({"machine": platform.node(), "command": "PYTHONPATH=build/python python3 bench/reference_mu_trace.py",
           "input": args.gdp, "note": "differences of mu at GPGP's unclipped voxels, as fractions of its largest mu; "
           "ours at each QMC count in OUR_QMC", "rows": rows}, open(args.out, "w"), indent=1)
print("wrote", args.out)
