#!/usr/bin/env python3
"""The product's figures: the demo's wall time and peak memory (with its own per-stage report), and the file size
of a band stored with --half against float32. Writes bench/results/demo.json (or --out)."""
import argparse, json, os, resource, subprocess, tempfile, time

ap = argparse.ArgumentParser()
ap.add_argument("--out", default="bench/results/demo.json")
ap.add_argument("--exe", default="build/bin/gpisvdb")
ap.add_argument("--data", default="data")
args = ap.parse_args()

with tempfile.TemporaryDirectory() as tmp:
    # === The demo at its defaults, as the README runs it
    demo_dir = os.path.join(tmp, "demo-output")
    t0 = time.monotonic()
    subprocess.run([args.exe, "demo", "-o", demo_dir, "--quiet"], check=True)
    wall = time.monotonic() - t0
    peak_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    report = json.load(open(os.path.join(demo_dir, "report.json")))

    # === --half against float32 on the same band
    sizes = {}
    for name, extra in (("float32", []), ("half", ["--half"])):
        path = os.path.join(tmp, name + ".vdb")
        subprocess.run([args.exe, "band", os.path.join(args.data, "bunny.obj"), "--sigma", "2", "--voxel-size", "0.4",
                        "--quiet", "-o", path] + extra, check=True)
        sizes[name] = os.path.getsize(path)

out = {
    "command": "python3 bench/bench_demo.py --out " + args.out,
    "demo": {"command": args.exe + " demo -o demo-output", "wall_seconds": round(wall, 2), "peak_rss_kb": peak_kb,
             "report": report},
    "half_float": {"command": args.exe + " band bunny.obj --sigma 2 --voxel-size 0.4 -o OUT.vdb [--half]",
                   "float32_bytes": sizes["float32"], "half_bytes": sizes["half"],
                   "ratio": sizes["half"] / sizes["float32"]},
}
with open(args.out + ".tmp", "w") as f:
    json.dump(out, f, indent=2)
    f.write("\n")
os.replace(args.out + ".tmp", args.out)
print("demo: %.1f s, peak %d KB; --half: %.3f of the float32 file" % (wall, peak_kb, out["half_float"]["ratio"]))
