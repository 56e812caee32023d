"""lsc.analysis.max_closing_speed: the paper's bound technique (Table 3) by root finding."""

import numpy as np
import pytest

import lsc
from helpers import paper_scene
from lsc.analysis import max_closing_speed, peak_force
from lsc.curves import Curve

G = 32.2
M = 3500 / G
K_SYS = 1 / (1 / 48000 + 1 / 30000)  # Eq. 11: 18,462 lb/ft


def table3_scene(**changes):
    return paper_scene(**{"contacts.0.loading": {"series": [{"stiffness": 48000}, {"stiffness": 30000}]},
                          "contacts.0.unloading.restitution": 0.8, **changes})


def closed_form_speed(F, k=K_SYS, m1=M, m2=M):
    """F_max = v0 sqrt(k mu)  =>  v0 = F / sqrt(k mu)."""
    return F / np.sqrt(k * m1 * m2 / (m1 + m2))


@pytest.mark.parametrize("method", ["auto", "exact", "scipy"])
def test_table3_rows_and_bound(method):
    b = max_closing_speed(table3_scene(), "5000 lbf", method=method)
    assert [v for v, _ in b.rows] == [4.0, 5.0, 6.0]
    for (v, r), (peak, dv2) in zip(b.rows, [(4007, 3.6), (5009, 4.5), (6011, 5.4)]):
        assert abs(r.peak_force[0] - peak) <= 2
        assert f"{r.delta_v[1]:.1f}" == f"{dv2:.1f}"
    assert b.step_speed == 5.0          # 5009 lb: just above the 5000 lb failure force
    assert b.bound_speed == 6.0         # the paper's conservative upper limit
    assert b.bound_result is b.rows[-1][1]


@pytest.mark.parametrize("method, tol", [("closed-form", 1e-12), ("exact", 1e-12), ("scipy", 1e-6)])
def test_root_matches_closed_form(method, tol):
    b = max_closing_speed(table3_scene(), 5000.0, method=method)
    exact = closed_form_speed(5000.0)
    assert exact == pytest.approx(4.99166, abs=1e-5)
    assert b.speed == pytest.approx(exact, rel=tol)
    assert b.closing_speed == pytest.approx(b.speed, rel=1e-15)
    assert b.result.peak_force[0] == pytest.approx(5000.0, rel=max(tol, 1e-9))
    # the crash at the root: ΔV2 = (1+e) m1 v0/(m1+m2), peak accelerations F/m in g
    assert b.result.delta_v[1] == pytest.approx(1.8 * exact / 2, rel=max(tol, 1e-9))
    assert b.result.peak_acceleration_g[1] == pytest.approx(5000 / M / G, rel=max(tol, 1e-9))


def test_reference_backend_close():
    b = max_closing_speed(table3_scene(), 5000.0, method="reference", dt=1e-5)
    assert b.speed == pytest.approx(closed_form_speed(5000.0), rel=2e-4)


def test_moving_target_and_other_steps():
    b = max_closing_speed(table3_scene(**{"vehicles.1.speed": 2.0, "vehicles.0.speed": 3.0}), 5000.0)
    assert b.closing_speed == pytest.approx(closed_form_speed(5000.0), rel=1e-12)
    assert b.speed == pytest.approx(2.0 + closed_form_speed(5000.0), rel=1e-12)
    mph = 5280 / 3600
    b2 = max_closing_speed(table3_scene(), 5000.0, step="1 mph", margin_steps=2)
    assert b2.speed == pytest.approx(b.closing_speed, rel=1e-12)
    assert b2.step == pytest.approx(mph)
    assert b2.step_speed == pytest.approx(4 * mph)          # 4.99 ft/s = 3.4 mph → 4 mph
    assert b2.bound_speed == pytest.approx(6 * mph)
    assert [round(v / mph) for v, _ in b2.rows] == [3, 4, 5, 6]


def test_failure_force_from_scene_and_units():
    sc = table3_scene(**{"contacts.0.failure": {"force": "5000 lbf"}})
    b = max_closing_speed(sc)
    assert b.failure_force == 5000.0
    b_kn = max_closing_speed(table3_scene(), "22.2411 kN")
    assert b_kn.failure_force == pytest.approx(5000.0, rel=1e-5)
    with pytest.raises(lsc.SceneError, match="failure force"):
        max_closing_speed(table3_scene())


def test_piecewise_table_against_energy():
    """Monotone table: the peak force is f(D_max) and ½ μ v0² = ∫_0^{D_max} f dD."""
    pts = [[0, 0], [0.02, 400], [0.05, 3000], [0.09, 6000], [0.2, 20000]]
    sc = {"units": "US", "vehicles": [{"weight": 4000, "speed": 3}, {"weight": 3000, "speed": 0}],
          "contacts": [{"loading": {"table": pts}, "unloading": {"restitution": 0.5}}]}
    s = lsc.Scene.load(sc)
    mu = s.masses.prod() / s.masses.sum()
    c = Curve.table(pts)
    for F in (1000.0, 4500.0, 9000.0):
        b = max_closing_speed(sc, F)
        d_star = c.deformation_at(F)
        assert b.speed == pytest.approx(np.sqrt(2 * c.energy(d_star) / mu), rel=1e-12)
        assert b.result.method == "exact"


def test_table_that_never_reaches_the_force():
    pts = [[0, 0], [0.05, 3000], [0.1, 4000]]
    sc = {"units": "US", "vehicles": [{"weight": 4000, "speed": 3}, {"weight": 3000, "speed": 0}],
          "contacts": [{"loading": {"table": pts}, "unloading": {"restitution": 0.5}}]}
    with pytest.raises(lsc.SimulationError, match="does not reach the failure force"):
        max_closing_speed(sc, 5000.0)
    # below the table's top it works, whatever the bracket expansion hit on the way
    b = max_closing_speed(sc, 3500.0)
    assert b.result.peak_force[0] == pytest.approx(3500.0, rel=1e-9)


def test_bracket_and_bad_arguments():
    sc = table3_scene()
    b = max_closing_speed(sc, 5000.0, bracket=(1.0, 9.0))
    assert b.speed == pytest.approx(closed_form_speed(5000.0), rel=1e-12)
    with pytest.raises(lsc.SceneError, match="bracket"):
        max_closing_speed(sc, 5000.0, bracket=(6.0, 9.0))
    with pytest.raises(lsc.SceneError, match="contact"):
        max_closing_speed(sc, 5000.0, contact=1)
    with pytest.raises(lsc.SceneError, match="positive"):
        max_closing_speed(sc, -1.0)
    with pytest.raises(lsc.SceneError, match="step"):
        max_closing_speed(sc, 5000.0, step=0)


def test_peak_force_helper_and_summary():
    sc = table3_scene()
    assert peak_force(sc, 5.0) == pytest.approx(5.0 * np.sqrt(K_SYS * M / 2), rel=1e-12)
    b = max_closing_speed(sc, "5000 lbf")
    text = b.summary()
    assert "4.99166" in text and "conservative bound" in text and "6 ft/s" in text
    d = b.to_dict()
    assert d["bound_speed"] == 6.0 and len(d["rows"]) == 3


SOLVER_OPTIONS = "atol, dt, first_step, integrator, max_events, max_steps, n_samples, t_end"


def test_unknown_keyword_is_refused_by_name():
    # (it used to be passed on to lsc.solve, where method "auto" dropped it silently)
    with pytest.raises(lsc.SceneError) as e:
        max_closing_speed(table3_scene(), 5000.0, rtoll=1e-13)
    assert e.value.path == "rtoll"
    assert str(e.value) == (
        "rtoll: max_closing_speed() got an unknown keyword 'rtoll'; it accepts failure_force, "
        "contact, speed_path, method, step, margin_steps, bracket, xtol, rtol, maxiter and the "
        f"solver options {SOLVER_OPTIONS}")   # (rtol is Brent's here)
    with pytest.raises(lsc.SceneError, match="peak_force\\(\\) got an unknown keyword 'spped'"):
        peak_force(table3_scene(), 5.0, spped=1)


@pytest.mark.parametrize("kw, message", [
    ({"xtol": -1}, "xtol: xtol must be a positive finite number, got -1"),
    ({"xtol": float("nan")}, "xtol: xtol must be a positive finite number, got nan"),
    ({"maxiter": 0}, "maxiter: maxiter must be a positive integer, got 0"),
    ({"maxiter": 2.5}, "maxiter: maxiter must be a positive integer, got 2.5"),
    ({"rtol": 1e-17}, "rtol: rtol must be a finite number >= 8.88178e-16 (4 machine epsilons), "
                      "got 1e-17"),
    ({"margin_steps": 1e9}, "margin_steps: must be a whole number from 0 to 1000 (one solve "
                            "per step), got 1000000000.0"),
    ({"margin_steps": -1}, "margin_steps: must be a whole number from 0 to 1000 (one solve "
                           "per step), got -1"),
])
def test_bad_search_settings_are_refused(kw, message):
    with pytest.raises(lsc.SceneError) as e:
        max_closing_speed(table3_scene(), 5000.0, **kw)
    assert str(e.value) == message
