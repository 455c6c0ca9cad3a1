#!/usr/bin/env python3
"""gpisvdb side by side with the paper's own implementation (GPGP) on its shipped Gaussian dipoles
(docs/reference.md). Needs a checkout of GPGP (github.com/baptiste-genest/GPGP); CI does not run this.

The reference is built headless from a copy (bench/reference/prepare_gpgp.py, then bench/reference/CMakeLists.txt
with bench/reference/gpgp_driver.cpp) against Debian's Eigen, Spectra, spdlog and OpenMP, and run with its
showcase's defaults. gpisvdb runs the same input twice:
  - in reference mode: its parameters mapped onto ours (the smoothing reg·lfs, β, η absolute, the voxel size h and
    the level: GPGP's is the mean of its field at the dipoles, here the mean of γ at them), bench flags only;
  - at our defaults.
Stages: the band with μ and T, the operators, the Green's function, the geodesic distance and 10 eigenpairs; the
reference's and ours alternated, `--repeat` times; medians. Writes bench/results/reference.json.

With --agreement-only: μ, T and the field at its voxels against ours; with --joins also the Green's function and
the geodesic distance on its lattice (docs/reference.md#joins; reads our grids with Debian's pyopenvdb, so run it
with /usr/bin/python3), and with --eigen-joins the 10 lowest eigenvalues there. --gpgp-args and --our-args pass
switches to the driver and flags to gpisvdb, for tracing a difference (docs/reference.md#running-it).

Usage: python3 bench/reference.py --gpgp PATH [--inputs spot_low_variance,...] [--repeat 1] [--no-eigen]
                                  [--agreement-only [--joins [--eigen-joins]]] [--gpgp-args ARGS] [--our-args ARGS]
                                  [--work DIR] [--out FILE]
"""
import argparse, json, os, re, statistics, subprocess, sys, tempfile, time

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--gpgp", required=True, help="a GPGP checkout")
ap.add_argument("--inputs", default="spot_low_variance", help="names of its data/*.gdp, or paths of .gdp files, comma separated")
ap.add_argument("--repeat", type=int, default=1)
ap.add_argument("--no-eigen", action="store_true", help="leave out the 10 eigenpairs (GPGP takes minutes)")
ap.add_argument("--agreement-only", action="store_true",
                help="only the voxel-by-voxel agreement (one reference run without eigenpairs, no timings)")
ap.add_argument("--joins", action="store_true",
                help="with --agreement-only: also the Green's function and the geodesic distance voxel by voxel, ours "
                     "on the reference's lattice (the input shifted so that its voxel centres are ours); needs pyopenvdb")
ap.add_argument("--eigen-joins", action="store_true",
                help="with --joins: also the 10 lowest eigenvalues of its L and M (through L's Cholesky factor, "
                     "--eigen-direct of the driver) against ours on its lattice")
ap.add_argument("--exe", default="build/bin/gpisvdb")
ap.add_argument("--work", default="build/reference", help="where the reference's copy and build go")
ap.add_argument("--gpgp-args", default="", help="more arguments for the reference's driver, e.g. '--beta 100'")
ap.add_argument("--our-args", default="",
                help="more flags for gpisvdb in the joins, e.g. '--max-anisotropy 1e9' (what a difference owes to)")
ap.add_argument("--out", help="default: bench/results/reference.json (reference_agreement.json with --agreement-only)")
args = ap.parse_args()
if args.out is None:
    args.out = "bench/results/reference_agreement.json" if args.agreement_only else "bench/results/reference.json"
here = os.path.dirname(os.path.abspath(__file__))

# === The reference, built headless
copy, build = os.path.join(args.work, "gpgp"), os.path.join(args.work, "driver")
subprocess.run([sys.executable, os.path.join(here, "reference", "prepare_gpgp.py"), args.gpgp, copy], check=True)
subprocess.run(["cmake", "-S", os.path.join(here, "reference"), "-B", build, "-DGPGP_SOURCE=" + os.path.abspath(copy)],
               check=True, stdout=subprocess.DEVNULL)
subprocess.run(["cmake", "--build", build, "-j", str(os.cpu_count())], check=True, stdout=subprocess.DEVNULL)
driver = os.path.join(build, "gpgp_driver")
SOURCE = "-0.286,-0.141,-0.181"  # a point on spot's side (the driver's default source)


def gpgp(gdp, dump=None, eigen=True, extra=()):
    cmd = [driver, "--input", gdp, "--source", SOURCE] + (["--no-eigen"] if args.no_eigen or not eigen else []) + \
        (["--dump", dump] if dump else []) + args.gpgp_args.split() + list(extra)
    start = time.monotonic()
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=dict(os.environ, OMP_NUM_THREADS=str(os.cpu_count()))).stdout
    result = json.loads(out.split("RESULT ", 1)[1])
    result["wall"] = time.monotonic() - start
    return result


def ours(command, gdp, flags, tmp, extra=()):
    report = os.path.join(tmp, "report.json")
    cmd = [args.exe, command, gdp, "-o", os.path.join(tmp, "out.vdb"), "--report", report, "--quiet"] + flags + list(extra)
    subprocess.run(cmd, check=True)
    return json.load(open(report))


def with_reference_eta(gdp, first, flags, tmp):
    """`flags` plus GPGP's η, which is absolute, as our relative --eta: over the median μ at the samples' voxels of a
    band built with `flags` (a probe). Returns the flags and the probe's report."""
    probe = ours("band", gdp, flags, tmp)
    return flags + ["--eta", repr(first["eta"] / probe["band"]["median_mu_at_samples"])], probe


def dipole_positions(gdp):
    tokens = open(gdp).read().split()
    n = int(tokens[1])
    return [[float(t) for t in tokens[2 + 42 * i: 5 + 42 * i]] for i in range(n)]


def median(values):
    return statistics.median(values) if values else None


def quantile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(q * len(v)))] if v else None


def read_csv(path):
    rows = open(path).read().splitlines()
    names = rows[0].split(",")
    return {n: [float(r.split(",")[k]) for r in rows[1:]] for k, n in enumerate(names)}


def agreement(gdp, voxels_csv, flags, tmp):
    """mu, T and the field at the reference's voxel centres against ours evaluated at the same points (point
    values both: a join on position, whatever the two lattices' anchors). Voxels where the reference clipped mu
    (at max_mu = 20) or T (Frobenius norm at 20) are counted and left out of the comparison."""
    g = read_csv(voxels_csv)
    points = os.path.join(tmp, "voxels.xyz")
    with open(points, "w") as f:
        for x, y, z in zip(g["x"], g["y"], g["z"]):
            f.write("%r %r %r\n" % (x, y, z))
    at = os.path.join(tmp, "voxels_ours.csv")
    subprocess.run([args.exe, "evaluate", gdp, "--at", points, "-o", at, "--quiet"] + flags, check=True)
    o = read_csv(at)
    n = len(g["mu"])
    T_g = [(g["T00"][i], g["T01"][i], g["T02"][i], g["T11"][i], g["T12"][i], g["T22"][i]) for i in range(n)]
    T_o = [(o["Txx"][i], o["Txy"][i], o["Txz"][i], o["Tyy"][i], o["Tyz"][i], o["Tzz"][i]) for i in range(n)]

    def frobenius(t):
        return (t[0] ** 2 + t[3] ** 2 + t[5] ** 2 + 2 * (t[1] ** 2 + t[2] ** 2 + t[4] ** 2)) ** 0.5

    clipped = [g["mu"][i] >= 20 * (1 - 1e-6) or frobenius(T_g[i]) >= 20 * (1 - 1e-6) for i in range(n)]
    # The fields differ by an affine map (the reference's φ against our γ): least squares a γ + b
    mg, mo = statistics.mean(g["mean"]), statistics.mean(o["gamma"])
    cov = sum((a - mo) * (b - mg) for a, b in zip(o["gamma"], g["mean"]))
    var = sum((a - mo) ** 2 for a in o["gamma"])
    a = cov / var
    b = mg - a * mo
    field = [abs(a * x + b - y) for x, y in zip(o["gamma"], g["mean"])]
    spread = max(g["mean"]) - min(g["mean"])
    keep = [i for i in range(n) if not clipped[i]]
    peak = max(g["mu"][i] for i in keep)
    mu_rel = [abs(o["mu"][i] - g["mu"][i]) / peak for i in keep]
    T_rel = [frobenius([p - q for p, q in zip(T_o[i], T_g[i])]) / peak for i in keep]
    return {"voxels": n, "clipped_share": sum(clipped) / n,
            "field_affine": {"scale": a, "offset": b, "max_residual_over_range": max(field) / spread},
            "mu_unclipped": {"ours_over_reference": sum(o["mu"][i] for i in keep) / sum(g["mu"][i] for i in keep),
                             "median_abs_diff_over_peak": median(mu_rel), "p99_abs_diff_over_peak": quantile(mu_rel, 0.99),
                             "peak": peak},
            "T_unclipped": {"median_frobenius_diff_over_peak_mu": median(T_rel), "p99": quantile(T_rel, 0.99)},
            "ours_sum_mu_over_reference_voxels": sum(o["mu"]) / sum(g["mu"])}


def shifted_gdp(gdp, offset, path):
    """The .gdp with every dipole's position less `offset` (normals and covariances unchanged): a translation, so
    that the reference's voxel centres o + h k fall on ours, h k."""
    tokens = open(gdp).read().split()
    n = int(tokens[1])
    for i in range(n):
        for d in range(3):
            k = 2 + 42 * i + d
            tokens[k] = repr(float(tokens[k]) - offset[d])
    with open(path, "w") as f:
        f.write(tokens[0] + " " + tokens[1] + "\n")
        for i in range(n):
            f.write(" ".join(tokens[2 + 42 * i: 2 + 42 * (i + 1)]) + "\n")


def grid_values(vdb, name):
    """{(i, j, k): value} of a float grid's active voxels (Debian's pyopenvdb)."""
    import pyopenvdb
    grid = pyopenvdb.read(vdb, name)
    return {tuple(item.min): item.value for item in grid.citerOnValues() if item.count == 1}


def fit(ours, theirs):
    """theirs ≈ a·ours (least squares through 0) and ≈ a·ours + b, with the affine fit's residuals over the
    reference's range: how far two fields are from differing by their units alone."""
    n = len(ours)
    scale = sum(x * y for x, y in zip(ours, theirs)) / sum(x * x for x in ours)
    mo, mt = sum(ours) / n, sum(theirs) / n
    a = sum((x - mo) * (y - mt) for x, y in zip(ours, theirs)) / sum((x - mo) ** 2 for x in ours)
    b = mt - a * mo
    spread = max(theirs) - min(theirs)
    res = sorted(abs(a * x + b - y) / spread for x, y in zip(ours, theirs))
    return {"scale_through_zero": scale, "affine": [a, b], "median_residual_over_range": res[n // 2],
            "p99_residual_over_range": res[min(n - 1, int(0.99 * n))], "max_residual_over_range": res[-1]}


def joins(gdp, first, base, tmp):
    """Our Green's function and geodesic distance from GPGP's source voxel, on GPGP's lattice, joined voxel by voxel
    with its own (columns green and distance of its dump)."""
    g = read_csv(os.path.join(tmp, "gpgp_voxels.csv"))
    h = first["dx"]
    offset = [g[c][0] - h * round(g[c][0] / h) for c in "xyz"]
    keys = [tuple(int(round((g[c][i] - offset[d]) / h)) for d, c in enumerate("xyz")) for i in range(len(g["x"]))]
    off_lattice = max(abs((g[c][i] - offset[d]) / h - keys[i][d]) for i in range(len(keys)) for d, c in enumerate("xyz"))
    shifted = os.path.join(tmp, "shifted.gdp")
    shifted_gdp(gdp, offset, shifted)
    source = ",".join(repr(first["source_node"][d] - offset[d]) for d in range(3))
    flags, probe = with_reference_eta(shifted, first, base, tmp)
    out = {"offset": offset, "off_lattice_max": off_lattice, "reference_voxels": len(keys), "mapped_flags": flags,
           "band_voxels": probe["band"]["voxels"], "mass": probe["band"]["mass"]}
    for command, grid, column in (("green", "green", "green"), ("geodesic", "geodesic", "distance")):
        vdb = os.path.join(tmp, command + ".vdb")
        subprocess.run([args.exe, command, shifted, "--source", source, "-o", vdb, "--quiet"] + flags, check=True)
        mine = grid_values(vdb, grid)
        common = [i for i, k in enumerate(keys) if k in mine]
        o = [mine[keys[i]] for i in common]
        t = [g[column][i] for i in common]
        out[command] = {"our_voxels": len(mine), "common_voxels": len(common), **fit(o, t),
                        # GPGP's L lacks the h its M carries, its source is M e_s, its distances are in voxels
                        "expected_scale": first["source_mu"] * h ** 4 if command == "green" else 1 / h}
    if args.eigen_joins:
        # Its L lacks the h its M carries: its λ are ours over h. Its eigenpairs came with its first run.
        report = os.path.join(tmp, "spectrum.json")
        subprocess.run([args.exe, "spectrum", shifted, "-k", "10", "-o", os.path.join(tmp, "spectrum.vdb"), "--report", report,
                        "--quiet"] + flags, check=True)
        mine = sorted(json.load(open(report))["spectrum"]["eigenvalues"])
        scaled = sorted(v * h for v in first.get("eigenvalues_grid_units", []))  # the driver lists them from the largest
        out["eigenvalues"] = {"ours": mine, "reference_times_h": scaled, "voxels": first["voxels"],
                              "ours_over_reference": [a / b for a, b in zip(mine, scaled)],
                              "reference_seconds": first["seconds"].get("eigen")}
    return out


results = {"command": "python3 bench/reference.py --gpgp PATH --inputs %s --repeat %d%s%s%s" %
           (args.inputs, args.repeat, " --no-eigen" if args.no_eigen else "",
            " --agreement-only" + (" --joins" if args.joins else "") + (" --eigen-joins" if args.eigen_joins else "")
            if args.agreement_only else "",
            " --gpgp-args '%s'" % args.gpgp_args if args.gpgp_args else "") +
           (" --our-args '%s'" % args.our_args if args.our_args else ""),
           "machine": {"nproc": os.cpu_count()}, "date": time.strftime("%Y-%m-%d"), "inputs": []}
with tempfile.TemporaryDirectory() as tmp:
    for name in args.inputs.split(","):
        gdp = name if name.endswith(".gdp") else os.path.join(args.gpgp, "data", name + ".gdp")
        # === Reference mode: GPGP's parameters in our terms
        eigen_joins = args.agreement_only and args.joins and args.eigen_joins  # its eigenpairs from this one run
        first = gpgp(gdp, dump=os.path.join(tmp, "gpgp"), eigen=not args.agreement_only or eigen_joins,
                     extra=["--eigen-direct"] if eigen_joins else [])
        info = subprocess.run([args.exe, "info", gdp, "--no-forecast"], check=True, capture_output=True, text=True).stdout
        ell = float(re.search(r"length scale: *([0-9.eE+-]+)", info).group(1))
        points = os.path.join(tmp, "dipoles.xyz")
        with open(points, "w") as f:
            for p in dipole_positions(gdp):
                f.write("%r %r %r\n" % tuple(p))
        base = ["--smoothing", repr(first["smoothing"] / ell), "--noise-smoothing", "0", "--beta", repr(first["beta"]),
                "--qmc", str(first["qmc"]), "--voxel-size", repr(first["dx"])]
        subprocess.run([args.exe, "evaluate", gdp, "--at", points, "-o", os.path.join(tmp, "at.csv"), "--quiet"] + base[:6],
                       check=True)
        rows = open(os.path.join(tmp, "at.csv")).read().splitlines()
        column = rows[0].split(",").index("gamma")
        iso = statistics.mean(float(r.split(",")[column]) for r in rows[1:])
        agree = agreement(gdp, os.path.join(tmp, "gpgp_voxels.csv"), base[:6] + ["--qmc", str(first["qmc"]), "--iso", repr(iso)], tmp)
        if args.agreement_only:
            results["inputs"].append({"input": name, "length_scale": ell, "mapped_flags": base + ["--iso", repr(iso)],
                                      "gpgp": {k: first[k] for k in ("voxels", "dx", "iso", "mass", "smoothing")},
                                      "agreement_at_reference_voxels": agree})
            if args.joins:
                results["inputs"][-1]["joins_on_reference_lattice"] = joins(gdp, first, base + ["--iso", repr(iso)] +
                                                                            args.our_args.split(), tmp)
            print(json.dumps(results["inputs"][-1], indent=1))
            continue
        mapped, _ = with_reference_eta(gdp, first, base + ["--iso", repr(iso)], tmp)
        runs = {"gpgp": [first], "reference_mode": [], "defaults": []}
        for k in range(args.repeat):
            if k:
                runs["gpgp"].append(gpgp(gdp))
            for mode, flags in (("reference_mode", mapped), ("defaults", [])):
                r = {"band": ours("band", gdp, flags, tmp),
                     "green": ours("green", gdp, flags, tmp, ["--source", SOURCE]),
                     "geodesic": ours("geodesic", gdp, flags, tmp, ["--source", SOURCE])}
                if not args.no_eigen:
                    r["spectrum"] = ours("spectrum", gdp, flags, tmp, ["-k", "10"])
                runs[mode].append(r)
        g = runs["gpgp"]
        entry = {"input": name, "length_scale": ell, "mapped_flags": mapped, "agreement_at_reference_voxels": agree,
                 "gpgp": {"voxels": first["voxels"], "h": first["dx"], "iso": first["iso"], "mass": first["mass"],
                          "mu_max": first["mu_max"], "smoothing": first["smoothing"],
                          "eigenvalues_grid_units": first.get("eigenvalues_grid_units"),
                          "seconds": {k: median([r["seconds"][k] for r in g if k in r["seconds"]])
                                      for k in ("band", "operators", "green", "fmm_stencils", "fmm_march", "eigen")},
                          "green_iterations": first.get("green_iterations")}}
        for mode in ("reference_mode", "defaults"):
            rs = runs[mode]
            b = rs[0]["band"]
            entry[mode] = {
                "voxels": b["band"]["voxels"], "h": b["band"]["voxel_size"], "mass": b["band"]["mass"],
                "smoothing": b["parameters"].get("smoothing"),
                "seconds": {"band": median([r["band"]["timings_s"]["band"] for r in rs]),
                            "operators": median([r["green"]["timings_s"]["operators"] for r in rs]),
                            "green": median([r["green"]["timings_s"]["solve"] for r in rs]),
                            "geodesic": median([r["geodesic"]["timings_s"]["solve"] for r in rs]),
                            "eigen": median([r["spectrum"]["timings_s"]["solve"] for r in rs]) if not args.no_eigen else None}}
            if not args.no_eigen:
                entry[mode]["eigenvalues"] = rs[0]["spectrum"]["spectrum"]["eigenvalues"]
        results["inputs"].append(entry)
        print(json.dumps(entry, indent=1))
os.makedirs(os.path.dirname(args.out), exist_ok=True)
json.dump(results, open(args.out, "w"), indent=1)
print("wrote", args.out)
