"""lsc.analysis.fit: least-squares recovery of scene parameters from test channels."""

from dataclasses import replace

import numpy as np
import pytest

import lsc
from lsc.analysis import calibrate_force_scale, read_channels
from lsc.analysis.channels import write_csv, write_isomme
from lsc.analysis.filters import cfc_filter
from lsc.analysis.fit import fit, sampled_channels, scene_toml

K, E = 24000.0, 0.4                        # lbf/ft, -
STIFFNESS, RESTITUTION = "contacts.0.loading.stiffness", "contacts.0.unloading.restitution"
PARAMS = [STIFFNESS, RESTITUTION]
T = np.round(np.arange(-200, 2001) / 1e4, 12)   # 10 kHz, 20 ms pre-trigger, 200 ms after contact


def scene(k=K, e=E):
    return lsc.Scene.load({
        "name": "fit test", "units": "US", "g": "32.2 ft/s^2",
        "vehicles": [{"name": "bullet", "weight": 3500, "speed": 10},
                     {"name": "target", "weight": 3000, "speed": 0}],
        "contacts": [{"loading": {"stiffness": k}, "unloading": {"restitution": e}}]})


@pytest.fixture(scope="module")
def measured():
    """The true scene's accelerations as ideal 10 kHz sensors record them (force and
    deformation left out: the fit uses the accelerations alone)."""
    chans = sampled_channels(lsc.solve(scene(), n_samples=40000), T)
    return replace(chans, channels={n: chans[n] for n in ("accel_bullet", "accel_target")})


def wrong_start():
    return scene(1.5 * K, 0.2)


@pytest.mark.parametrize("fmt", ["csv", "isomme"])
def test_fit_recovers_stiffness_and_restitution_without_noise(measured, tmp_path, fmt):
    path = write_csv(measured, tmp_path / "test.csv") if fmt == "csv" else \
        write_isomme(measured, tmp_path / "test.zip")
    f = fit(wrong_start(), read_channels(path), PARAMS)
    assert f.values[STIFFNESS] == pytest.approx(K, rel=1e-6)
    assert f.values[RESTITUTION] == pytest.approx(E, rel=1e-6)
    assert f.initial == {STIFFNESS: 1.5 * K, RESTITUTION: 0.2}
    assert set(f.iso18571) == {"accel_bullet", "accel_target"}
    assert all(r.total > 0.999 for r in f.iso18571.values())
    # the fitted scene is the scene the values describe
    assert f.scene.contacts[0].law.loading.stiffness == f.values[STIFFNESS]
    assert f.result.scene is f.scene


def test_fit_with_filtered_noise_lies_within_two_standard_errors(measured):
    rng = np.random.default_rng(14)
    g = 32.2
    noisy = {n: replace(c, values=c.values + cfc_filter(rng.normal(0.0, 0.1 * g, T.size), 60, 1e4))
             for n, c in measured.channels.items()}
    f = fit(wrong_start(), replace(measured, channels=noisy), PARAMS)
    for path, truth in ((STIFFNESS, K), (RESTITUTION, E)):
        se = f.standard_errors[path]
        assert 0 < se < 0.01 * truth
        assert abs(f.values[path] - truth) < 2 * se
    # the correlation matrix: unit diagonal, symmetric, |r| < 1
    assert np.allclose(np.diag(f.correlation), 1.0)
    assert np.allclose(f.correlation, f.correlation.T)
    assert abs(f.correlation[0, 1]) < 1


def test_independent_errors_understate_those_of_filtered_noise(measured):
    """CFC 60 noise is correlated over ~1 ms: the OLS errors are several times too small."""
    rng = np.random.default_rng(3)
    noisy = {n: replace(c, values=c.values + cfc_filter(rng.normal(0.0, 3.0, T.size), 60, 1e4))
             for n, c in measured.channels.items()}
    chans = replace(measured, channels=noisy)
    hac = fit(scene(), chans, PARAMS)
    ols = fit(scene(), chans, PARAMS, errors="independent")
    assert hac.values[STIFFNESS] == pytest.approx(ols.values[STIFFNESS], rel=1e-9)
    for p in PARAMS:
        assert hac.standard_errors[p] > 2 * ols.standard_errors[p]
    # OLS: cov = SSR/(n - p) (JᵀJ)⁻¹, so sigma² = SSR/dof
    assert ols.sigma ** 2 == pytest.approx(ols.ssr / ols.dof, rel=1e-12)
    assert ols.dof == 2 * np.count_nonzero(T >= 0) - 2


def test_fitted_scene_is_written_as_toml_and_read_back(measured, tmp_path):
    f = fit(wrong_start(), measured, PARAMS)
    text = f.to_toml(tmp_path / "fitted.toml")
    back = lsc.Scene.load(tmp_path / "fitted.toml")
    assert (tmp_path / "fitted.toml").read_text() == text
    assert back.contacts[0].law.loading.stiffness == f.values[STIFFNESS]
    assert back.contacts[0].law.unloading.e == f.values[RESTITUTION]
    assert [v.mass for v in back.vehicles] == [v.mass for v in f.scene.vehicles]


def test_scene_toml_keeps_tables_and_csv_paths(tmp_path):
    (tmp_path / "curve.csv").write_text("0,0\n0.5,6000\n")
    src = {"name": 'quote " and ü', "units": "US",
           "vehicles": [{"name": "a", "weight": "3500 lbf", "speed": 10}, {"name": "b", "mass": 100.0, "speed": 0}],
           "contacts": [{"loading": {"csv": "curve.csv", "scale": 1.1},
                         "unloading": {"table": [[0.5, 100.0], [0.4, 0.0]]}}]}
    sc = lsc.Scene.load(src, base_dir=tmp_path)
    other = tmp_path / "elsewhere"
    other.mkdir()
    scene_toml(sc, other / "s.toml")
    back = lsc.Scene.load(other / "s.toml")
    assert back.name == sc.name
    assert np.array_equal(back.contacts[0].law.loading.f, sc.contacts[0].law.loading.f)
    assert np.array_equal(back.contacts[0].law.unloading.d, sc.contacts[0].law.unloading.d)
    assert back.vehicles[0].mass == sc.vehicles[0].mass


def test_force_channel_and_a_mass_are_fitted(measured):
    chans = sampled_channels(lsc.solve(scene(), n_samples=40000), T)
    start = scene().with_values({"vehicles.1.weight": 3600})
    f = fit(start, chans, ["vehicles.1.weight"], roles=["force"])
    assert f.values["vehicles.1.weight"] == pytest.approx(3000, rel=1e-6)
    assert list(f.residuals) == ["force"]
    assert f.units["vehicles.1.weight"] == "lbf"


def test_fitting_a_table_force_scale_agrees_with_calibrate_force_scale():
    """A 'measured' table that under-reads the force by 1.15: the fit of its scale to the pulses
    and the paper's calibration (common velocity at the table's end) both find 1.15."""
    truth = scene()
    d_max = float(lsc.solve(truth).max_deformation[0])
    chans = sampled_channels(lsc.solve(truth, n_samples=40000), T)
    under = 1.15
    long_table = [[0.0, 0.0], [1.3 * d_max, K * 1.3 * d_max / under]]
    to_fit = truth.with_values({"contacts.0.loading": {"table": long_table}})
    f = fit(to_fit, chans, ["contacts.0.loading.scale"], roles=["accel_bullet", "accel_target"])
    assert f.initial["contacts.0.loading.scale"] == 1.0
    assert f.values["contacts.0.loading.scale"] == pytest.approx(under, rel=1e-6)
    ending = truth.with_values({"contacts.0.loading": {"table": [[0.0, 0.0], [d_max, K * d_max / under]]}})
    assert calibrate_force_scale(ending).factor == pytest.approx(f.values["contacts.0.loading.scale"], rel=1e-6)


def test_dependent_parameters_are_refused(measured):
    """Accelerations alone cannot separate stiffness from the masses (k, m1, m2 all x λ gives the
    same pulses)."""
    with pytest.raises(lsc.SceneError, match="cannot tell the parameters"):
        fit(scene(), measured, [STIFFNESS, "vehicles.0.weight", "vehicles.1.weight"])


@pytest.mark.parametrize("kwargs, match", [
    ({"params": ["vehicles.0.colour"]}, "colour"),
    ({"params": "contacts.0.loading.stiffness"}, "a list of dotted scene paths"),
    ({"params": PARAMS, "bounds": {RESTITUTION: (0.5, 1.0)}}, "strictly inside the bounds"),
    ({"params": PARAMS, "roles": ["force"]}, "no acceleration or force channel for"),
    ({"params": PARAMS, "errors": "robust"}, "autocorrelated, independent"),
    ({"params": PARAMS, "window": (0.1, 0.5)}, "must lie inside the record"),
    ({"params": PARAMS, "initial": {"vehicles.0.speed": 3}}, "not fitted parameters"),
])
def test_bad_arguments_raise_scene_errors(measured, kwargs, match):
    with pytest.raises(lsc.SceneError, match=match):
        fit(scene(), measured, **kwargs)


def test_a_failing_simulation_names_the_parameters(measured):
    short = scene().with_values({"contacts.0.loading": {"table": [[0.0, 0.0], [0.1, 2400.0]]}})
    with pytest.raises(lsc.SimulationError, match=r"contacts.0.loading.scale = 1\b"):
        fit(short, measured, ["contacts.0.loading.scale"])
