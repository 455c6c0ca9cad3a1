"""The tasks on a band from Python, each against the command line's result on the same input or its defining
property."""
import json
import re

import numpy as np
import pytest

import gpisvdb
from conftest import FLAGS, VOXEL, at_coords, read_grid, run_cli

SOURCE, TARGET = (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)


def test_green_equals_the_command_line(band, sphere_obj, tmp_path):
    g = band.green(SOURCE)
    assert g["solver"]["converged"]
    assert g["source_index"] == band.nearest(SOURCE)
    run_cli("green", sphere_obj, "--source", "%g,%g,%g" % SOURCE, "-o", tmp_path / "green.vdb",
            "--report", tmp_path / "green.json", *FLAGS)
    dense, lo = read_grid(tmp_path / "green.vdb", "green")
    np.testing.assert_array_equal(at_coords(dense, lo, band.coords), g["values"])
    # The command's solver section (app::solverReport), with `converged`
    cli = json.load(open(tmp_path / "green.json"))["solver"]
    assert set(g["solver"]) - set(cli) == {"converged"}
    assert {k: g["solver"][k] for k in cli} == cli
    # Symmetric about its source: largest there.
    assert np.argmax(g["values"]) == g["source_index"]


def test_green_multigrid_equals_jacobi_within_the_tolerance_and_matches_the_command_line(band, sphere_obj, tmp_path):
    jacobi = band.green(SOURCE, preconditioner="jacobi")
    multigrid = band.green(SOURCE, preconditioner="multigrid")
    assert jacobi["solver"]["preconditioner"] == "Jacobi"
    assert multigrid["solver"]["preconditioner"] == "multigrid"
    assert multigrid["solver"]["converged"]
    assert multigrid["solver"]["iterations"] < jacobi["solver"]["iterations"]
    # Two solutions at relative residual 1e-6: within a few 1e-5 of each other (the conditioning of L here).
    scale = np.linalg.norm(jacobi["values"])
    assert np.linalg.norm(multigrid["values"] - jacobi["values"]) <= 5e-5 * scale
    run_cli("green", sphere_obj, "--source", "%g,%g,%g" % SOURCE, "-o", tmp_path / "green.vdb",
            "--preconditioner", "multigrid", *FLAGS)
    dense, lo = read_grid(tmp_path / "green.vdb", "green")
    np.testing.assert_array_equal(at_coords(dense, lo, band.coords), multigrid["values"])
    aggregation = band.green(SOURCE, preconditioner="aggregation")
    assert aggregation["solver"]["preconditioner"] == "aggregation"
    assert aggregation["solver"]["iterations"] < jacobi["solver"]["iterations"]
    assert np.linalg.norm(aggregation["values"] - jacobi["values"]) <= 5e-5 * scale
    with pytest.raises(gpisvdb.ParameterError):
        band.green(SOURCE, preconditioner="amg")


def test_geodesic_equals_the_command_line_and_its_path_joins_target_to_source(band, sphere_obj, tmp_path):
    g = band.geodesic(SOURCE, TARGET)
    assert g["distance"].shape == (len(band),) and g["unreached"] == 0
    assert g["distance"][g["source_index"][0]] == 0
    run_cli("geodesic", sphere_obj, "--source", "%g,%g,%g" % SOURCE, "--target", "%g,%g,%g" % TARGET,
            "-o", tmp_path / "geo.vdb", "--paths", tmp_path / "path.json", *FLAGS)
    dense, lo = read_grid(tmp_path / "geo.vdb", "geodesic")
    np.testing.assert_array_equal(at_coords(dense, lo, band.coords), g["distance"].astype(np.float32))
    (path,) = g["paths"]
    assert g["reached_source"][0]
    np.testing.assert_allclose(path[0], band.world[g["target_index"][0]])
    np.testing.assert_allclose(path[-1], band.world[g["source_index"][0]])
    # Pole to pole on the unit sphere: about half a great circle, pi.
    assert g["path_length"][0] == pytest.approx(np.pi, rel=0.1)
    cli = json.load(open(tmp_path / "path.json"))
    cli_path = cli["paths"][0]["points"] if isinstance(cli, dict) else cli[0]["points"]
    np.testing.assert_allclose(np.array(cli_path), path, rtol=1e-12)


def test_spectrum_is_m_orthonormal_and_equals_the_command_line(band, sphere_obj, tmp_path):
    values, vectors, info = band.spectrum(6)
    assert values.shape == (6,) and vectors.shape == (len(band), 6)
    assert np.all(np.diff(values) >= 0)
    M = band.mu.astype(np.float64) * band.voxel_size ** 3
    np.testing.assert_allclose(vectors.T @ (M[:, None] * vectors), np.eye(6), atol=1e-6)
    run_cli("spectrum", sphere_obj, "-k", 6, "-o", tmp_path / "s.vdb", "--report", tmp_path / "s.json", *FLAGS)
    np.testing.assert_allclose(values, json.load(open(tmp_path / "s.json"))["spectrum"]["eigenvalues"], rtol=1e-9)
    # The unit sphere: lambda_1..3 - lambda_0 about l(l+1) = 2 (docs/spectrum.md).
    np.testing.assert_allclose(values[1:4] - values[0], 2, rtol=0.2)
    assert max(info["residuals"]) < 1e-6


def test_spectrum_by_lobpcg_equals_lanczos_and_the_command_line(band, sphere_obj, tmp_path):
    lanczos, _, info_l = band.spectrum(4, method="lanczos")
    lobpcg, _, info_b = band.spectrum(4, method="lobpcg")
    assert info_l["method"] == "lanczos" and info_b["method"] == "lobpcg" and info_b["iterations"] > 0
    np.testing.assert_allclose(lobpcg, lanczos, rtol=1e-6)
    run_cli("spectrum", sphere_obj, "-k", 4, "--eigen-method", "lobpcg", "-o", tmp_path / "s.vdb",
            "--report", tmp_path / "s.json", *FLAGS)
    report = json.load(open(tmp_path / "s.json"))["spectrum"]
    assert report["method"].startswith("LOBPCG")
    np.testing.assert_allclose(report["eigenvalues"], lobpcg, rtol=1e-9)
    with pytest.raises(gpisvdb.ParameterError):
        band.spectrum(4, method="arpack")


def test_eigen_max_voxels_is_the_spectrum_and_regress_commands_default_budget():
    assert gpisvdb.EIGEN_MAX_VOXELS == 3e5
    for command in ("spectrum", "regress"):
        assert "--max-voxels FLOAT=300000 " in run_cli(command, "--help").stdout


def test_regression_interpolates_exact_data(band):
    rng = np.random.default_rng(5)
    idx = rng.choice(np.flatnonzero(band.mu > np.median(band.mu)), 12, replace=False)
    points = band.world[idx]
    values = points[:, 2]
    r = band.regress(points, values, k=30)
    np.testing.assert_allclose(r["mean_at_data"], values, atol=1e-4)
    assert np.all(r["variance"] >= 0) and r["mean"].shape == (len(band),)
    with pytest.raises(gpisvdb.InputError, match="shape"):
        band.regress(points, values[:3])


def test_hodge_parts_sum_to_the_field_and_the_rotation_is_free(band):
    h = band.hodge("mixed")
    np.testing.assert_allclose(h["gradient"] + h["free"], h["input"], atol=1e-5)
    assert h["solver"]["converged"] and h["divergence_residual"] < 1e-3
    assert abs(h["s_inner_product"]) < 1e-4  # the parts are orthogonal in the S inner product (docs/hodge.md)
    # A rotation about z is mostly free (the sphere is a faceted soup, not exactly one of revolution); the gradient
    # of the height mostly a gradient.
    rot, grad = band.hodge("rotation"), band.hodge("gradient")
    assert np.linalg.norm(rot["free"]) > 1.5 * np.linalg.norm(rot["gradient"])
    assert np.linalg.norm(grad["gradient"]) > 3 * np.linalg.norm(grad["free"])
    with pytest.raises(gpisvdb.InputError, match=r"\(%d, 3\)" % len(band)):
        band.hodge(np.zeros((3, 3)))
    with pytest.raises(gpisvdb.ParameterError, match="preset|rotation"):
        band.hodge("spiral")


def test_smoothed_distance_grows_away_from_the_sphere(band):
    d = band.smoothed_distance(20.0, grid_voxel_size=0.1)
    values, H, origin = d["values"], d["voxel_size"], np.array(d["origin"])
    assert H == pytest.approx(0.1)
    centre = np.round((np.zeros(3) - origin) / H).astype(int)
    corner = values[0, 0, 0]
    on_surface = values[tuple(centre + np.array([0, 0, 10]))]  # (0, 0, 1)
    assert on_surface < values[tuple(centre)] and on_surface < corner
    with pytest.raises(gpisvdb.ParameterError, match="alpha"):
        band.smoothed_distance(-1.0)


def test_smoothed_distance_refuses_a_grid_beyond_max_memory_naming_the_grid_voxel_size_that_fits(model):
    # The grid's memory as the command estimates it (k-d tree, values, dense grid), against what max_memory leaves
    # beside the band: a 0.01 grid (about 2e7 points) needs far more than the 6 MB left, the size it names fits
    # (a coarse tolerance keeps that run short; the memory does not depend on it).
    small = gpisvdb.band(model, voxel_size=VOXEL, max_memory=9e6)
    with pytest.raises(gpisvdb.MemoryLimitError) as e:
        small.smoothed_distance(20.0, grid_voxel_size=0.01, tolerance=0.05)
    message = str(e.value)
    assert "(max_memory)" in message and "grid voxel size (grid_voxel_size) of" in message
    fits = float(re.search(r"grid voxel size \(grid_voxel_size\) of ([0-9.e+-]+)", message).group(1))
    assert 0.01 < fits < 0.1
    d = small.smoothed_distance(20.0, grid_voxel_size=fits, tolerance=0.05)
    assert d["voxel_size"] == pytest.approx(fits)


def test_surfaces_equal_the_command_line_draw_for_draw(band, sphere_obj, tmp_path):
    draws = band.surfaces(3, seed=9)
    assert len(draws) == 3
    for V, F in draws:
        assert len(F) > 100 and F.max() < len(V)
        assert 0.7 < np.linalg.norm(V, axis=1).mean() < 1.2  # near the unit sphere
    assert not np.array_equal(draws[0][0], draws[1][0])
    V2, F2 = band.surfaces(1, seed=9, first=2)[0]  # draw 2 alone: the same mesh
    np.testing.assert_array_equal(V2, draws[2][0])
    np.testing.assert_array_equal(F2, draws[2][1])
    run_cli("surfaces", sphere_obj, "-n", 3, "--seed", 9, "-o", tmp_path / "draws", *FLAGS)
    with open(tmp_path / "draws" / "surface_0002.ply", "rb") as f:
        header = f.read(300)
    assert b"draw 2 of seed 9" in header
    assert re.search(rb"element vertex (\d+)", header).group(1) == str(len(V2)).encode()  # the same band, the same mesh
    with pytest.raises(gpisvdb.ParameterError):
        band.surfaces(0)


def test_query_rays_and_collision_equal_the_command_line(model, sphere_obj, tmp_path):
    origins = np.array([[0, 0, 2.5], [0, 0, 0], [-2.5, 0, 3.0]])
    directions = np.array([[0, 0, -1], [0, 0, 1], [1, 0, 0]])
    lengths = np.array([2.5, 2.0, 5.0])
    r = model.query_rays(origins, directions, lengths)
    assert r["p_hit"][0] > 0.999 and 0.8 < r["hit_distance"][0] < 1.6  # down onto the sphere's top
    assert r["p_inside_origin"][1] > 0.999 and r["hit_distance"][1] < 1e-6  # inside at the origin: a hit at 0
    assert r["p_hit"][2] < 1e-9 and np.isnan(r["hit_distance"][2])  # passing far above
    rays = tmp_path / "rays.csv"
    np.savetxt(rays, np.c_[origins, directions, lengths], delimiter=",")
    run_cli("query", sphere_obj, "--rays", rays, "-o", tmp_path / "hits.csv", *[f for f in FLAGS if f != "--voxel-size" and f != str(VOXEL)])
    cli = np.genfromtxt(tmp_path / "hits.csv", delimiter=",", names=True)
    np.testing.assert_allclose(cli["p_hit"], r["p_hit"], atol=1e-12)
    np.testing.assert_allclose(cli["hit_distance"][:2], r["hit_distance"][:2], atol=1e-12)
    V = np.array([[-0.1, 0, 0], [0.1, 0, 0], [0, 0.1, 0]])
    c = model.collision(V, np.array([[0, 1, 2]]), draws=50)
    assert c["p_collision"] == 1.0 and c["standard_error"] == 0 and c["points"] >= 3
    with pytest.raises(gpisvdb.InputError):
        model.query_rays(origins, directions[:2], lengths)


def test_mean_surface_lies_on_the_sphere_and_carries_channels(band):
    V, F, values = band.mean_surface()
    assert len(F) > 100 and F.max() < len(V)
    r = np.linalg.norm(V, axis=1)
    assert r.min() > 0.85 and r.max() < 1.02  # inside the unit sphere: the mean surface of an inscribed soup
    assert set(values) == {"mu", "stddev"} and values["mu"].shape == (len(V),)
    V2, F2, extra = band.mean_surface(channels={"z": band.world[:, 2], "mean": band.mean})
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_allclose(extra["z"], V2[:, 2], atol=1e-4)  # a linear field is interpolated exactly
    np.testing.assert_allclose(extra["mean"], band.iso, atol=0.01)  # the vertices lie on gamma = u
