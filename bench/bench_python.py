#!/usr/bin/env python3
"""Overhead of the Python module against the command line on the same band (docs/python.md#overhead-against-the-command-line).

For each sigma S of --sigmas, runs alternately and `--repeat` times each, as separate processes:
  cli:    build/bin/gpisvdb band INPUT -o OUT.vdb --sigma S --quiet
  python: /usr/bin/python3 -c "import gpisvdb; gpisvdb.band(gpisvdb.Model.from_file(INPUT, sigma=S)).write_vdb(OUT)"
and records each process's wall time, CPU time (user + system) and peak RSS (wait4), the median overhead, and whether the two files hold the
same grids (pyopenvdb). Both use every core.

    python3 bench/bench_python.py --out bench/results/python.json   (re-runs itself with --python if numpy is missing)
"""
import argparse
import json
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]

PY_JOB = """
import sys, time
t0 = time.perf_counter()
import gpisvdb
t1 = time.perf_counter()
model = gpisvdb.Model.from_file(sys.argv[1], sigma=float(sys.argv[3]))
band = gpisvdb.band(model)
t2 = time.perf_counter()
band.write_vdb(sys.argv[2])
t3 = time.perf_counter()
mu = band.mu
print(len(band), t1 - t0, t2 - t1, t3 - t2, int(mu.flags.owndata), flush=True)
"""


def timed(cmd, env=None):
    """Wall seconds, peak RSS (bytes) and CPU seconds (user + system) of one process; its stdout."""
    start = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    out = p.stdout.read().decode()
    err = p.stderr.read().decode()
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - start
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        sys.exit(f"bench_python: {' '.join(map(str, cmd))} failed ({p.returncode}): {err}")
    return wall, usage.ru_maxrss * 1024, out, usage.ru_utime + usage.ru_stime


def same_grids(a, b):
    import numpy as np
    import pyopenvdb
    ga, ma = pyopenvdb.readAll(str(a))
    gb, mb = pyopenvdb.readAll(str(b))
    if sorted(g.name for g in ga) != sorted(g.name for g in gb):
        return False
    byname = {g.name: g for g in gb}
    for g in ga:
        h = byname[g.name]
        if g.activeVoxelCount() != h.activeVoxelCount() or g.evalActiveVoxelBoundingBox() != h.evalActiveVoxelBoundingBox():
            return False
        lo, hi = g.evalActiveVoxelBoundingBox()
        shape = tuple(x - y + 1 for y, x in zip(lo, hi)) + ((3,) if g.valueTypeName.startswith("vec3") else ())
        da, db = np.zeros(shape, np.float32), np.zeros(shape, np.float32)
        g.copyToArray(da, ijk=lo)
        h.copyToArray(db, ijk=lo)
        if not np.array_equal(da, db):
            return False
    return True


def measure(a, sigma, env, tmp):
    """One input and sigma: `repeat` alternating runs of each, their medians and the comparison of the files."""
    rows = []
    cli_vdb, py_vdb = pathlib.Path(tmp) / "cli.vdb", pathlib.Path(tmp) / "py.vdb"
    for i in range(a.repeat):
        # Alternating, and which goes first too: a change of the machine's load hits both alike.
        run_cli = lambda: timed([a.exe, "band", a.input, "-o", cli_vdb, "--sigma", str(sigma), "--quiet"])  # noqa: E731
        run_py = lambda: timed([a.python, "-c", PY_JOB, a.input, py_vdb, str(sigma)], env=env)  # noqa: E731
        if i % 2 == 0:
            cli, py = run_cli(), run_py()
        else:
            py, cli = run_py(), run_cli()
        voxels, t_import, t_band, t_write, owndata = py[2].split()
        rows.append({"cli_s": cli[0], "cli_cpu_s": cli[3], "cli_peak_rss_bytes": cli[1], "python_s": py[0],
                     "python_cpu_s": py[3], "python_peak_rss_bytes": py[1],
                     "python_import_s": float(t_import), "python_model_and_band_s": float(t_band),
                     "python_write_s": float(t_write), "voxels": int(voxels), "mu_owns_its_data": bool(int(owndata))})
        print(f"sigma {sigma} run {i + 1}: cli {cli[0]:.2f} s, python {py[0]:.2f} s ({int(voxels)} voxels)", file=sys.stderr)
    cli_med = statistics.median(r["cli_s"] for r in rows)
    py_med = statistics.median(r["python_s"] for r in rows)
    work_med = statistics.median(r["python_model_and_band_s"] + r["python_write_s"] for r in rows)
    cli_cpu = statistics.median(r["cli_cpu_s"] for r in rows)
    py_cpu = statistics.median(r["python_cpu_s"] for r in rows)
    return {
        "sigma_rel": sigma, "voxels": rows[0]["voxels"], "runs": rows,
        "cli_median_s": cli_med, "python_median_s": py_med,
        "overhead_percent": 100.0 * (py_med - cli_med) / cli_med,
        "cli_cpu_median_s": cli_cpu, "python_cpu_median_s": py_cpu,
        "cpu_overhead_percent": 100.0 * (py_cpu - cli_cpu) / cli_cpu,
        "python_import_median_s": statistics.median(r["python_import_s"] for r in rows),
        "python_in_process_median_s": work_med,
        "in_process_overhead_percent": 100.0 * (work_med - cli_med) / cli_med,
        "cli_median_peak_rss_bytes": statistics.median(r["cli_peak_rss_bytes"] for r in rows),
        "python_median_peak_rss_bytes": statistics.median(r["python_peak_rss_bytes"] for r in rows),
        "identical_grids": same_grids(cli_vdb, py_vdb),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--input", default=str(ROOT / "data" / "bunny.obj"))
    ap.add_argument("--sigmas", default="1,0.5", help="relative sigmas, one case each (smaller: finer default voxels)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--exe", default=str(ROOT / "build" / "bin" / "gpisvdb"))
    ap.add_argument("--python", default="/usr/bin/python3")
    ap.add_argument("--out", help="JSON results (default: print only)")
    a = ap.parse_args()
    try:  # the comparison of the files needs numpy and pyopenvdb: Debian's python3 has them
        import numpy  # noqa: F401
        import pyopenvdb  # noqa: F401
    except ImportError:
        if os.path.realpath(sys.executable) != os.path.realpath(a.python):
            os.execv(a.python, [a.python, __file__, *sys.argv[1:]])
        raise
    env = dict(os.environ, PYTHONPATH=str(ROOT / "build" / "python"))
    with tempfile.TemporaryDirectory() as tmp:
        cases = [measure(a, float(s), env, tmp) for s in a.sigmas.split(",")]
    result = {
        "what": "wall time of one process: gpisvdb band vs the Python module's Model.from_file + band + write_vdb "
                "(in_process: the Python process's time less interpreter start and import)",
        "input": os.path.relpath(a.input, ROOT), "voxel_size": "default", "repeat": a.repeat,
        "cpus": os.cpu_count(), "load_average_at_end": os.getloadavg()[0], "cases": cases,
    }
    print(json.dumps([{k: v for k, v in c.items() if k != "runs"} for c in cases], indent=2))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(result, f, indent=2)
            f.write("\n")


if __name__ == "__main__":
    main()
