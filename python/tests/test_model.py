"""Models from numpy and files: evaluate against the command line, and bad inputs refused with typed errors."""
import csv

import numpy as np
import pytest

import gpisvdb
from conftest import SIGMA, SMOOTHING, run_cli


def test_evaluate_equals_the_command_line_csv(model, sphere_obj, tmp_path):
    rng = np.random.default_rng(7)
    points = np.concatenate([rng.uniform(-1.5, 1.5, (40, 3)), 0.95 * rng.standard_normal((40, 3)) / 1.7])
    xyz = tmp_path / "points.xyz"
    np.savetxt(xyz, points, fmt="%.17g")
    out = tmp_path / "values.csv"
    run_cli("evaluate", sphere_obj, "--at", xyz, "-o", out, "--sigma", SIGMA, "--smoothing", SMOOTHING, "--quiet")
    with open(out) as f:
        rows = np.array([[float(v) for v in r] for r in list(csv.reader(f))[1:]])
    got = gpisvdb.Model.from_file(str(sphere_obj), sigma=SIGMA, smoothing=SMOOTHING).evaluate(points)
    upper4 = [(r, c) for r in range(4) for c in range(r, 4)]
    upper3 = [(r, c) for r in range(3) for c in range(r, 3)]
    expected = {
        "mean": rows[:, 3],
        "gradient": rows[:, 4:7],
        "covariance": rows[:, [7 + i for i in range(10)]],
        "mu": rows[:, 17],
        "T": rows[:, 18:24],
        "p_inside": rows[:, 24],
    }
    np.testing.assert_array_equal(rows[:, :3], points)
    np.testing.assert_array_equal(got["mean"], expected["mean"])
    np.testing.assert_array_equal(got["gradient"], expected["gradient"])
    np.testing.assert_array_equal(np.array([got["covariance"][:, r, c] for r, c in upper4]).T, expected["covariance"])
    np.testing.assert_array_equal(got["mu"], expected["mu"])
    np.testing.assert_array_equal(np.array([got["T"][:, r, c] for r, c in upper3]).T, expected["T"])
    np.testing.assert_array_equal(got["p_inside"], expected["p_inside"])
    # The model of the arrays is the model of the file.
    direct = model.evaluate(points)
    for key in expected:
        np.testing.assert_array_equal(direct[key], got[key])


def test_evaluate_shapes_and_symmetry(model):
    r = model.evaluate([0.0, 0.0, 1.0])  # one point as a flat triple
    assert r["mean"].shape == (1,) and r["gradient"].shape == (1, 3)
    assert r["covariance"].shape == (1, 4, 4) and r["T"].shape == (1, 3, 3)
    np.testing.assert_allclose(r["covariance"][0], r["covariance"][0].T)
    np.testing.assert_allclose(np.trace(r["T"][0]), 2 * r["mu"][0], rtol=1e-9)
    assert r["mu"][0] > 0


def test_p_inside_is_the_probability_that_phi_exceeds_the_level(model):
    from math import erfc, sqrt
    r = model.evaluate([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 3.0]])
    for i in range(3):  # P(phi > 1/2) for phi ~ N(mean, c00)
        z = (r["mean"][i] - 0.5) / sqrt(r["covariance"][i, 0, 0])
        assert r["p_inside"][i] == pytest.approx(0.5 * erfc(-z / sqrt(2)), abs=1e-15)
    assert r["p_inside"][0] > 0.99 and r["p_inside"][2] < 1e-6  # the unit sphere's centre, and far outside


def test_model_properties_are_in_world_units(model, sphere):
    V, F = sphere
    edges = np.concatenate([V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 1]], V[F[:, 0]] - V[F[:, 2]]])
    assert model.samples == len(F)
    assert model.length_scale == pytest.approx(np.linalg.norm(edges, axis=1).mean(), rel=1e-9)
    assert model.sigma == pytest.approx(SIGMA * model.length_scale)
    assert model.smoothing == pytest.approx(SMOOTHING * model.length_scale)
    assert model.iso == 0.5 and model.kind == "winding" and model.is_soup


def test_inside_out_input_is_flipped_with_a_warning(sphere):
    V, F = sphere
    points = np.array([[0.0, 0.0, 0.0], [0.3, -0.2, 1.1], [2.0, 0.0, 0.0]])
    outward = gpisvdb.Model(V, F)
    with pytest.warns(UserWarning, match="normals point inward"):
        inward = gpisvdb.Model(V, F[:, [0, 2, 1]])
    assert inward.normals_flipped and not outward.normals_flipped
    np.testing.assert_allclose(inward.evaluate(points)["mean"], outward.evaluate(points)["mean"], atol=1e-9)
    assert inward.evaluate(points)["p_inside"][0] > 0.99  # the inside is the enclosed side


def test_input_conversions_give_the_same_model(sphere):
    V, F = sphere
    points = np.array([[0.0, 0.0, 0.9], [0.3, -0.2, 1.1]])
    ref = gpisvdb.Model(V, F).evaluate(points)
    # Non-contiguous, Fortran-ordered, float32-exact integers, int32 faces: converted, same model.
    Vnc = np.zeros((len(V), 6))
    Vnc[:, ::2] = V
    for v, f in [(Vnc[:, ::2], F), (np.asfortranarray(V), F.astype(np.int32)), (V.tolist(), F.tolist())]:
        got = gpisvdb.Model(v, f).evaluate(points)
        np.testing.assert_array_equal(got["mean"], ref["mean"])
        np.testing.assert_array_equal(got["covariance"], ref["covariance"])


def test_cloud_from_numpy_equals_cloud_from_file(tmp_path):
    rng = np.random.default_rng(3)
    P = rng.standard_normal((300, 3))
    P /= np.linalg.norm(P, axis=1)[:, None]
    sig = np.full(300, 0.05)
    xyz = tmp_path / "cloud.xyz"
    np.savetxt(xyz, np.hstack([P, P, sig[:, None]]), fmt="%.17g")
    a = gpisvdb.Model.from_cloud(P, P, sigma=sig)
    b = gpisvdb.Model.from_file(str(xyz))
    assert not a.is_soup and a.samples == 300
    x = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 3.0]])
    np.testing.assert_array_equal(a.evaluate(x)["covariance"], b.evaluate(x)["covariance"])
    # The winding number: 1 inside, 0 outside, half the inside value on the surface (300 points on a unit sphere
    # estimate its area ≈ 20 % low, the flat cylinder's count on a curved surface, so both values are that low).
    model = gpisvdb.Model.from_cloud(P, P, sigma=0.5)
    gamma = model.evaluate(x)["mean"]
    Q = np.random.default_rng(5).standard_normal((200, 3))
    on = model.evaluate(Q / np.linalg.norm(Q, axis=1)[:, None])["mean"]
    assert gamma[0] > 0.75 and abs(gamma[2]) < 0.01 and abs(on.mean() / gamma[0] - 0.5) < 0.05


def test_a_cloud_denser_than_the_kernel_is_merged_into_dipoles_within_the_model_error():
    # 20 000 points with sigma 0.05: s = 1.2 sigma = 0.06 > l = 0.025, so cells of s hold several points each.
    rng = np.random.default_rng(11)
    P = rng.standard_normal((20000, 3))
    P /= np.linalg.norm(P, axis=1)[:, None]
    sig = np.full(len(P), 0.05)
    merged = gpisvdb.Model.from_cloud(P, P, sigma=sig)
    every = gpisvdb.Model.from_cloud(P, P, sigma=sig, merge=0)
    assert merged.samples == every.samples == 20000
    assert merged.model_samples < 20000 / 3 and every.model_samples == 20000
    Q = rng.standard_normal((200, 3))
    x = (1 + 0.1 * rng.uniform(-1, 1, (200, 1))) * Q / np.linalg.norm(Q, axis=1)[:, None]
    a, b = merged.evaluate(x), every.evaluate(x)
    assert np.max(np.abs(a["mean"] - b["mean"])) < 0.01
    assert np.max(np.abs(a["gradient"] - b["gradient"])) < 0.01 * np.max(np.abs(b["gradient"]))
    with pytest.raises(gpisvdb.ParameterError, match="merge"):
        gpisvdb.Model.from_cloud(P, P, sigma=sig, merge=-1)


@pytest.mark.parametrize(
    "V_F, error, words",
    [
        (lambda V, F: (V[:, :2], F), gpisvdb.InputError, "n x 3"),
        (lambda V, F: (np.where(np.arange(V.size).reshape(V.shape) == 5, np.nan, V), F), gpisvdb.InputError, "V[1] is not finite"),
        (lambda V, F: (V, F.astype(float)), gpisvdb.InputError, "integer"),
        (lambda V, F: (V, F + len(V)), gpisvdb.InputError, "outside"),
        (lambda V, F: (V, -F), gpisvdb.InputError, "outside"),
        (lambda V, F: (V.astype(complex), F), gpisvdb.InputError, "real numbers"),
        (lambda V, F: (np.array(["a", "b", "c"]), F), gpisvdb.InputError, "real numbers"),
        (lambda V, F: (None, F), gpisvdb.InputError, "None"),
        (lambda V, F: (V, F[:, :2]), gpisvdb.InputError, "m x 3"),
        (lambda V, F: (V, np.zeros((0, 3), int)), gpisvdb.InputError, "m x 3"),
    ],
)
def test_bad_arrays_raise_input_error(sphere, V_F, error, words):
    with pytest.raises(error) as e:
        gpisvdb.Model(*V_F(*sphere))
    assert words in str(e.value)
    assert isinstance(e.value, gpisvdb.Error) and isinstance(e.value, ValueError)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"sigma": -1.0}, "(sigma) must be finite and > 0"),
        ({"sigma": float("nan")}, "(sigma)"),
        ({"smoothing": 0.0}, "(smoothing) must be finite and > 0"),
        ({"beta": 0.5}, "(beta)"),
        ({"model": "kriging"}, "'winding' or 'regression'"),
        ({"threads": -1}, "threads must be >= 0"),
    ],
)
def test_bad_parameters_raise_parameter_error_naming_the_keyword(sphere, kwargs, words):
    with pytest.raises(gpisvdb.ParameterError) as e:
        gpisvdb.Model(*sphere, **kwargs)
    assert words in str(e.value)
    assert "::" not in str(e.value)  # the engine's Options fields are translated to keywords


def test_bad_cloud_and_file_inputs(tmp_path):
    P = np.random.default_rng(0).standard_normal((50, 3))
    with pytest.raises(gpisvdb.InputError, match="one normal per point"):
        gpisvdb.Model.from_cloud(P, P[:10])
    with pytest.raises(gpisvdb.InputError, match="zero normal"):
        gpisvdb.Model.from_cloud(P, np.zeros_like(P))
    with pytest.raises(gpisvdb.InputError, match=r"sigma\[0\] must be > 0"):
        gpisvdb.Model.from_cloud(P, P, sigma=np.zeros(50))
    with pytest.raises(gpisvdb.InputError, match="shape"):
        gpisvdb.Model.from_cloud(P, P, area=np.ones(3))
    with pytest.raises(gpisvdb.InputError, match="nonexistent"):
        gpisvdb.Model.from_file(str(tmp_path / "nonexistent.obj"))
    with pytest.raises(gpisvdb.InputError):
        gpisvdb.Model.from_file(str(tmp_path))


def test_bad_query_points(model):
    with pytest.raises(gpisvdb.InputError, match="not finite"):
        model.evaluate([[0.0, np.inf, 0.0]])
    with pytest.raises(gpisvdb.InputError, match="n x 3"):
        model.evaluate(np.zeros((4, 2)))
    with pytest.raises(gpisvdb.ParameterError, match="qmc"):
        model.evaluate(np.zeros((1, 3)), qmc=0)


def test_regression_model_from_labels(sphere):
    V, F = sphere
    labels = np.vstack([np.c_[V, np.zeros(len(V))], np.c_[0.7 * V, np.ones(len(V))], np.c_[1.3 * V, -np.ones(len(V))]])
    m = gpisvdb.Model(V, F, model="regression", labels=labels)
    assert m.kind == "regression" and m.iso == 0.0
    r = m.evaluate(np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 1.6]]))
    assert r["mean"][0] > 0 > r["mean"][1]
    with pytest.raises(gpisvdb.ParameterError, match="model='regression'"):
        gpisvdb.Model(V, F, labels=labels)
