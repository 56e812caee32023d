"""lsc.analysis.calibrate_force_scale: the paper's force factor for measured crash-test curves."""

import numpy as np
import pytest

import lsc
from lsc.analysis import calibrate_force_scale, energy_force_scale
from lsc.curves import Curve

G = 32.174
# A synthetic "measured" dynamic IF-D compression branch (ft, lbf): a soft start, a plateau,
# a dip (the impact bar buckling) and a stiff end, as the crash-test curves of the paper's Fig. 3.
MEASURED = [[0, 0], [0.01, 300], [0.03, 2500], [0.05, 2600], [0.08, 5200], [0.1, 4800], [0.13, 9000]]
W1, W2 = 4246.0, 3382.0  # the paper's crash-test weights [lbf]


def speed_for_factor(c, pts=MEASURED, w1=W1, w2=W2, v2=0.0):
    """The closing speed at which the factor is exactly c: ½ μ v0² = c ∫ f dD."""
    m1, m2 = w1 / G, w2 / G
    mu = m1 * m2 / (m1 + m2)
    E = Curve.table(pts).energy(pts[-1][0])
    return v2 + np.sqrt(2 * c * E / mu)


def scene(v1, pts=MEASURED, v2=0.0, e=0.3, **loading):
    return {"units": "US", "name": "crash test",
            "vehicles": [{"name": "bullet", "weight": W1, "speed": v1},
                         {"name": "target", "weight": W2, "speed": v2}],
            "contacts": [{"loading": {"table": pts, **loading}, "unloading": {"restitution": e}}]}


def test_uncalibrated_curve_fails_and_says_so():
    with pytest.raises(lsc.SimulationError, match="calibrate_force_scale"):
        lsc.solve(scene(speed_for_factor(1.16)))


def test_recovers_1_16():
    sc = scene(speed_for_factor(1.16))
    cal = calibrate_force_scale(sc)
    assert cal.factor == pytest.approx(1.16, abs=1e-8)
    assert cal.energy_factor == pytest.approx(1.16, abs=1e-12)
    assert cal.previous_scale == 1.0
    # the calibrated scene reaches its common velocity on the table's last point
    assert cal.d_end == 0.13
    assert cal.result.max_deformation[0] == pytest.approx(0.13, rel=1e-10)
    assert cal.scene.source["contacts"][0]["loading"]["scale"] == cal.factor
    assert cal.scene.contacts[0].law.loading.f[-1] == pytest.approx(9000 * 1.16)
    # and lsc.solve runs it as it is
    r = lsc.solve(cal.scene)
    assert r.max_deformation[0] == pytest.approx(0.13, rel=1e-10)
    assert "1.16" in cal.summary()


@pytest.mark.parametrize("c, v2, e", [(1.14, 0.0, 0.2), (1.18, 1.5, 0.5), (0.8, 0.0, 0.0), (3.0, -2.0, 0.4)])
def test_root_finding_equals_energy_identity(c, v2, e):
    sc = scene(speed_for_factor(c, v2=v2), v2=v2, e=e)
    cal = calibrate_force_scale(sc)
    assert cal.factor == pytest.approx(c, rel=1e-10)
    assert energy_force_scale(sc) == pytest.approx(c, rel=1e-12)


def test_existing_scale_is_replaced_by_the_total_factor():
    sc = scene(speed_for_factor(1.16), scale=1.05)
    cal = calibrate_force_scale(sc)
    assert cal.previous_scale == 1.05
    assert cal.factor == pytest.approx(1.16, abs=1e-8)
    assert energy_force_scale(sc) == pytest.approx(1.16, abs=1e-12)
    assert "had scale = 1.05" in cal.summary()


def test_csv_with_column_units_keeps_its_form(tmp_path):
    rows = "\n".join(f"{d * 12!r},{f * 4.4482216152605!r}" for d, f in MEASURED)
    (tmp_path / "ifd.csv").write_text("deformation_in,force_N\n" + rows + "\n")
    sc = scene(speed_for_factor(1.18))
    sc["contacts"][0]["loading"] = {"csv": "ifd.csv", "deformation": "in", "force": "N"}
    cal = calibrate_force_scale(lsc.Scene.load(sc, base_dir=tmp_path))
    assert cal.factor == pytest.approx(1.18, abs=1e-8)
    loading = cal.scene.source["contacts"][0]["loading"]
    assert loading["csv"] == "ifd.csv" and loading["deformation"] == "in"


def test_chain_uses_simulations():
    """Three cars (the calibrated contact first): no energy identity, root finding still works."""
    sc = scene(8.0)
    sc["vehicles"].append({"name": "third", "weight": 3000, "speed": 0})
    sc["contacts"].append({"loading": {"stiffness": 20000}, "unloading": {"restitution": 0.3},
                           "gap": 0.05})
    cal = calibrate_force_scale(sc, rtol=1e-11)
    assert cal.energy_factor is None
    assert cal.result.max_deformation[0] == pytest.approx(0.13, rel=1e-7)
    # the third car is still 0.05 ft away when contact 0 reaches its max: the identity holds too
    assert cal.factor == pytest.approx(energy_force_scale(scene(8.0)), rel=1e-7)


def test_rejects_curves_that_do_not_end():
    sc = scene(5.0)
    sc["contacts"][0]["loading"] = {"stiffness": 24000}
    with pytest.raises(lsc.SceneError, match="table that ends"):
        calibrate_force_scale(sc)
    with pytest.raises(lsc.SceneError, match="contact"):
        calibrate_force_scale(scene(5.0), contact=2)


@pytest.mark.parametrize("kw, message", [
    ({"maxiter": -1}, "maxiter: maxiter must be a positive integer, got -1"),
    ({"xtol": 0.0}, "xtol: xtol must be a positive finite number, got 0.0"),
    ({"rtol": 0.0}, "rtol: rtol must be a finite number >= 8.88178e-16 (4 machine epsilons), "
                    "got 0.0"),
    ({"rtoll": 1e-12}, "rtoll: calibrate_force_scale() got an unknown keyword 'rtoll'; it accepts "
                       "contact, method, xtol, rtol, maxiter and the solver options atol, dt, "
                       "first_step, integrator, max_events, max_steps, n_samples, t_end"),
])
def test_bad_search_settings_and_unknown_keywords_are_refused(kw, message):
    with pytest.raises(lsc.SceneError) as e:
        calibrate_force_scale(scene(speed_for_factor(1.16)), **kw)
    assert str(e.value) == message
