#!/usr/bin/env python3
"""gpisvdb-mpi on 1, 2 and 4 ranks against the one-process gpisvdb: time per stage, communication, memory per rank.

Each configuration runs --repeat times, alternating with the others (the machine is shared and noisy), and each
figure is a median. Every rank runs one thread; the one-process baseline runs with 1 thread and with as many
threads as ranks, so that "ranks vs threads" on the same cores is visible. Commands: band, green (PETSc CG with
BoomerAMG vs our PCG with BoomerAMG) and spectrum (SLEPc Krylov-Schur on MUMPS vs Lanczos on CHOLMOD).

Usage: bench/bench_mpi.py [--input data/bunny.obj] [--sigma 1] [--voxel-size 0.1] [--ranks 1,2,4] [--repeat 3]
           [--out bench/results/mpi.json]
"""
import argparse
import json
import os
import platform
import statistics
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(cmd, workdir):
    report = os.path.join(workdir, "report.json")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    subprocess.run(cmd + ["--report", report, "--quiet"], check=True, stdout=subprocess.DEVNULL, env=env)
    with open(report) as f:
        return json.load(f)


def command(task, args, ranks, threads, workdir):
    out = os.path.join(workdir, "out.vdb")
    extra = {"band": [], "green": ["--source", args.source], "spectrum": ["-k", str(args.k)]}[task]
    common = [args.input, "--sigma", str(args.sigma), "--voxel-size", str(args.voxel_size), "-o", out,
              "--threads", str(threads)] + extra
    if ranks == 0:
        return [os.path.join(ROOT, "build/bin/gpisvdb"), task] + common
    return ["mpirun", "--oversubscribe", "-n", str(ranks), os.path.join(ROOT, "build/bin/gpisvdb-mpi"), task] + common


def figures(task, r):
    t = r["timings_s"]
    f = {"total_s": t["total"], "band_s": t["band"], "voxels": r["band"]["voxels"],
         "peak_rss_bytes": r["memory"]["peak_rss_bytes"]}
    for key in ("operators", "setup", "solve"):
        if key in t:
            f[key + "_s"] = t[key]
    if "mpi" in r:
        m = r["mpi"]
        f.update({"bytes_exchanged": m["bytes_exchanged"], "max_seconds_exchanging": m["max_seconds_exchanging"],
                  "voxels_per_rank": m["voxels_per_rank"], "search_voxels_per_rank": m["search_voxels_per_rank"],
                  "peak_rss_bytes_per_rank": m["peak_rss_bytes_per_rank"]})
        if "halo_unknowns" in m:
            f["halo_unknowns"] = m["halo_unknowns"]
    if task == "green":
        f["iterations"] = r["solver"]["iterations"]
        f["relative_residual"] = r["solver"]["relative_residual"]
        f["method"] = r["solver"]["method"]
    if task == "spectrum":
        f["method"] = r["spectrum"]["method"]
        f["max_residual"] = max(r["spectrum"]["residuals"])
    return f


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--input", default=os.path.join(ROOT, "data/bunny.obj"))
    p.add_argument("--sigma", type=float, default=1.0)
    p.add_argument("--voxel-size", type=float, default=0.1)
    p.add_argument("--source", default="0.5,6,1")
    p.add_argument("-k", type=int, default=20)
    p.add_argument("--ranks", default="1,2,4")
    p.add_argument("--tasks", default="band,green,spectrum")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", default=os.path.join(ROOT, "bench/results/mpi.json"))
    args = p.parse_args()
    ranks = [int(x) for x in args.ranks.split(",")]
    # (label, ranks, threads): ranks 0 is the one-process gpisvdb
    configs = [("gpisvdb, 1 thread", 0, 1), ("gpisvdb, 2 threads", 0, 2)] + \
              [(f"gpisvdb-mpi, {n} rank{'s' if n > 1 else ''}", n, 1) for n in ranks]
    results = {}
    with tempfile.TemporaryDirectory() as workdir:
        for task in args.tasks.split(","):
            runs = {label: [] for label, _, _ in configs}
            for _ in range(args.repeat):
                for label, n, threads in configs:
                    runs[label].append(figures(task, run(command(task, args, n, threads, workdir), workdir)))
            results[task] = {}
            for label, _, _ in configs:
                rs = runs[label]
                med = {k: statistics.median(x[k] for x in rs) for k in rs[0] if isinstance(rs[0][k], (int, float))}
                med.update({k: rs[0][k] for k in rs[0] if not isinstance(rs[0][k], (int, float))})
                results[task][label] = med
                print(task, label, {k: med[k] for k in ("total_s", "band_s") if k in med}, flush=True)
    out = {"command": "bench/bench_mpi.py " + " ".join(f"--{k.replace('_', '-')} {v}" for k, v in vars(args).items()
                                                      if k not in ("out", "input")),
           "input": os.path.relpath(args.input, ROOT), "sigma": args.sigma, "voxel_size": args.voxel_size,
           "repeat": args.repeat, "machine": {"cores": os.cpu_count(), "processor": platform.processor()},
           "results": results}
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
