"""Backends against closed forms and conservation laws."""

import itertools

import numpy as np
import pytest

import lsc
from lsc.solvers import closed_form
from helpers import NONLINEAR, max_rel_error as _rel, two_cars

GRID = list(itertools.product([0.1, 1.0, 10.0], [0.0, 0.4, 1.0], [1e3, 2.4e4, 1e6]))


@pytest.mark.parametrize("ratio, e, k", GRID)
def test_scipy_matches_closed_form(ratio, e, k):
    scene = two_cars(1500.0 * ratio, 1500.0, 5.0, 1.0, {"stiffness": k}, {"restitution": e})
    cf = lsc.solve(scene, method="closed-form")
    sp = lsc.solve(scene, method="scipy", rtol=1e-12)
    exact = closed_form.metrics(1500.0 * ratio, 1500.0, 5.0, 1.0, k, e)
    for name in ("delta_v", "duration", "peak_force", "max_deformation"):
        assert _rel(getattr(sp, name), exact[name]) < 1e-9, name
        assert _rel(getattr(cf, name), exact[name]) < 1e-12, name
    assert _rel(sp.delta_v, cf.delta_v) < 1e-9
    # momentum: m1 v1 + m2 v2 is the same before and after, to 1e-12 relative
    m = np.array([1500.0 * ratio, 1500.0])
    p0 = m @ np.array([5.0, 1.0])
    assert abs(m @ sp.v_final - p0) <= 1e-12 * abs(p0)
    # momentum along the whole trajectory
    assert np.max(np.abs(sp.v @ m - p0)) <= 1e-12 * abs(p0) * 10


def test_closed_form_against_hand_numbers():
    # paper scene, e = 0.4: D_max = v0/ω, F_max = v0 √(kμ), ΔV = ∓(1+e) v0/2
    mu = 3500 / 32.2 / 2
    w = np.sqrt(24000 / mu)
    m = closed_form.metrics(3500 / 32.2, 3500 / 32.2, 10.0, 0.0, 24000.0, 0.4)
    assert m["max_deformation"] == pytest.approx(10 / w, rel=1e-15)
    assert m["peak_force"] == pytest.approx(10 * np.sqrt(24000 * mu), rel=1e-15)
    assert m["duration"] == pytest.approx(np.pi / (2 * w) * 1.4, rel=1e-15)
    assert m["delta_v"] == pytest.approx([-7.0, 7.0], rel=1e-15)
    assert m["permanent_deformation"] == pytest.approx(10 / w * (1 - 0.16), rel=1e-15)


@pytest.mark.parametrize("e", [0.0, 0.1, 0.5, 0.9, 1.0])
def test_nonlinear_table_restitution_both_definitions(e):
    scene = two_cars(1600.0, 1200.0, 6.0, 0.0, NONLINEAR, {"restitution": e})
    r = lsc.solve(scene, method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(e, abs=1e-9)
    assert r.restitution_energy[0] == pytest.approx(e, abs=1e-12)
    # energy balance: kinetic energy lost = absorbed - returned by the bumpers
    m = np.array([1600.0, 1200.0])
    ke0 = 0.5 * m @ np.array([6.0, 0.0]) ** 2
    ke1 = 0.5 * m @ r.v_final**2
    lost = r.energy_absorbed[0] - r.energy_returned[0]
    assert abs((ke0 - ke1) - lost) <= 1e-9 * r.energy_absorbed[0]
    # the crash passes the kinks as events: the loading force is continuous and follows the table
    kinds = [ev.kind for ev in r.events]
    assert kinds[0] == "contact" and "breakpoint" in kinds
    assert kinds[-1] in ("separation", "max_deformation+separation")


def test_nonlinear_table_loading_force_follows_table():
    scene = two_cars(1600.0, 1200.0, 6.0, 0.0, NONLINEAR, {"restitution": 0.5})
    r = lsc.solve(scene, method="scipy", rtol=1e-12)
    curve = lsc.Scene.load(scene).contacts[0].law.loading
    t_max = [ev.time for ev in r.events if ev.kind == "max_deformation"][0]
    load = r.t <= t_max
    assert np.max(np.abs(r.force[load, 0] - curve.force(r.deformation[load, 0]))) < 1e-6 * 14000


def test_unloading_stiffness_gives_energy_restitution():
    k, su = 24000.0, 24000.0 / 0.25  # e² = k / su
    scene = two_cars(1500.0, 1500.0, 3.0, 0.0, {"stiffness": k}, {"stiffness": su})
    r = lsc.solve(scene, method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(0.5, abs=1e-9)
    assert r.restitution_energy[0] == pytest.approx(0.5, abs=1e-12)
    cf = lsc.solve(scene, method="closed-form")
    assert _rel(r.delta_v, cf.delta_v) < 1e-9


def test_unloading_table_mapped_onto_simulated_peak():
    # a rebound curve measured from (0.5, 10000) down to (0.3, 0), given in time order
    unl = {"table": [[0.5, 10000], [0.45, 5000], [0.38, 1000], [0.3, 0]]}
    scene = two_cars(1500.0, 1500.0, 3.0, 0.0, {"stiffness": 30000.0}, unl)
    r = lsc.solve(scene, method="scipy", rtol=1e-12)
    dmax, fmax = r.max_deformation[0], r.peak_force[0]
    # deformation shifted by D_max - 0.5, force scaled by F_max / 10000
    assert r.permanent_deformation[0] == pytest.approx(dmax - 0.2, rel=1e-12)
    e_ret = fmax / 10000 * (0.05 * 7500 + 0.07 * 3000 + 0.08 * 500)
    assert r.energy_returned[0] == pytest.approx(e_ret, rel=1e-12)
    m = 1500.0
    ke_lost = 0.5 * m * 9 - 0.5 * m * (r.v_final @ r.v_final)
    assert ke_lost == pytest.approx(r.energy_absorbed[0] - r.energy_returned[0], rel=1e-9)


def test_gap_closes_at_gap_over_closing_speed():
    scene = two_cars(1500.0, 1000.0, 6.0, 1.0, {"stiffness": 50000.0}, {"restitution": 0.3},
                     gap=0.25)
    for method in ("closed-form", "scipy"):
        r = lsc.solve(scene, method=method)
        contact = [ev for ev in r.events if ev.kind == "contact"][0]
        assert contact.time == pytest.approx(0.25 / 5.0, rel=1e-10)
    a = lsc.solve(scene, method="scipy", rtol=1e-12)
    b = lsc.solve(scene, method="closed-form")
    assert _rel(a.delta_v, b.delta_v) < 1e-9
    assert a.duration == pytest.approx(b.duration, rel=1e-9)


def test_reference_converges_at_first_order():
    scene = two_cars(1500.0, 1000.0, 5.0, 0.0, {"stiffness": 40000.0}, {"restitution": 0.5})
    exact = lsc.solve(scene, method="closed-form")
    errs = []
    for dt in (4e-5, 2e-5, 1e-5):
        r = lsc.solve(scene, method="reference", dt=dt)
        errs.append(np.max(np.abs(r.delta_v - exact.delta_v)))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 1.6) & (ratios < 2.4)), (errs, ratios)


def test_table_ending_before_common_velocity_is_a_simulation_error():
    scene = two_cars(1500.0, 1500.0, 10.0, 0.0, {"table": [[0, 0], [0.05, 3000]]},
                     {"restitution": 0.5})
    for method in ("scipy", "reference"):
        with pytest.raises(lsc.SimulationError, match="ends before the vehicles reach a common"):
            lsc.solve(scene, method=method)


def test_result_carries_method_tolerances_and_stats():
    scene = two_cars(1500.0, 1500.0, 3.0, 0.0, {"stiffness": 30000.0}, {"restitution": 0.4})
    r = lsc.solve(scene, method="scipy", rtol=1e-8, integrator="RK45")
    assert r.method == "scipy-RK45"
    assert r.tolerances["rtol"] == 1e-8
    assert r.stats["rhs_evaluations"] > 0 and r.stats["steps"] > 0 and r.stats["wall_time"] > 0
    assert r.units["delta_v"] == "m/s" and r.units["peak_force"] == "N"


@pytest.mark.parametrize("integrator", ["RK45", "DOP853", "LSODA", "Radau"])
def test_every_scipy_integrator_reaches_its_tolerance(integrator):
    scene = two_cars(1500.0, 900.0, 4.0, 0.0, {"stiffness": 30000.0}, {"restitution": 0.6})
    r = lsc.solve(scene, method="scipy", integrator=integrator, rtol=1e-9)
    exact = lsc.solve(scene, method="closed-form")
    assert _rel(r.delta_v, exact.delta_v) < 1e-6
    assert r.duration == pytest.approx(exact.duration, rel=1e-6)


def test_auto_picks_the_cheapest_exact_backend():
    lin = two_cars(1500.0, 900.0, 4.0, 0.0, {"stiffness": 30000.0}, {"restitution": 0.6})
    assert lsc.solve(lin).method == "closed-form"
    tab = two_cars(1500.0, 900.0, 4.0, 0.0, NONLINEAR, {"restitution": 0.6})
    assert lsc.solve(tab).method != "closed-form"


def test_t_end_extends_the_series_and_rejects_cutting_the_crash():
    scene = two_cars(1500.0, 900.0, 4.0, 0.0, {"stiffness": 30000.0}, {"restitution": 0.6})
    for method in ("closed-form", "scipy", "reference"):
        r = lsc.solve(scene, method=method, t_end=1.0)
        assert r.t[-1] == pytest.approx(1.0)
        # (the reference reports the paper's V*, before the impulse of its last step)
        assert r.v[-1] == pytest.approx(r.v_final, rel=1e-12 if method != "reference" else 1e-6)
        with pytest.raises(lsc.SimulationError, match="before the crash is over"):
            lsc.solve(scene, method=method, t_end=0.01)
