"""The band from Python: equal to the command line's and to the band of the same file, channels as views, .vdb
output read back by pyopenvdb, thread-count independence, Ctrl-C, typed errors."""
import _thread
import json
import os
import signal
import threading
import time

import numpy as np
import pytest

import gpisvdb
from conftest import FLAGS, SIGMA, SMOOTHING, VOXEL, at_coords, read_grid, run_cli

CHANNELS = ["coords", "mu", "mean", "stddev", "T", "normal", "stencil_width"]


def test_band_from_numpy_equals_band_from_the_same_file(band, sphere_obj):
    other = gpisvdb.band(gpisvdb.Model.from_file(str(sphere_obj), sigma=SIGMA, smoothing=SMOOTHING), voxel_size=VOXEL)
    assert len(other) == len(band) > 1000
    for name in CHANNELS:
        np.testing.assert_array_equal(getattr(other, name), getattr(band, name), err_msg=name)
    assert other.mass == band.mass


def test_channels_are_read_only_views_with_documented_shapes_and_units(band):
    n = len(band)
    shapes = {"coords": (n, 3), "world": (n, 3), "mu": (n,), "mean": (n,), "stddev": (n,), "T": (n, 6),
              "normal": (n, 3), "stencil_width": (n,)}
    for name, shape in shapes.items():
        assert getattr(band, name).shape == shape, name
    assert band.coords.dtype == np.int32 and band.mu.dtype == np.float32 and band.stencil_width.dtype == np.uint8
    np.testing.assert_array_equal(band.world, band.voxel_size * band.coords)
    assert band.voxel_size == VOXEL
    # tr T = 2 mu (docs/math.md#kac-rice), mass = sum mu h^3 close to the sphere's area.
    np.testing.assert_allclose(band.T[:, :3].sum(axis=1), 2 * band.mu, rtol=1e-4, atol=1e-6)
    assert band.mass == pytest.approx(float(np.sum(band.mu.astype(np.float64)) * VOXEL ** 3), rel=1e-6)
    V, F = _sphere()
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
    assert band.mass == pytest.approx(area, rel=0.1)  # the expected area: the soup's, within 10 % on this coarse grid
    assert np.all(band.stencil_width >= 1)
    np.testing.assert_allclose(np.linalg.norm(band.normal, axis=1), 1, atol=1e-5)
    # Outward normals on a sphere about the origin.
    assert np.mean(np.sum(band.normal * band.world, axis=1) > 0) > 0.99
    with pytest.raises(ValueError):
        band.mu[0] = 1  # a view on the engine's band: read-only
    # A view keeps the band alive.
    mu = gpisvdb.band(gpisvdb.Model(*_small_sphere()), voxel_size=0.2).mu
    assert np.all(np.isfinite(mu))


def _small_sphere():
    from conftest import icosphere
    return icosphere(1)


def _sphere():
    from conftest import icosphere
    return icosphere()


def test_report_matches_the_command_line_report(band, sphere_obj, tmp_path):
    run_cli("band", sphere_obj, "-o", tmp_path / "cli.vdb", "--report", tmp_path / "cli.json", *FLAGS)
    cli = json.load(open(tmp_path / "cli.json"))
    r = band.report
    assert r["band"]["voxels"] == cli["band"]["voxels"] == len(band)
    assert r["band"]["mass"] == pytest.approx(cli["band"]["mass"], rel=1e-12)
    for key in ["sigma", "smoothing", "iso", "eta", "voxel_size", "h_star", "mu_width", "qmc_samples"]:
        assert r["parameters"][key] == pytest.approx(cli["parameters"][key], rel=1e-12), key
    # One report for both (app::bandReport): every key of the command's sections, and Python's few of its own
    for section in ["input", "parameters", "band", "memory"]:
        assert set(cli[section]) <= set(r[section]), section
    assert set(r["input"]) - set(cli["input"]) == {"source"}
    assert set(r["band"]) - set(cli["band"]) == {"bytes_per_voxel"}
    assert r["warnings"] == cli["warnings"] == []


def test_report_warns_in_keywords(model):
    r = gpisvdb.band(model, voxel_size=VOXEL, qmc=64).report
    assert len(r["warnings"]) == 1 and r["warnings"][0].startswith("qmc=64 is below 512")


def test_write_vdb_is_read_back_by_pyopenvdb_and_equals_the_command_line_file(band, sphere_obj, tmp_path):
    ours, theirs = tmp_path / "py.vdb", tmp_path / "cli.vdb"
    band.write_vdb(str(ours))
    run_cli("band", sphere_obj, "-o", theirs, *FLAGS)
    import pyopenvdb
    grids, meta = pyopenvdb.readAll(str(ours))
    names = {g.name for g in grids}
    assert {"mu", "mean", "stddev", "T_diag", "T_offdiag", "normal", "stencil_width", "density"} <= names
    assert meta["iso"] == 0.5 and meta["voxel_size"] == VOXEL
    for name, ref in [("mu", band.mu), ("mean", band.mean), ("stddev", band.stddev), ("T_diag", band.T[:, :3]),
                      ("normal", band.normal)]:
        dense, lo = read_grid(ours, name)
        np.testing.assert_array_equal(at_coords(dense, lo, band.coords), ref, err_msg=name)
        cli_dense, cli_lo = read_grid(theirs, name)
        np.testing.assert_array_equal(at_coords(cli_dense, cli_lo, band.coords), ref, err_msg="cli " + name)
    mu_grid = pyopenvdb.read(str(ours), "mu")
    assert mu_grid.activeVoxelCount() == len(band)
    assert mu_grid.transform.voxelSize()[0] == pytest.approx(VOXEL)
    # One metadata writer for both front ends (app/band_metadata.h): the same keys and values but the command's
    cli_meta = pyopenvdb.readAll(str(theirs))[1]
    provenance = {"command_line", "input"}
    assert {k: v for k, v in meta.items() if k not in provenance} == {
        k: v for k, v in cli_meta.items() if k not in provenance}
    assert meta["command_line"] == "python: gpisvdb.band"


def test_write_vdb_records_the_regression_model(sphere, tmp_path):
    V, F = sphere
    labels = np.vstack([np.c_[V, np.zeros(len(V))], np.c_[0.7 * V, np.ones(len(V))], np.c_[1.3 * V, -np.ones(len(V))]])
    m = gpisvdb.Model(V, F, model="regression", labels=labels, label_noise=0.02)
    gpisvdb.band(m, voxel_size=VOXEL).write_vdb(str(tmp_path / "regression.vdb"))
    import pyopenvdb
    meta = pyopenvdb.readAll(str(tmp_path / "regression.vdb"))[1]
    assert meta["model"] == "regression"
    assert meta["training_labels"] == len(labels) and meta["label_noise"] == pytest.approx(0.02)
    assert "labels" not in meta  # given as an array, not a file


def test_write_vdb_names_the_occupancy_and_writes_nanovdb(band, tmp_path):
    import pyopenvdb
    band.write_vdb(str(tmp_path / "fog.vdb"), fog_name="occupancy")
    grids, meta = pyopenvdb.readAll(str(tmp_path / "fog.vdb"))
    fog = {g.name: g for g in grids}["occupancy"]
    assert fog.gridClass == "fog volume" and meta["occupancy_grid"] == "occupancy"
    assert fog.activeVoxelCount() > len(band)  # the band and the region it encloses
    lo, hi = fog.evalMinMax()
    assert 0 <= lo and hi == 1
    band.write_vdb(str(tmp_path / "plain.vdb"), fog_name="")
    assert "density" not in {g.name for g in pyopenvdb.readAll(str(tmp_path / "plain.vdb"))[0]}
    with pytest.raises(gpisvdb.ParameterError, match="fog_name"):
        band.write_vdb(str(tmp_path / "bad.vdb"), fog_name="mu")
    band.write_vdb(str(tmp_path / "band.nvdb"))
    with open(tmp_path / "band.nvdb", "rb") as f:
        assert f.read(8) == b"NanoVDB0"  # NanoVDB's file magic, not OpenVDB's
    assert not (tmp_path / "bad.vdb").exists()


def test_write_vdb_half_channels_and_errors(band, tmp_path):
    path = tmp_path / "extra.vdb"
    band.write_vdb(str(path), half=True, channels={"height": band.world[:, 2]}, vectors={"position": band.world})
    height, lo = read_grid(path, "height")
    np.testing.assert_allclose(at_coords(height, lo, band.coords), band.world[:, 2], atol=2e-3)
    with pytest.raises(gpisvdb.InputError, match=r"one row per band voxel"):
        band.write_vdb(str(tmp_path / "bad.vdb"), channels={"x": np.zeros(3)})
    with pytest.raises(gpisvdb.OutputError, match="does not exist"):
        band.write_vdb(str(tmp_path / "missing" / "b.vdb"))
    assert sorted(os.listdir(tmp_path)) == ["extra.vdb"]  # nothing left by the failures


def test_threads_1_and_2_give_identical_arrays(model):
    one = gpisvdb.band(model, voxel_size=0.12, threads=1)
    two = gpisvdb.band(model, voxel_size=0.12, threads=2)
    for name in CHANNELS:
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name), err_msg=name)
    x = np.random.default_rng(2).uniform(-1.2, 1.2, (200, 3))
    a, b = model.evaluate(x, threads=1), model.evaluate(x, threads=2)
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    ga, gb = one.green([0, 0, 1], threads=1), two.green([0, 0, 1], threads=2)
    np.testing.assert_array_equal(ga["values"], gb["values"])


def test_progress_callback_reports_stages_and_its_exception_stops_the_band(model):
    seen = []
    gpisvdb.band(model, voxel_size=0.12, progress=lambda stage, f: seen.append((stage, f)))
    assert seen and all(0 <= f <= 1 for _, f in seen) and seen[-1] == ("band", 1.0)

    def fail(stage, fraction):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        gpisvdb.band(model, voxel_size=0.12, progress=fail)
    with pytest.raises(gpisvdb.ParameterError, match="callable"):
        gpisvdb.band(model, progress=3)


def _interrupt_after(seconds, how):
    def fire():
        time.sleep(seconds)
        if how == "signal":
            os.kill(os.getpid(), signal.SIGINT)  # a real Ctrl-C
        else:
            _thread.interrupt_main()

    t = threading.Thread(target=fire, daemon=True)
    t.start()
    return t


@pytest.mark.parametrize("how", ["signal", "interrupt_main"])
def test_keyboard_interrupt_stops_a_band_within_a_second_and_leaves_no_file(sphere, tmp_path, how):
    slow = gpisvdb.Model(*sphere, sigma=SIGMA)
    out = tmp_path / "never.vdb"
    # A band of about a million voxels takes tens of seconds on 2 cores: the interrupt must cut it short.
    start = time.monotonic()
    t = _interrupt_after(0.5, how)
    with pytest.raises(KeyboardInterrupt):
        b = gpisvdb.band(slow, voxel_size=0.012)
        b.write_vdb(str(out))
    elapsed = time.monotonic() - start
    t.join()
    assert elapsed < 1.5, f"stopped {elapsed - 0.5:.2f} s after the interrupt"
    assert os.listdir(tmp_path) == []
    # The module is usable afterwards.
    assert len(gpisvdb.band(slow, voxel_size=0.2)) > 0


def test_bad_band_parameters_raise_typed_errors(model):
    with pytest.raises(gpisvdb.ParameterError, match=r"voxel size \(voxel_size\)"):
        gpisvdb.band(model, voxel_size=-1.0)
    with pytest.raises(gpisvdb.ParameterError, match=r"\(eta\)"):
        gpisvdb.band(model, eta=0.0)
    with pytest.raises(gpisvdb.ParameterError, match="qmc"):
        gpisvdb.band(model, qmc=0)
    with pytest.raises(gpisvdb.MemoryLimitError) as e:
        gpisvdb.band(model, voxel_size=0.01, max_memory=1e6)
    assert isinstance(e.value, gpisvdb.ParameterError)
    assert "(max_memory)" in str(e.value) and "voxel size (voxel_size) of" in str(e.value)
    with pytest.raises(gpisvdb.ParameterError, match=r"voxel values \(voxel_values\)"):
        gpisvdb.band(model, voxel_values="centre")
    with pytest.raises(TypeError):
        gpisvdb.band("not a model")


def test_voxel_values_follow_the_budget_and_are_reported(model):
    # the default h is at most 1.25 w_mu: the centres' values; a budget that raises h past 2 w_mu: their means
    # along the axes; a voxel size given keeps the centres' values unless asked
    fine = gpisvdb.band(model)
    assert fine.report["parameters"]["voxel_values"] == "point"
    coarse = gpisvdb.band(model, max_voxels=2000)
    par = coarse.report["parameters"]
    assert par["voxel_size_by_budget"] and par["voxel_size"] > 2 * par["mu_width"]
    assert par["voxel_values"] == "column"
    assert "column values" in par["voxel_size_note"]
    assert gpisvdb.band(model, voxel_size=coarse.voxel_size).report["parameters"]["voxel_values"] == "point"
    column = gpisvdb.band(model, voxel_size=coarse.voxel_size, voxel_values="column")
    assert len(column) == len(coarse) and column.report["band"]["mass"] == pytest.approx(coarse.report["band"]["mass"], rel=1e-12)
