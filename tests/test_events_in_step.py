"""Events found inside an integrator step, not only as a sign change between its ends, and the
end of a crash that has nothing left in it (issue 11, item 1).

The reference is the independent modal solution of a linear chain (tests/hard/modal_chain.py),
which shares no code with lsc; the property over generated chains is in
tests/hard/test_chains.py (test_linear_chains_match_the_modal_solution).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import chebyshev as cheb

import lsc
from lsc.solvers import step_roots

from hard.modal_chain import ModalChain

G_US = 32.174

#: The issue's reproducer: a soft contact behind a stiff one between two light cars. The stiff
#: contact reloads past its max deformation and comes back inside one DOP853 step: `lsc run`
#: gave ΔV3 = 19.6714 ft/s, 12.590 g and 16 events (two missed).
REPRODUCER = {
    "units": "US",
    "vehicles": [{"weight": 5250, "speed": 29.8}, {"weight": 1150, "speed": 9.93},
                 {"weight": 1290, "speed": 6.4}],
    "contacts": [{"loading": {"stiffness": 4320}, "unloading": {"restitution": 0.18}},
                 {"loading": {"stiffness": 396000}, "unloading": {"restitution": 0.807}}]}


def _modal(scene):
    """Final speeds and events of a US chain scene given by weights, on linear contacts."""
    m = np.array([v["weight"] for v in scene["vehicles"]], float) / G_US
    v = [v["speed"] for v in scene["vehicles"]]
    c = scene["contacts"]
    return ModalChain(m, v, [x["loading"]["stiffness"] for x in c],
                      [x["unloading"]["restitution"] for x in c],
                      [x.get("gap", 0.0) for x in c]).run()


def _whole_run_peak_g(r, vehicle):
    """The largest |acceleration| [g] of ``vehicle`` over all its impacts."""
    return max(abs(imp.peak_acceleration_g[imp.vehicles.index(vehicle)])
               for imp in r.impacts if vehicle in imp.vehicles)


@pytest.mark.parametrize("method", ["scipy", "auto"])
def test_reproducer_chain_finds_the_events_inside_a_step(method):
    v_ref, ref_events = _modal(REPRODUCER)
    r = lsc.solve(REPRODUCER, method=method)
    closing = 29.8 - 6.4
    # the figures (RK45, LSODA and an independent integration agree on them): the front
    # car's ΔV and peak over the whole run (its contact closes several times: several impacts)
    assert round(float(r.delta_v_total[2]), 4) == 19.6653
    assert round(_whole_run_peak_g(r, vehicle=2), 3) == 12.552
    assert len(r.events) == 18
    # and the modal solution's: its 16 events after the two contacts at t = 0
    assert len(ref_events) == 16 and sum(e.time == 0 for e in r.events) == 2
    assert np.max(np.abs(r.v_final - v_ref)) <= 1e-8 * closing


def test_reproducer_chain_on_diffrax():
    pytest.importorskip("diffrax")
    v_ref, _ = _modal(REPRODUCER)
    r = lsc.solve(REPRODUCER, method="diffrax")
    assert round(float(r.delta_v_total[2]), 4) == 19.6653
    assert len(r.events) == 18
    assert np.max(np.abs(r.v_final - v_ref)) <= 1e-8 * (29.8 - 6.4)


def test_the_pair_of_crossings_the_old_search_missed_lies_inside_one_step():
    """The reproducer's two events that a sign test between step ends missed (the stiff
    contact's reload past its max deformation and its max right after) are closer together
    than the longest step the integrator takes while that contact unloads (MAX_ANGLE radians of
    its unloading line): a crossing and a crossing back inside one step."""
    from lsc.solvers.scipy_ode import MAX_ANGLE

    _, ref_events = _modal(REPRODUCER)
    reload = [i for i, (_, j, kind) in enumerate(ref_events)
              if kind == "reload_past_max" and j == 1]
    gaps = [ref_events[i + 1][0] - ref_events[i][0] for i in reload
            if ref_events[i + 1][2] == "max_deformation"]
    m = np.array([1150, 1290]) / G_US
    w_unload = np.sqrt(396000 / 0.807 ** 2 * (1 / m[0] + 1 / m[1]))
    assert min(gaps) < MAX_ANGLE / w_unload


# ---------------------------------------------------------------- the roots of a step's series
def test_first_crossing_finds_a_dip_that_both_step_ends_hide():
    # (x - 0.2)(x - 0.3) + tiny: positive at both ends, below zero between 0.2 and 0.3
    coef = cheb.poly2cheb(np.polynomial.polynomial.polyfromroots([0.2, 0.3]))
    a, b = step_roots.first_crossing(coef, depth=1e-6, end_below=False)
    assert a <= 0.2 <= b and b <= 0.3


def test_first_crossing_takes_the_earliest_of_three_roots():
    # down at -0.5, up at 0, down at 0.5: ends positive then negative
    coef = cheb.poly2cheb(-np.polynomial.polynomial.polyfromroots([-0.5, 0.0, 0.5]))
    a, b = step_roots.first_crossing(coef, depth=0.0, end_below=True)
    assert a <= -0.5 <= b and b < 0.0


def test_first_crossing_ignores_a_touch_shallower_than_its_depth():
    coef = cheb.poly2cheb(np.polynomial.polynomial.polyfromroots([0.25, 0.25]) - [1e-12, 0, 0])
    assert step_roots.first_crossing(coef, depth=1e-9, end_below=False) is None
    assert step_roots.first_crossing(coef, depth=0.0, end_below=False) is not None


def test_fit_reproduces_a_polynomial_of_its_degree():
    x = step_roots.lobatto(7)
    p = np.polynomial.polynomial.polyfromroots([-0.9, -0.1, 0.3, 0.35, 0.8, 1.5, 2.0])
    coef = step_roots.fit(np.polynomial.polynomial.polyval(x, p)[None, :])[0]
    xs = np.linspace(-1, 1, 101)
    assert np.allclose(cheb.chebval(xs, coef), np.polynomial.polynomial.polyval(xs, p),
                       rtol=0, atol=1e-13)


# ---------------------------------------------------------------- the end of a crash
def _elastic_chain(gaps):
    """Three 3000 lbf cars, 10 ft/s into two at rest, k = 24000 lbf/ft, e = 1."""
    return {"units": "US",
            "vehicles": [{"weight": 3000, "speed": 10}, {"weight": 3000, "speed": 0},
                         {"weight": 3000, "speed": 0}],
            "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 1},
                          "gap": g} for g in gaps]}


@pytest.mark.parametrize("method", ["scipy", "auto"])
@pytest.mark.parametrize("gaps", [(2.0, 2.0), (0.0, 2.0)])
def test_elastic_chain_passes_the_speed_on_and_ends(method, gaps):
    """Equal masses, elastic: the speed passes from car to car, (10, 0, 0) → (0, 0, 10). The
    first two are left at rest to the integrator's error, closing at 1e-11 ft/s 2 ft apart:
    they would meet after 2e11 s (failed: "no event before t = 44077.9 s although the crash
    is not over"); the crash is over."""
    r = lsc.solve(_elastic_chain(gaps), method=method)
    assert np.max(np.abs(r.v_final - [0.0, 0.0, 10.0])) <= 1e-8 * 10.0
    assert len(r.events) == 6


def test_a_pair_that_closes_again_within_the_horizon_is_not_over():
    """The end test leaves real second impacts alone: cars 1 and 2 left closing at 0.5 ft/s
    (a heavy rear car), 2 ft apart after their first impact, meet again."""
    scene = {"units": "US",
             "vehicles": [{"weight": 6000, "speed": 10}, {"weight": 3000, "speed": 0},
                          {"weight": 3000, "speed": 0}],
             "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 1},
                           "gap": g} for g in (0.0, 2.0)]}
    r = lsc.solve(scene, method="scipy")
    contacts0 = [e for e in r.events if e.index == 0 and e.kind == "contact"]
    assert len(contacts0) >= 2
    m = np.array([6000, 3000, 3000.0])
    assert abs(m @ r.v_final - m @ [10, 0, 0]) <= 1e-12 * m @ [10, 0, 0]


def test_diffrax_dip_floor_sees_a_dip_between_its_sample_points():
    """diffrax's in-step test: a parabola dipping to -d exactly between two of the 129 points at
    which the step's event series is evaluated (both read 0: sampling alone sees no dip) has a
    floor of -d from the curvature bound; a series whose slope shows it monotone has its least
    sampled value as floor."""
    pytest.importorskip("diffrax")
    from numpy.polynomial import chebyshev as C
    from lsc.solvers import diffrax_ode as dx
    h = 2.0 / (dx._DIP_POINTS - 1)
    s0, d = -1.0 + 64.5 * h, 1e-6                   # between points 64 and 65
    K = 4 * d / h ** 2                              # q(s0 ± h/2) = 0
    q = C.poly2cheb([K * s0 ** 2 - d, -2 * K * s0, K])
    coef = np.zeros((10, 2))
    coef[:3, 0] = q
    coef[:2, 1] = [0.5, 0.25]                       # 0.5 + 0.25 s: monotone, least 0.25
    sampled = np.min(dx._CHEB_DIP @ coef, axis=0)
    floor = dx.dip_floor(coef)
    assert sampled[0] >= -1e-15                     # sampling alone misses the dip...
    assert floor[0] <= -d * (1 - 1e-9)              # ...the bound does not
    assert floor[1] == pytest.approx(0.25, abs=1e-15)
