#!/usr/bin/python3
"""Plots the Dirichlet-energy validation (paper Fig. 6 top) from bench/results/energy*.json.

Usage: bench/plot_energy.py [--out docs/images/energy.png] [--footer TEXT]   (needs Debian's python3-matplotlib)
(bench/plots.py calls it with a footer naming the machine, threads and commands.)
"""
import argparse
import json
import os
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

parser = argparse.ArgumentParser()
parser.add_argument("--out", default="docs/images/energy.png")
parser.add_argument("--footer", default=None, help="text line(s) below the axes")
args = parser.parse_args()

runs = [("bench/results/energy.json", "h = h* (Eq. 25)", "-"), ("bench/results/energy_fine.json", "h = 1.5 w_mu", "--")]
fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=120)
for path, label, style in runs:
    if not os.path.exists(path):
        continue
    rows = json.load(open(path))["rows"]
    sigma = [r["sigma_rel"] for r in rows]
    ax.loglog(sigma, [abs(r["x1"]["L_error_vs_mean_surface"]) for r in rows], "o" + style, color="C0",
              label="L (adaptive stencil), " + label)
    ax.loglog(sigma, [abs(r["x1"]["naive_error_vs_mean_surface"]) for r in rows], "s" + style, color="C3",
              label="naive D_phi G_phi, " + label)
ax.set_xlabel("sigma_rel (vertex noise / mean edge length)")
ax.set_ylabel("|relative error| of f^T A f, f = x1")
ax.set_title("Expected Dirichlet energy on a unit-sphere soup (1280 triangles)\n"
             "reference: cotan energy on the mean surface; eta = 1e-6", fontsize=9)
ax.invert_xaxis()
ax.grid(True, which="both", alpha=0.3)
ax.legend(fontsize=7)
if args.footer:
    text = textwrap.fill(args.footer, width=int(fig.get_size_inches()[0] * 72 / (6.5 * 0.55)))
    fig.tight_layout(rect=(0, (0.12 + (text.count("\n") + 1) * 0.125) / fig.get_size_inches()[1], 1, 1))
    fig.text(0.01, 0.01, text, fontsize=6.5, ha="left", va="bottom", color="0.25", family="DejaVu Sans Mono")
else:
    fig.tight_layout()
fig.savefig(args.out)
print("wrote", args.out)
