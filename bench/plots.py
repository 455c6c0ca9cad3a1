#!/usr/bin/python3
"""Plots of the benchmark results: reads bench/results/*.json and writes docs/images/bench_*.png (and, through
bench/plot_energy.py, docs/images/energy.png). docs/benchmarks.md embeds them.

Usage: python3 bench/plots.py [--results bench/results] [--images docs/images]
Run from the repository root (bench/run does). Needs matplotlib (Debian: apt-get install python3-matplotlib), a
bench-only dependency. Every figure has a footer with the machine (bench/results/machine.json, written by
bench/run; else what the result file says; else "machine not recorded"), the threads and the command.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import textwrap

try:
    import matplotlib
except ImportError:
    # A pyenv or venv python3 may shadow Debian's, which has the package: use that one if it can.
    system = "/usr/bin/python3"
    if os.path.realpath(sys.executable) != os.path.realpath(system) and os.access(system, os.X_OK) and \
            subprocess.run([system, "-c", "import matplotlib"], capture_output=True).returncode == 0:
        os.execv(system, [system] + sys.argv)
    print("bench/plots.py needs matplotlib: apt-get install python3-matplotlib", file=sys.stderr)
    sys.exit(1)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))

# The commands that produced each result file, as docs/benchmarks.md documents them (used when neither the
# file's "command" field nor bench/results/machine.json has one; bench/run runs the same).
DOCUMENTED = {
    "model": ["build/bin/bench_model --out bench/results/model.json"],
    "band": ["build/bin/bench_band --part %s --out bench/results/band.json" % p
             for p in ("area", "fig7", "scan", "scanfine", "throughput")],
    "solve": ["build/bin/bench_solve --part all --repeat 3 --out bench/results/solve.json",
              "build/bin/bench_solve --part table --out bench/results/solve.json"],
    "geodesic": ["build/bin/bench_geodesic --part all --repeat 3 --out bench/results/geodesic.json"],
    "spectrum": ["build/bin/bench_spectrum --data data --scales 1,0.8,0.63 --counts 20,200 "
                 "--methods cholmod --out bench/results/spectrum.json",
                 "build/bin/bench_spectrum --data data --scales 1 --counts 20 "
                 "--methods cholmod,simplicial --out bench/results/spectrum.json"],
    "extras": ["build/bin/bench_extras --grid 128 --out bench/results/extras.json"],
    "scan_model": ["build/bin/bench_scan_model --out bench/results/scan_model.json"],
    "energy": ["build/bin/validate_energy --out bench/results/energy.json",
               "build/bin/validate_energy --h-over-wmu 1.5 --out bench/results/energy_fine.json"],
}
# How each program uses threads (none has a --threads flag).
THREAD_USE = {
    "model": "the program measures 1 and 2 threads itself",
    "band": "throughput measured on 1 and 2 threads, the rest uses all threads",
    "solve": "2 threads unless marked 1t; Eigen CG on 1",
    "geodesic": "march single-threaded, tables use all threads",
    "spectrum": "band uses all threads; CHOLMOD + OpenBLAS serial",
    "extras": "uses all threads",
    "scan_model": "evaluation on 1 thread, samples and tree on all",
    "reference": "2 threads (OpenMP for GPGP, TBB for gpisvdb)",
    "energy": "uses all threads",
}
# Paper (Genest & Coeurjolly, cited in docs/math.md) Sec. 9: Intel Xeon W-2245, 8 cores; Green's problem of Fig. 5, sigma {0.25, 0.5, 1}
# (the text prints 0.5 twice), bounding boxes 299x477x282, 106x165x101, 83x128x81.
PAPER_SEC9 = {"band_and_operators_s": [21.0, 4.5, 3.2], "cg_s": [21.0, 6.7, 6.2],
              "box": ["299×477×282", "106×165×101", "83×128×81"]}

plt.rcParams.update({"font.size": 9, "axes.titlesize": 9.5, "legend.fontsize": 7.5, "axes.labelsize": 9,
                     "figure.dpi": 110, "savefig.dpi": 110})


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        print("bench/plots.py: skipping %s (%s)" % (path, e), file=sys.stderr)
        return None


class Context:
    def __init__(self, results, images):
        self.results, self.images = results, images
        self.machine = load(os.path.join(results, "machine.json")) if os.path.exists(
            os.path.join(results, "machine.json")) else None
        self.written = []

    def footer(self, name, data, parts=None):
        """One text block: machine, threads, command(s) (those containing one of `parts`, when given)."""
        # Only the entry bench/run wrote for this benchmark describes the machine that produced this file.
        run = ((self.machine or {}).get("runs") or {}).get(name)
        m = (run or {}).get("machine")
        if m and m.get("cpu_model"):
            machine = "%s, %s cores, %s GiB, %s" % (m.get("cpu_model"), m.get("cores", "?"), m.get("ram_gib", "?"),
                                                    m.get("compiler", "compiler ?"))
            if run and run.get("git_commit"):
                machine += ", commit %s%s, %s" % (run["git_commit"][:10], "+dirty" if run.get("git_dirty") else "",
                                                  run.get("started", "")[:10])
        else:
            said = data.get("machine") if isinstance(data, dict) else None
            if isinstance(said, dict):
                said = ", ".join("%s %s" % kv for kv in said.items())
            machine = "machine not recorded" + (" (%s says: %s)" % (name + ".json", said) if said else "")
        if run and "threads" in run:
            threads = "%s available to the run; %s" % (run["threads"], THREAD_USE.get(name, ""))
        else:
            threads = "not recorded; %s" % THREAD_USE.get(name, "")
        said = data.get("command") if isinstance(data, dict) else None
        documented = False
        if said and " " in said.strip():  # validate_energy records its bare name only: not a command line
            commands = [said]
        elif run and run.get("commands"):
            commands = run["commands"]
        else:
            commands = DOCUMENTED.get(name, ["not recorded"])
            documented = True
        if parts:
            picked = [c for c in commands if any(p in c for p in parts)]
            commands = picked or commands
        if documented:
            commands = [c + ("  (as documented)" if i == len(commands) - 1 else "") for i, c in enumerate(commands)]
        return "machine: %s | threads: %s | command: %s" % (machine, threads, "; ".join(commands))

    def save(self, fig, what, name, data, parts=None):
        """Adds the footer below the axes and writes docs/images/bench_<what>.png."""
        w, h = fig.get_size_inches()
        text = textwrap.fill(self.footer(name, data, parts), width=int(w * 72 / (6.5 * 0.8)))
        lines = text.count("\n") + 1
        bottom = (0.12 + lines * 0.125) / h
        fig.tight_layout(rect=(0, bottom, 1, 1))
        fig.text(0.01, 0.01, text, fontsize=6.5, ha="left", va="bottom", color="0.25", family="DejaVu Sans Mono")
        path = os.path.join(self.images, "bench_%s.png" % what)
        fig.savefig(path)
        plt.close(fig)
        self.written.append(path)
        print("wrote", path)


# === Helpers
def ref_line(ax, xs, x0, y0, f, label, pos=1.0, **kw):
    """A dashed reference c·f(x) through (x0, y0) over the range of xs, labelled at its end."""
    lo, hi = min(xs), max(xs)
    n = 50
    grid = [lo * (hi / lo) ** (i / (n - 1)) for i in range(n)]
    c = y0 / f(x0)
    ys = [c * f(x) for x in grid]
    ax.plot(grid, ys, ls=(0, (4, 3)), color=kw.pop("color", "0.45"), lw=1, zorder=1)
    i = min(n - 1, int(pos * (n - 1)))
    ax.annotate(label, (grid[i], ys[i]), textcoords="offset points", xytext=(3, 2), fontsize=7.5, color="0.35")


def fit_exponent(xs, ys):
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def loglog(ax):
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.25)


def plain_ticks(ax, values, fmt, axis="x"):
    """Ticks at the data's values only (log axes with few points otherwise print 3×10^-1)."""
    a = ax.xaxis if axis == "x" else ax.yaxis
    vals = sorted(set(values))
    a.set_major_locator(matplotlib.ticker.FixedLocator(vals))
    a.set_major_formatter(matplotlib.ticker.FixedFormatter([fmt(v) for v in vals]))
    a.set_minor_formatter(matplotlib.ticker.NullFormatter())


def fmt_n(n):
    return "%.3g M" % (n / 1e6) if n >= 1e6 else ("%.3g k" % (n / 1e3) if n >= 1e3 else "%d" % n)


# === Figures
def plot_model(ctx, d):
    rows = d.get("scaling") or []
    if rows:
        spheres = sorted([r for r in rows if r["input"].startswith("sphere_l")], key=lambda r: r["n"])
        others = [r for r in rows if not r["input"].startswith("sphere_l")]
        names = {"cloud_sphere_20k": "sphere cloud 21k", "bunny": "bunny"}
        fig, axs = plt.subplots(2, 2, figsize=(10, 7.6))
        ax = axs[0][0]
        ns = [r["n"] for r in rows]
        ax.plot([r["n"] for r in spheres], [1e6 / r["direct_qps_1t"] for r in spheres], "o-", color="C3",
                label="direct sum (sphere soups)")
        ax.plot([r["n"] for r in spheres], [1e6 / r["bh_qps_1t"] for r in spheres], "o-", color="C0",
                label="Barnes–Hut, β = %g (sphere soups)" % d.get("beta_default", 6))
        blocks = [r for r in spheres if "leaf_block_us_per_point_1t" in r]
        if blocks:
            ax.plot([r["n"] for r in blocks], [r["leaf_block_us_per_point_1t"] for r in blocks], "o--", color="C1",
                    label="Barnes–Hut on band-like 8³ blocks (sphere soups)")
        cells = [r for r in spheres if "leaf_block_us_per_point_cells_1t" in r]
        if cells:
            ax.plot([r["n"] for r in cells], [r["leaf_block_us_per_point_cells_1t"] for r in cells], "o:", color="C2",
                    label="the same blocks, far field shared per cell")
        for i, r in enumerate(others):
            mk = "s^Dv"[i % 4]
            ax.plot(r["n"], 1e6 / r["direct_qps_1t"], mk, mfc="none", color="C3")
            ax.plot(r["n"], 1e6 / r["bh_qps_1t"], mk, mfc="none", color="C0", label=names.get(r["input"], r["input"]))
        s0 = spheres[0] if spheres else rows[0]
        ref_line(ax, ns, s0["n"], 1e6 / s0["direct_qps_1t"], lambda x: x, "O(n)")
        ref_line(ax, ns, s0["n"], 1e6 / s0["bh_qps_1t"], lambda x: math.log(x), "O(log n)")
        loglog(ax)
        ax.set_xlabel("samples n")
        ax.set_ylabel("µs per query (mean + covariance), 1 thread")
        ax.set_title("Cost per query")
        ax.legend()

        ax = axs[0][1]
        for key, mk, lab in (("speedup_1t", "o-", "1 thread"), ("speedup_2t", "s--", "2 threads")):
            ax.plot([r["n"] for r in spheres], [r[key] for r in spheres], mk, label="sphere soups, " + lab)
        for i, r in enumerate(others):
            ax.plot(r["n"], r["speedup_1t"], "s^Dv"[i % 4], mfc="none", color="k",
                    label=names.get(r["input"], r["input"]) + ", 1 thread")
        ax.plot([1e5], [100], "*", ms=12, color="C2", label="target: 100× at n = 1e5")
        ref_line(ax, ns, s0["n"], s0["speedup_1t"], lambda x: x / math.log(x), "O(n / log n)")
        loglog(ax)
        ax.set_xlabel("samples n")
        ax.set_ylabel("speed-up of Barnes–Hut over the direct sum")
        ax.set_title("Speed-up (same queries, same process)")
        ax.legend()

        ax = axs[1][0]
        ax.plot([r["n"] for r in spheres], [r["bh_error_worst"] for r in spheres], "o-", color="C0",
                label="sphere soups")
        for i, r in enumerate(others):
            ax.plot(r["n"], r["bh_error_worst"], "s^Dv"[i % 4], mfc="none", color="C0",
                    label=names.get(r["input"], r["input"]))
        ax.axhline(1e-3, color="C3", ls=":", lw=1, label="1e-3")
        loglog(ax)
        ax.set_ylim(5e-5, 3e-3)
        ax.set_xlabel("samples n")
        ax.set_ylabel("worst relative error of the 14 numbers")
        ax.set_title("Barnes–Hut error against the direct sum (β = %g)" % d.get("beta_default", 6))
        ax.legend()

        ax = axs[1][1]
        ax.plot([r["n"] for r in spheres], [r["bh_build_s"] for r in spheres], "o-", color="C4", label="tree build")
        for i, r in enumerate(others):
            ax.plot(r["n"], r["bh_build_s"], "s^Dv"[i % 4], mfc="none", color="C4",
                    label=names.get(r["input"], r["input"]))
        big = spheres[-1] if spheres else rows[-1]
        ref_line(ax, ns, big["n"], big["bh_build_s"], lambda x: x * math.log(x), "O(n log n)", pos=0.35)
        loglog(ax)
        ax.set_xlabel("samples n")
        ax.set_ylabel("seconds")
        ax2 = ax.twinx()
        ax2.plot([r["n"] for r in spheres], [r["bh_bytes_per_sample"] for r in spheres], "x:", color="C5")
        ax2.set_ylabel("tree bytes per sample (×, dotted)", color="C5")
        ax2.set_ylim(0, 1.2 * max(r["bh_bytes_per_sample"] for r in rows))
        ax.set_title("Tree build time and memory")
        ax.legend(loc="lower right")
        fig.suptitle("GPIS model: Barnes–Hut against the direct sum", fontsize=10.5)
        ctx.save(fig, "model", "model", d)

    sweep = d.get("beta_sweep_bunny") or []
    if sweep:
        fig, axs = plt.subplots(1, 2, figsize=(10, 4))
        b = [r["beta"] for r in sweep]
        ax = axs[0]
        ax.semilogy(b, [r["error_mean_max"] for r in sweep], "o-", label="mean (γ, ∇γ)")
        ax.semilogy(b, [r["error_cov_max"] for r in sweep], "s-", label="covariance")
        ax.axhline(1e-3, color="C3", ls=":", lw=1, label="1e-3")
        ax.axvline(d.get("beta_default", 6), color="0.5", lw=0.8)
        ax.set_xlabel("β (opening criterion)")
        ax.set_ylabel("worst relative error")
        ax.grid(True, which="both", alpha=0.25)
        ax.legend()
        ax.set_title("Error against β (bunny, 1 000 points)")
        ax = axs[1]
        ax.plot(b, [r["qps_1t"] for r in sweep], "o-", color="C2")
        ax.axvline(d.get("beta_default", 6), color="0.5", lw=0.8)
        ax.text(d.get("beta_default", 6), ax.get_ylim()[1] * 0.97, " default", va="top", fontsize=8)
        ax.set_xlabel("β")
        ax.set_ylabel("queries/s, 1 thread")
        ax.set_ylim(bottom=0)
        ax.grid(True, alpha=0.25)
        ax.set_title("Cost against β")
        ctx.save(fig, "model_beta", "model", d)


def plot_band(ctx, d):
    area = d.get("sphere_area") or []
    if area:
        fig, ax = plt.subplots(figsize=(7, 4.2))
        # bench_band's first row is at a fine h = w_μ/2 (the default before issue 17), the others at min(h*, 1.5 w_μ)
        first, rest = area[0], sorted(area[1:], key=lambda r: r["sigma_rel"])
        ax.plot([first["sigma_rel"]], [100 * first["relative_error_vs_soup"]], "D", ms=11, mfc="none", mew=1.5,
                color="C3", label="h = %g w_μ (fine), N = %s" % (first["h_over_mu_width"], fmt_n(first["voxels"])))
        if rest:
            ax.plot([r["sigma_rel"] for r in rest], [100 * r["relative_error_vs_soup"] for r in rest], "o-", color="C0",
                    label="h = min(h*, 1.5 w_μ)")
        for r in area:
            ax.annotate("%+.2f%%" % (100 * r["relative_error_vs_soup"]), (r["sigma_rel"], 100 * r["relative_error_vs_soup"]),
                        textcoords="offset points", xytext=(-12, -14 if r is first else 6), fontsize=7.5)
        r0 = area[0]
        ax.axhline(0, color="k", lw=0.8)
        ax.axhline(100 * (r0["sphere_area"] / r0["soup_area"] - 1), color="C2", ls="--", lw=1,
                   label="smooth sphere 4π vs soup")
        ax.set_xscale("log")
        plain_ticks(ax, [r["sigma_rel"] for r in area], lambda v: "%g" % v)
        ax.set_ylim(top=100 * max(r["relative_error_vs_soup"] for r in area) + 2)
        ax.set_xlabel("σ_rel")
        ax.set_ylabel("Σ μ h³ / soup area − 1  (%)")
        ax.grid(True, which="both", alpha=0.25)
        ax.legend()
        ax.set_title("Expected area on the unit sphere (1 280 triangles, soup area %.4f)" % r0["soup_area"])
        ctx.save(fig, "band_area", "band", d, ["--part area"])

    fig7 = d.get("fig7_band_size") or []
    if fig7:
        fig, axs = plt.subplots(1, 2, figsize=(10, 4.2))
        ax = axs[0]
        for i, eta in enumerate(sorted({r["eta_rel"] for r in fig7}, reverse=True)):
            rs = sorted([r for r in fig7 if r["eta_rel"] == eta], key=lambda r: r["sigma_rel"])
            ax.plot([r["sigma_rel"] for r in rs], [r["voxels"] for r in rs], "o-", color="C%d" % i, label="η = %g" % eta)
        loglog(ax)
        plain_ticks(ax, [r["sigma_rel"] for r in fig7], lambda v: "%g" % v)
        ax.set_xlabel("σ_rel")
        ax.set_ylabel("band voxels N")
        ax.set_title("Band size against σ and η (bunny, h = h*; paper Fig. 7 top)")
        ax.legend()
        ax = axs[1]
        sig = sorted({r["sigma_rel"] for r in fig7})
        hs = [next(r["h"] for r in fig7 if r["sigma_rel"] == s) for s in sig]
        ax.plot(sig, hs, "o-", color="C4")
        for s, h in zip(sig, hs):
            box = next(r["bbox_voxels"] for r in fig7 if r["sigma_rel"] == s and r["eta_rel"] == 0.01) \
                if any(r["sigma_rel"] == s and r["eta_rel"] == 0.01 for r in fig7) else None
            if box:
                ax.annotate("×".join(str(v) for v in box), (s, h), textcoords="offset points", xytext=(4, -10),
                            fontsize=7.5)
        ax.set_xscale("log")
        plain_ticks(ax, sig, lambda v: "%g" % v)
        ax.set_xlabel("σ_rel")
        ax.set_ylabel("h* (Eq. 25)")
        ax.grid(True, which="both", alpha=0.25)
        ax.set_title("Resolution h* and box (voxels, η = 0.01)")
        ctx.save(fig, "band_size", "band", d, ["--part fig7"])

    scan = list(d.get("bfs_vs_scan") or [])
    if d.get("bfs_vs_scan_fine"):
        scan.append(d["bfs_vs_scan_fine"])
    thr = d.get("throughput") or []
    if scan or thr or fig7:
        fig, axs = plt.subplots(1, 3, figsize=(13, 4.3))
        ax = axs[0]
        if scan:
            box = [math.prod(r["bbox_voxels"]) for r in scan]
            order = sorted(range(len(scan)), key=lambda i: box[i])
            bx = [box[i] for i in order]
            ax.plot(bx, [scan[i]["seconds_scan"] for i in order], "s-", color="C3", label="scan of the box")
            ax.plot(bx, [scan[i]["seconds_bfs"] for i in order], "o-", color="C0", label="BFS from the samples")
            for i in order:
                ax.annotate("%.1f×" % scan[i]["speedup"], (box[i], scan[i]["seconds_bfs"]), textcoords="offset points",
                            xytext=(4, -11), fontsize=7.5, color="C0")
            ref_line(ax, bx, bx[0], scan[order[0]]["seconds_scan"], lambda x: x, "O(box)")
            loglog(ax)
            ax.legend()
        ax.set_xlabel("voxels in the band's bounding box")
        ax.set_ylabel("seconds (μ, T and the band)")
        ax.set_title("BFS against the scan (bunny; paper Fig. 7 bottom)")

        ax = axs[1]
        allx = []
        if fig7:
            ax.plot([r["voxels"] for r in fig7], [r["seconds"] for r in fig7], "o", color="C1",
                    label="bunny, h = h*, all σ, η")
            allx += [r["voxels"] for r in fig7]
        if area:
            ax.plot([r["voxels"] for r in area], [r["seconds"] for r in area], "D", color="C2", label="unit sphere")
            allx += [r["voxels"] for r in area]
        if scan:
            ax.plot([r["band_voxels_bfs"] for r in scan], [r["seconds_bfs"] for r in scan], "s", color="C0",
                    label="bunny, σ = 1 and 0.25 (BFS runs)")
            allx += [r["band_voxels_bfs"] for r in scan]
        if allx:
            xs = sorted(allx)
            pts = [(r["voxels"], r["seconds"]) for r in fig7 + area]
            x0, y0 = min(pts) if pts else (xs[0], 1)
            ref_line(ax, xs, x0, y0, lambda x: x, "O(N)")
            loglog(ax)
            ax.legend()
        ax.set_xlabel("band voxels N")
        ax.set_ylabel("seconds (all threads)")
        ax.set_title("Band build time against N")

        ax = axs[2]
        if thr:
            x = list(range(len(thr)))
            w = 0.38
            ax.bar([i - w / 2 for i in x], [r["evaluated_per_s_1t"] for r in thr], w, label="1 thread")
            ax.bar([i + w / 2 for i in x], [r["evaluated_per_s_2t"] for r in thr], w, label="2 threads")
            for i, r in enumerate(thr):
                ax.text(i, r["evaluated_per_s_2t"] * 1.02, "%.0f B/voxel" % r["bytes_per_voxel"], ha="left",
                        fontsize=7.5)
            ax.set_xticks(x)
            ax.set_xticklabels(["σ_rel %g\nN = %s" % (r["sigma_rel"], fmt_n(r["voxels"])) for r in thr])
            ax.set_ylim(0, 1.25 * max(r["evaluated_per_s_2t"] for r in thr))
            ax.text(0.02, 0.97, "target 500 000 voxels/s: off scale", transform=ax.transAxes, va="top",
                    fontsize=7.5, color="C3")
            ax.legend(loc="upper right")
        ax.set_ylabel("evaluated voxels per second (μ + T)")
        ax.set_title("Throughput (bunny, h = h*)")
        ax.grid(True, axis="y", alpha=0.25)
        ctx.save(fig, "band_scaling", "band", d)


def plot_solve(ctx, d):
    t = d.get("sec9_table") or []
    if t:
        t = sorted(t, key=lambda r: r["sigma_rel"])
        fig, ax = plt.subplots(figsize=(9, 4.4))
        x = list(range(len(t)))
        w = 0.2
        paper_ok = len(t) == len(PAPER_SEC9["cg_s"]) and [r["sigma_rel"] for r in t] == [0.25, 0.5, 1.0]
        bars = [("ours: band + operators (2 cores)", [r["band_and_operators_s"] for r in t], "C0", None),
                ("paper: band + operators (8 cores)", PAPER_SEC9["band_and_operators_s"] if paper_ok else None, "C0", "//"),
                ("ours: CG, Jacobi (2 cores)", [r["cg_s"] for r in t], "C3", None),
                ("paper: CG (8 cores)", PAPER_SEC9["cg_s"] if paper_ok else None, "C3", "//")]
        for j, (lab, ys, col, hatch) in enumerate(bars):
            if ys is None:
                continue
            xs = [i + (j - 1.5) * w for i in x]
            ax.bar(xs, ys, w, label=lab, color=col if hatch is None else "white", edgecolor=col, hatch=hatch)
            for xi, y in zip(xs, ys):
                ax.text(xi, y * 1.08, "%.3g" % y, ha="center", fontsize=7)
        ax.set_yscale("log")
        ax.set_xticks(x)
        labels = []
        for i, r in enumerate(t):
            lab = "σ_rel %g, N = %s\nours %s" % (r["sigma_rel"], fmt_n(r["voxels"]), "×".join(map(str, r["bbox_voxels"])))
            if paper_ok:
                lab += "\npaper %s" % PAPER_SEC9["box"][i]
            labels.append(lab)
        ax.set_xticklabels(labels, fontsize=8)
        ax.set_ylabel("seconds")
        ax.set_ylim(top=max(max(r["band_and_operators_s"] for r in t), 21) * 4)
        ax.grid(True, axis="y", which="both", alpha=0.25)
        ax.legend(ncol=2, loc="upper right")
        ax.set_title("Paper Sec. 9 timings (Green's function, h = h*): ours on the bunny vs the paper's\n"
                     "(paper: Xeon W-2245, 8 cores, its own model of Fig. 5; the machines differ)")
        ctx.save(fig, "solve_sec9", "solve", d, parts=("--part table",))

    s = d.get("solvers") or []
    if s:
        s = sorted(s, key=lambda r: r["voxels"])
        N = [r["voxels"] for r in s]
        series = [("ours_matrix_free_jacobi_2t", "ours, matrix-free Jacobi, 2t", "o-", "C0"),
                  ("ours_assembled_jacobi_2t", "ours, assembled Jacobi, 2t", "o--", "C9"),
                  ("ours_matrix_free_jacobi_1t", "ours, matrix-free Jacobi, 1t", "^-", "C0"),
                  ("ours_assembled_jacobi_1t", "ours, assembled Jacobi, 1t", "^--", "C9"),
                  ("ours_assembled_ic_2t", "ours, incomplete Cholesky, 2t", "D-", "C4"),
                  ("eigen_cg_jacobi", "Eigen ConjugateGradient (1t)", "s-", "C3"),
                  ("openvdb_pcg_jacobi", "OpenVDB pcg::solve", "v-", "C2")]
        fig, axs = plt.subplots(1, 3, figsize=(14, 4.6))
        for key, lab, mk, col in series:
            if all(key in r for r in s):
                mfc = "none" if "1t" in key else None
                axs[0].plot(N, [r[key]["median_s"] for r in s], mk, color=col, mfc=mfc, label=lab)
                axs[1].plot(N, [r[key]["iterations"] for r in s], mk, color=col, mfc=mfc, label=lab)
        k0 = "ours_matrix_free_jacobi_2t"
        if all(k0 in r for r in s):
            ref_line(axs[0], N, N[0], s[0][k0]["median_s"], lambda x: x ** (4 / 3), "O(N^4/3)")
            ref_line(axs[1], N, N[0], s[0][k0]["iterations"], lambda x: x ** (1 / 3), "O(N^1/3)")
        tick = {r["voxels"]: "%s\nσ %g, h %.3g" % (fmt_n(r["voxels"]), r["sigma_rel"], r["h"]) for r in s}
        for ax in axs:
            loglog(ax)
            ax.set_xlabel("band voxels N (bunny σ_rel, voxel size h)")
        axs[0].set_ylabel("seconds to tolerance %g (median)" % s[0].get("tolerance", 1e-6))
        axs[0].set_title("PCG time (set-up included)")
        axs[0].legend(fontsize=6.8)
        axs[1].set_ylabel("iterations")
        axs[1].set_title("PCG iterations")
        ax = axs[2]
        for key, lab, mk in (("matrix_free", "matrix-free L", "o-"), ("assembled_csr", "assembled CSR", "s-"),
                             ("openvdb_stencil_matrix", "OpenVDB SparseStencilMatrix", "v-")):
            ax.plot(N, [r["applications_per_s"][key] * r["voxels"] for r in s], mk, label=lab)
        for ax in axs:
            loglog(ax)
            plain_ticks(ax, N, lambda v: tick[v])
            ax.tick_params(axis="x", labelsize=7)
        ax.set_ylabel("rows per second (applications/s × N), 2 threads")
        ax.set_title("Operator application throughput")
        ax.legend()
        fig.suptitle("Operators and solvers: the Green's function system on bunny bands (default model, η = 0.01)",
                     fontsize=10.5)
        ctx.save(fig, "solve_pcg", "solve", d, parts=("--part all",))


def plot_geodesic(ctx, d):
    boxes, bunny = d.get("boxes") or [], d.get("bunny") or []
    if not (boxes or bunny):
        return
    const = sorted([r for r in boxes if "varying" not in r["case"]], key=lambda r: r["voxels"])
    vary = [r for r in boxes if "varying" in r["case"]]
    bun = sorted(bunny, key=lambda r: r["voxels"])
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.4))
    ax = axs[0]
    allN = [r["voxels"] for r in boxes + bunny]
    if const:
        ax.plot([r["voxels"] for r in const], [r["march_s"] for r in const], "o-", color="C0",
                label="march, boxes (constant metric)")
        ax.plot([r["voxels"] for r in const], [r["tables_s"] for r in const], "o--", color="C1",
                label="stencil tables, boxes")
    for r in vary:
        ax.plot(r["voxels"], r["march_s"], "D", color="C0", mfc="none", ms=8, label="march, varying metric")
        ax.plot(r["voxels"], r["tables_s"], "D", color="C1", mfc="none", ms=8, label="tables, varying metric")
    if bun:
        ax.plot([r["voxels"] for r in bun], [r["march_s"] for r in bun], "s", color="C0", label="march, bunny bands")
        ax.plot([r["voxels"] for r in bun], [r["tables_s"] for r in bun], "s", color="C1", mfc="none",
                label="tables, bunny bands")
    a = const[0] if const else bun[0]
    ref_line(ax, allN, a["voxels"], a["march_s"], lambda x: x * math.log(x), "O(N log N)")
    loglog(ax)
    ax.set_xlabel("voxels N")
    ax.set_ylabel("seconds")
    ax.set_title("Fast marching time (march single-threaded)")
    ax.legend()

    ax = axs[1]
    if const:
        ax.plot([r["voxels"] for r in const], [r["accepted_per_s_march"] for r in const], "o-", color="C0",
                label="ours, boxes (anisotropy 10)")
    for r in vary:
        ax.plot(r["voxels"], r["accepted_per_s_march"], "D", color="C0", mfc="none", ms=8,
                label="ours, varying metric")
    if bun:
        ax.plot([r["voxels"] for r in bun], [r["accepted_per_s_march"] for r in bun], "s", color="C0",
                label="ours, bunny bands")
    ref = d.get("reference_hfm_accepted_per_s") or {}
    hfm = [(1e6, ref.get("box_100_anisotropy_10")), (8e6, ref.get("box_200_anisotropy_10"))]
    hfm = [(x, y) for x, y in hfm if y]
    if hfm:
        ax.plot([x for x, _ in hfm], [y for _, y in hfm], "o-", color="C3", mfc="none",
                label="Mirebeau's HFM, boxes (reference)")
    if ref.get("box_200_varying"):
        ax.plot(8e6, ref["box_200_varying"], "D", color="C3", mfc="none", ms=8, label="HFM, varying metric")
    if ref.get("target"):
        ax.axhline(ref["target"], color="C2", ls=":", lw=1.2, label="target %g M/s" % (ref["target"] / 1e6))
    loglog(ax)
    ax.set_ylim(1e5, 5e6)
    ax.set_xlabel("voxels N")
    ax.set_ylabel("accepted voxels per second (march)")
    ax.set_title("Fast marching throughput against HFM")
    ax.legend(fontsize=7)
    ctx.save(fig, "geodesic", "geodesic", d)


def plot_spectrum(ctx, d):
    runs = d.get("runs") or []
    if not runs:
        return
    # Scaling: the first CHOLMOD/METIS/OpenBLAS row of each (N, k)
    seen, main = set(), []
    for r in runs:
        key = (r["voxels"], r["k"])
        if r.get("method") == "cholmod" and r.get("blas", "OpenBLAS") == "OpenBLAS" and key not in seen:
            seen.add(key)
            main.append(r)
    fig, axs = plt.subplots(1, 3, figsize=(14, 4.6))
    ax = axs[0]
    Ns = sorted({r["voxels"] for r in main})
    for i, k in enumerate(sorted({r["k"] for r in main})):
        rs = sorted([r for r in main if r["k"] == k], key=lambda r: r["voxels"])
        x = [r["voxels"] for r in rs]
        ax.plot(x, [r["total_s"] for r in rs], "o-", color="C%d" % i, label="k = %d: total" % k)
        ax.plot(x, [r["lanczos_s"] for r in rs], "^--", color="C%d" % i, mfc="none", label="k = %d: Lanczos" % k)
        ax.plot(x, [r["factor_s"] for r in rs], "s:", color="C%d" % i, mfc="none", label="k = %d: factor" % k)
    if len(Ns) > 1:
        r0 = min((r for r in main if r["k"] == min(x["k"] for x in main)), key=lambda r: r["voxels"])
        ref_line(ax, Ns, r0["voxels"], r0["factor_s"] / 2, lambda x: x ** 1.5, "O(N^1.5)", pos=0.0)
        loglog(ax)
        plain_ticks(ax, Ns, fmt_n)
    ax.set_xlabel("band voxels N (bunny, σ_rel 1, h = 1, 0.8, 0.63 h*)")
    ax.set_ylabel("seconds")
    ax.set_title("k lowest eigenpairs: CHOLMOD (METIS) + Lanczos")
    ax.legend(fontsize=6.5, ncol=2, loc="lower right")

    ax = axs[1]
    for i, k in enumerate(sorted({r["k"] for r in main})):
        rs = sorted([r for r in main if r["k"] == k], key=lambda r: r["voxels"])
        ax.plot([r["voxels"] for r in rs], [r["peak_bytes"] / 2**30 for r in rs], "o-", color="C%d" % i,
                label="peak memory, k = %d" % k)
    fr = sorted({(r["voxels"], r["factor_nonzeros"]) for r in main})
    if fr:
        ax.plot([x for x, _ in fr], [12 * f / 2**30 for _, f in fr], "x:", color="k", label="12 B × factor entries")
        if len(fr) > 1:
            p = fit_exponent([x for x, _ in fr], [f for _, f in fr])
            ref_line(ax, [x for x, _ in fr], fr[0][0], 12 * fr[0][1] / 2**30 * 0.6, lambda x: x ** p,
                     "fit: factor ∝ N^%.2f" % p, pos=0.55)
    loglog(ax)
    if len(Ns) > 1:
        plain_ticks(ax, Ns, fmt_n)
    ax.set_xlabel("band voxels N")
    ax.set_ylabel("GiB")
    ax.set_title("Peak resident memory (band included)")
    ax.legend(fontsize=7)

    ax = axs[2]
    n0, k0 = (main[0]["voxels"], main[0]["k"]) if main else (runs[0]["voxels"], runs[0]["k"])
    same = [r for r in runs if r["voxels"] == n0 and r["k"] == k0]
    labels, fac, lan = [], [], []
    for r in same:
        labels.append("%s%s, %s\n(row %d of %d)" % (r["method"], " " + r["ordering"] if r.get("ordering") else " (AMD)",
                                                  r.get("blas", ""), runs.index(r) + 1, len(runs)))
        fac.append(r["factor_s"])
        lan.append(r["lanczos_s"])
    y = list(range(len(same)))
    ax.barh(y, fac, color="C1", label="factor")
    ax.barh(y, lan, left=fac, color="C0", label="Lanczos")
    for yi, f, l in zip(y, fac, lan):
        ax.text(f + l, yi, " %.1f s" % (f + l), va="center", fontsize=7.5)
    ax.set_yticks(y)
    ax.set_yticklabels(labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlim(0, 1.2 * max(f + l for f, l in zip(fac, lan)))
    ax.set_xlabel("seconds")
    ax.set_title("Every run at N = %s, k = %d (file order)" % (fmt_n(n0), k0))
    ax.legend(loc="lower right")
    ax.grid(True, axis="x", alpha=0.25)
    ctx.save(fig, "spectrum", "spectrum", d)


def plot_extras(ctx, d):
    hodge = sorted(d.get("hodge") or [], key=lambda r: r["voxels"])
    if hodge:
        N = [r["voxels"] for r in hodge]
        fig, axs = plt.subplots(1, 2, figsize=(10, 4.2))
        ax = axs[0]
        ax.plot(N, [r["seconds"] for r in hodge], "o-", label="solve (median of 3)")
        ref_line(ax, N, N[0], hodge[0]["seconds"], lambda x: x ** (4 / 3), "O(N^4/3)")
        ref_line(ax, N, N[0], hodge[0]["seconds"], lambda x: x, "O(N)", color="0.7")
        for r in hodge:
            ax.annotate("h %g" % r["h"], (r["voxels"], r["seconds"]), textcoords="offset points", xytext=(4, -10),
                        fontsize=7.5)
        loglog(ax)
        plain_ticks(ax, N, fmt_n)
        ax.set_xlabel("band voxels N")
        ax.set_ylabel("seconds")
        ax.set_title("Hodge decomposition (sphere, preset mixed)")
        ax.legend()
        ax = axs[1]
        ax.plot(N, [r["iterations"] for r in hodge], "s-", color="C3", label="PCG iterations (Jacobi, 1e-5)")
        ref_line(ax, N, N[0], hodge[0]["iterations"], lambda x: x ** (1 / 3), "O(N^1/3)")
        loglog(ax)
        plain_ticks(ax, N, fmt_n)
        plain_ticks(ax, [r["iterations"] for r in hodge], lambda v: "%d" % v, axis="y")
        ax.set_xlabel("band voxels N")
        ax.set_ylabel("iterations")
        ax.set_title("Iterations against N")
        ax.legend()
        ctx.save(fig, "hodge", "extras", d)

    reg = sorted(d.get("regression") or [], key=lambda r: r["labels"])
    if reg:
        n = [r["labels"] for r in reg]
        fig, axs = plt.subplots(1, 3, figsize=(13, 4.2))
        for ax, key, scale, ylab, title, p in (
                (axs[0], "build_seconds", 1, "seconds", "Build (dense Cholesky)", 3),
                (axs[1], "us_per_point", 1, "µs per query point", "Query (%d points, batched)" % reg[0]["query_points"], 2),
                (axs[2], "memory_bytes", 1 / 2**20, "MiB", "Factor memory", 2)):
            ys = [r[key] * scale for r in reg]
            ax.plot(n, ys, "o-")
            ref_line(ax, n, n[-1], ys[-1], lambda x, p=p: x ** p, "O(n^%d)" % p, pos=0.0)
            loglog(ax)
            plain_ticks(ax, n, lambda v: "%d" % v)
            ax.set_xlabel("labels n")
            ax.set_ylabel(ylab)
            ax.set_title(title)
        fig.suptitle("Regression GPIS (unit icosphere(4) samples) against the number of labels", fontsize=10.5)
        ctx.save(fig, "regression", "extras", d)

    dist = d.get("smoothed_distance") or []
    rows = [r for r in dist if "brute_force_seconds" in r]
    if rows:
        r = rows[0]
        fig, axs = plt.subplots(1, 2, figsize=(9, 3.6))
        ax = axs[0]
        ax.barh([0, 1], [r["tree_seconds"], r["brute_force_seconds"]], color=["C0", "C3"])
        for y, v in enumerate([r["tree_seconds"], r["brute_force_seconds"]]):
            ax.text(v, y, " %.0f s" % v, va="center", fontsize=8)
        ax.set_yticks([0, 1])
        ax.set_yticklabels(["k-d tree", "brute force"])
        ax.set_xlim(0, 1.25 * r["brute_force_seconds"])
        ax.set_xlabel("seconds")
        ax.set_title("Time (%s grid points, α = %g): %.2f×" % (fmt_n(r["grid_points"]), r["alpha"], r["speedup"]))
        ax = axs[1]
        ax.barh([0, 1], [r["mean_terms"], r["band_voxels"]], color=["C0", "C3"])
        for y, v in enumerate([r["mean_terms"], r["band_voxels"]]):
            ax.text(v, y, " %.0f" % v, va="center", fontsize=8)
        ax.set_yticks([0, 1])
        ax.set_yticklabels(["k-d tree", "brute force"])
        ax.set_xlim(0, 1.25 * r["band_voxels"])
        ax.set_xlabel("terms per grid point")
        ax.set_title("Max difference %.1e (bound %.1e)" % (r["max_difference"], r["tolerance"]))
        fig.suptitle("Smoothed distance on the unit-sphere band (%d voxels)" % r["band_voxels"], fontsize=10.5)
        ctx.save(fig, "distance", "extras", d)


def plot_energy(ctx):
    """energy.png stays bench/plot_energy.py's figure; this adds the footer through its --footer flag."""
    path = os.path.join(ctx.results, "energy.json")
    if not os.path.exists(path):
        return
    footer = ctx.footer("energy", load(path) or {})
    out = os.path.join(ctx.images, "energy.png")
    subprocess.run([sys.executable, os.path.join(HERE, "plot_energy.py"), "--out", out, "--footer", footer],
                   check=True)
    ctx.written.append(out)


def plot_scan_model(ctx, d):
    rows = sorted(d.get("rows") or [], key=lambda r: r["points"])
    if not rows:
        return
    n = [r["points"] for r in rows]
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.4))
    ax = axs[0]
    ax.plot(n, [r["cells_us_per_voxel_1t"] for r in rows], "o-", color="C0", label="cells (the band's path)")
    ax.plot(n, [r["packets_us_per_voxel_1t"] for r in rows], "s--", color="C1", label="packets")
    if all("merged_cells_us_per_voxel_1t" in r for r in rows):
        ax.plot(n, [r["merged_cells_us_per_voxel_1t"] for r in rows], "^-", color="C2",
                label="cells, merged into dipoles at cells of %g s (the default where s > ℓ)" % d.get("merge_rel", 1))
    a = rows[0]
    ref_line(ax, n, a["points"], a["cells_us_per_voxel_1t"], lambda x: x ** 0.5, "∝ √n")
    loglog(ax)
    ax.set_xlabel("cloud points n (unit sphere, σ = %g, s = %g fixed)" % (d.get("sigma", 0), rows[0]["smoothing"]))
    ax.set_ylabel("µs per band-like voxel, 1 thread")
    ax.set_title("Model cost per voxel on denser scans (h = %g)" % d.get("h", 0))
    ax.legend(fontsize=8)
    ax = axs[1]
    ax.plot(n, [r["samples_seconds_all_threads"] for r in rows], "o-", color="C0", label="samples (areas, ℓ)")
    ax.plot(n, [r["tree_build_seconds_all_threads"] for r in rows], "s-", color="C1", label="Barnes–Hut tree")
    ax2 = ax.twinx()
    ax2.plot(n, [r["sample_bytes"] + r["tree_bytes_per_sample"] for r in rows], "d:", color="C2",
             label="bytes per sample (samples + tree)")
    ax2.set_ylabel("bytes per sample")
    ax2.set_ylim(0, 1.2 * max(r["sample_bytes"] + r["tree_bytes_per_sample"] for r in rows))
    loglog(ax)
    ax.set_xlabel("cloud points n")
    ax.set_ylabel("seconds (all threads)")
    ax.set_title("Model build and memory")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left")
    ctx.save(fig, "scan_model", "scan_model", d)


def plot_reference(ctx):
    """GPGP's stage times over ours in its reference mode (bench/reference.py), per input: medians of alternated runs
    where the file has them, one run otherwise; the eigenpairs from the one run that measured them."""
    files = [("reference_repeat3.json", "median of 3"), ("reference_macaca.json", "one run"), ("reference.json", "one run")]
    rows, commands = {}, []
    for name, how in files:
        d = load(os.path.join(ctx.results, name)) if os.path.exists(os.path.join(ctx.results, name)) else None
        if not d:
            continue
        commands.append(d.get("command", name))
        for i in d.get("inputs", []):
            g, o = i["gpgp"]["seconds"], i["reference_mode"]["seconds"]
            r = rows.setdefault(i["input"].replace("_variance", ""), {"how": how})
            pairs = {"band + μ + T": (g.get("band"), o.get("band")), "operators": (g.get("operators"), o.get("operators")),
                     "Green": (g.get("green"), o.get("green")),
                     "geodesic": ((g.get("fmm_stencils") or 0) + (g.get("fmm_march") or 0) or None, o.get("geodesic")),
                     "10 eigenpairs (one run)": (g.get("eigen"), o.get("eigen"))}
            for stage, (a, b) in pairs.items():
                if a and b and stage not in r:
                    r[stage] = a / b
    if not rows:
        return
    stages = ["band + μ + T", "operators", "Green", "geodesic", "10 eigenpairs (one run)"]
    inputs = sorted(rows)
    fig, ax = plt.subplots(figsize=(11, 4.6))
    width = 0.8 / len(inputs)
    for k, name in enumerate(inputs):
        xs = [j + (k - (len(inputs) - 1) / 2) * width for j, st in enumerate(stages) if st in rows[name]]
        ys = [rows[name][st] for st in stages if st in rows[name]]
        ax.bar(xs, ys, width, label="%s (%s)" % (name, rows[name]["how"]), color="C%d" % k)
        for x, y in zip(xs, ys):
            ax.text(x, y * 1.05, "%.0f×" % y if y >= 10 else "%.1f×" % y, ha="center", va="bottom", fontsize=7)
    ax.set_yscale("log")
    ax.axhline(1, color="0.5", lw=0.8)
    ax.set_xticks(range(len(stages)))
    ax.set_xticklabels(stages)
    ax.set_ylabel("GPGP's time / gpisvdb's (reference mode)")
    ax.set_title("The paper's implementation (GPGP) against gpisvdb on its own data, same parameters, same 2-core machine")
    ax.legend(fontsize=8)
    ctx.save(fig, "reference", "reference", {"command": "; ".join(commands), "machine": {"nproc": 2}})


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", default="bench/results")
    ap.add_argument("--images", default="docs/images")
    args = ap.parse_args()
    os.makedirs(args.images, exist_ok=True)
    ctx = Context(args.results, args.images)
    for name, fn in (("model", plot_model), ("band", plot_band), ("solve", plot_solve), ("geodesic", plot_geodesic),
                     ("spectrum", plot_spectrum), ("extras", plot_extras),
                     ("scan_model", plot_scan_model)):
        path = os.path.join(args.results, name + ".json")
        if not os.path.exists(path):
            print("bench/plots.py: no %s, skipped" % path, file=sys.stderr)
            continue
        data = load(path)
        if data is not None:
            fn(ctx, data)
    plot_energy(ctx)
    plot_reference(ctx)
    print("bench/plots.py: %d figures" % len(ctx.written))


if __name__ == "__main__":
    main()
