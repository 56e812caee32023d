"""lsc.analysis.fit: least-squares recovery of scene parameters from test channels."""

from dataclasses import replace

import numpy as np
import pytest

import lsc
from lsc.analysis import calibrate_force_scale, read_channels
from lsc.analysis.channels import write_csv, write_isomme
from lsc.analysis.filters import cfc_filter
from lsc.analysis.fit import fit, sampled_channels, scene_toml
from helpers import HARD, have_diffrax

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


# ---------------------------------------------------------------------- the Jacobian by autodiff
needs_diffrax = pytest.mark.skipif(not have_diffrax(), reason="diffrax (the [jax] extra) is not installed")


@needs_diffrax
def test_autodiff_jacobian_of_the_sampled_channels_matches_central_differences():
    """d(sampled channel)/d(parameter) by autodiff through the diffrax solve against central
    differences of the same sampled channels. A 0.05 ft gap puts first contact at 5 ms, so the
    samples (time from first contact) move with the speed through the contact's event time; the
    maximum deformation and separation move with all three. Central differences of relative step
    1e-4 are good to ~1e-8 of a column's scale where the channel is smooth (truncation, h²); the
    solve's own noise (its steps move with the parameters: ~1e-9 of a channel's scale) over the
    step makes ~1e-5, the measured largest difference 2e-5; the samples at 10 kHz lie much further
    from the events than the events move over the step (~1e-5 x 0.1 s), so no sample straddles a
    kink. Tolerance: 1e-4 of each column's largest value (an event time's derivative left out, or
    halved, as a clipped sample time did, is off by O(1))."""
    base = scene().with_values({"contacts.0.gap": 0.05})
    values, jac, info = _central_differences_agree(base, [STIFFNESS, RESTITUTION, "vehicles.0.speed"],
                                                   np.array([K, E, 10.0]), 1e-4)
    assert info["first_contact"] == pytest.approx(0.05 / 10.0, rel=1e-9)
    truth = lsc.solve(base, "diffrax", n_samples=40000)
    tau = T[T >= 0]
    assert np.allclose(values[0], np.interp(tau, truth.t - info["first_contact"], truth.a[:, 0],
                                            right=0.0),
                       rtol=0, atol=1e-6 * np.max(np.abs(truth.a[:, 0])))
    # the accelerations of a linear loading scale with the closing speed: v ∂a/∂v = a
    assert np.allclose(10.0 * jac[:2, :, 2], values[:2], rtol=0, atol=1e-8 * np.max(np.abs(values)))


def _central_differences_agree(base, paths, x0, tol):
    """The autodiff derivatives of both accelerations and the force on 200 ms at 10 kHz against
    central differences (relative step 1e-4) of the same channels, to ``tol`` of each column's
    largest value."""
    from lsc.model import HybridModel
    from lsc.parameters import tangent
    from lsc.solvers.diffrax_ode.series import sampled_jacobian

    tau = T[T >= 0]

    def channels(x):
        model = HybridModel(base.with_values(dict(zip(paths, x))))
        tangents = [tangent(model, p, v) for p, v in zip(paths, x)]
        return sampled_jacobian(model, tangents, tau, accel=(0, 1), force=(0,))

    values, jac, info = channels(x0)
    for j in range(len(paths)):
        h = 1e-4 * x0[j]
        up, down = x0.copy(), x0.copy()
        up[j] += h
        down[j] -= h
        central = (channels(up)[0] - channels(down)[0]) / (2 * h)
        assert np.max(np.abs(central)) > 0
        for row in range(3):
            scale = np.max(np.abs(central[row]))
            if scale == 0:   # a channel this parameter does not reach within the window
                scale = 1e-8 * np.max(np.abs(values[row])) / x0[j]
            assert np.max(np.abs(jac[row, :, j] - central[row])) < tol * scale, (paths[j], row)
    return values, jac, info


@needs_diffrax
@pytest.mark.skipif(not HARD, reason="hard-case mode (--hard): one more compile")
def test_autodiff_jacobian_through_table_breakpoints_matches_central_differences():
    """A loading table (two breakpoints on the way up), a gap, and a table scale, a restitution,
    a speed and a weight: the tangents go through every event's transition (each breakpoint's
    next segment, D_max, separation). Tolerance as above (measured: 4e-5)."""
    base = lsc.Scene.load({
        "units": "US", "g": "32.2 ft/s^2",
        "vehicles": [{"name": "a", "weight": 3500, "speed": 10}, {"name": "b", "weight": 3000, "speed": 0}],
        "contacts": [{"loading": {"table": [[0, 0], [0.2, 3000], [0.4, 9000], [0.8, 20000]]},
                      "unloading": {"restitution": 0.4}, "gap": 0.02}]})
    paths = ["contacts.0.loading.scale", RESTITUTION, "vehicles.0.speed", "vehicles.1.weight"]
    _central_differences_agree(base, paths, np.array([1.0, 0.4, 10.0, 3000.0]), 1e-4)


_CARS = [{"name": "a", "weight": 3500, "speed": 10}, {"name": "b", "weight": 3000, "speed": 0}]
_IFD = {"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}
_OTHER_MODELS = {   # scene, paths, values (measured largest difference: 3e-8, 1.3e-5, 2.1e-5)
    "hunt-crossley (work integral, nonlinear events)": (
        [{"law": "hunt-crossley", "stiffness": 30000, "restitution": 0.5}], _CARS,
        ["vehicles.0.speed", "vehicles.1.weight"], [10.0, 3000.0]),
    "three-car chain, second contact with a gap": (
        [_IFD, {"loading": {"stiffness": 20000}, "unloading": {"restitution": 0.3}, "gap": 0.1}],
        _CARS + [{"name": "c", "weight": 2500, "speed": 0}],
        [STIFFNESS, "contacts.1.unloading.restitution", "vehicles.0.speed"], [K, 0.3, 10.0]),
    "braked target": ([_IFD], [_CARS[0], dict(_CARS[1], brake={"mu": 0.7})],
                      [STIFFNESS, "vehicles.0.speed"], [K, 10.0]),
}


@needs_diffrax
@pytest.mark.skipif(not HARD, reason="hard-case mode (--hard): one more compile each")
@pytest.mark.parametrize("name", list(_OTHER_MODELS))
def test_autodiff_jacobian_of_other_models_matches_central_differences(name):
    contacts, vehicles, paths, x0 = _OTHER_MODELS[name]
    base = lsc.Scene.load({"units": "US", "g": "32.2 ft/s^2", "vehicles": vehicles,
                           "contacts": contacts})
    _central_differences_agree(base, paths, np.array(x0), 1e-4)


@needs_diffrax
def test_fit_on_diffrax_takes_its_jacobian_by_autodiff_and_recovers_k_and_e(measured):
    f = fit(wrong_start(), measured, PARAMS, method="diffrax")
    assert f.jacobian.startswith("forward-mode autodiff through the diffrax solve")
    assert f.values[STIFFNESS] == pytest.approx(K, rel=1e-6)
    assert f.values[RESTITUTION] == pytest.approx(E, rel=1e-6)
    assert f.njev > 0 and f.nfev < 30        # one solve per point, no finite-difference solves
    assert all(r.total > 0.999 for r in f.iso18571.values())
    assert f.result.scene is f.scene and f.method.startswith("diffrax")
    # the same fit by finite differences of the diffrax solve finds the same values
    fd = fit(wrong_start(), measured, PARAMS, method="diffrax", jac="2-point")
    assert fd.jacobian.startswith("finite differences (2-point)")
    for p in PARAMS:
        assert fd.values[p] == pytest.approx(f.values[p], rel=1e-7)


def test_jacobian_choice_is_checked_and_said(measured):
    with pytest.raises(lsc.SceneError, match="one of 'autodiff', '2-point', '3-point'"):
        fit(scene(), measured, PARAMS, jac="cs")
    with pytest.raises(lsc.SceneError, match=r"jac='autodiff' does not apply: autodiff needs "
                                             r"method='diffrax' \(this fit: closed-form\)"):
        fit(scene(), measured, PARAMS, jac="autodiff")
    if have_diffrax():   # refused before anything is solved
        with pytest.raises(lsc.SceneError, match="the Kvaerno5 integrator is implicit"):
            fit(scene(), measured, PARAMS, method="diffrax", integrator="Kvaerno5", jac="autodiff")
    f = fit(wrong_start(), measured, PARAMS)
    assert f.jacobian == ("finite differences (2-point) of lsc.solve; autodiff needs "
                          "method='diffrax' (this fit: closed-form)")
