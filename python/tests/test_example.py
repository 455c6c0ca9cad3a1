"""examples/noisy_scan.py runs and writes what docs/python.md says it writes."""
import os
import pathlib
import subprocess
import sys

import numpy as np

from conftest import ROOT, read_grid


def test_noisy_scan_example_writes_mu_and_a_geodesic(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, str(ROOT / "examples" / "noisy_scan.py"), str(tmp_path)], env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "geodesic:" in r.stdout and "expected area" in r.stdout
    mu, _ = read_grid(tmp_path / "scan.vdb", "mu")
    geo, _ = read_grid(tmp_path / "scan.vdb", "geodesic")
    assert np.nanmax(mu) > 0 and np.nanmax(geo) > 0
