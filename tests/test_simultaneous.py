"""Contacts that close at the same instant: a vehicle's metrics do not depend on the order in
which a solve's rounding or tolerance put the closings (docs: metrics page, simultaneous
impacts): of simultaneous first touches, the lower contact index takes the tie.

The scene (US: slug, ft/s, lbf/ft, ft): three vehicles of 1, 1 and 100 slug at 2, 1 and 0 ft/s,
both contacts linear (k = 100), elastic, 1 ft apart: both close at t = 1 s exactly (each closes
at 1 ft/s). The integrators put the two closings a rounding error or a tolerance apart, in either
order (diffrax: contact 1 first by 1.4e-13 s; exact-chain at the same float), and the middle
vehicle's ΔV came out -2.083 or -2.049 ft/s by that order.

The elastic chain of 9.03, 1 and 40.3 slug, the rear two touching at the same speed: exact-chain
stopped at its event limit (10,000 events at t = 2.17 s, where contact 1 closes) and SciPy and
diffrax finish in 24 events."""

import numpy as np
import pytest

import lsc
from lsc import metrics as M

from helpers import chain, have_diffrax

#: Both contacts close at t = 1 s (see the module docstring).
SCENE = chain([1.0, 1.0, 100.0], [2.0, 1.0, 0.0],
              [{"loading": {"stiffness": 100.0}, "unloading": {"restitution": 1.0}, "gap": 1.0}]
              * 2, units="US")


def _record(t_close, t_end, v_touch, v_sep):
    """A two-contact first-impact record (see lsc.metrics) with the given closing and end times
    (K,) and speeds (K, 2)."""
    return {"contact_time": np.asarray(t_close, float), "v_touch": np.asarray(v_touch, float),
            "first_end": np.asarray(t_end, float), "v_sep": np.asarray(v_sep, float),
            "peak_force": np.ones(2), "peak_acc": np.array([[-1.0, 2.0], [-3.0, 4.0]]),
            "v_max": np.asarray(2.0)}


def _headline(t_close, resolution):
    rec = _record(t_close, [1.5, 1.4], [[2.0, 1.0], [1.0, 0.0]], [[0.0, 2.0], [-1.0, 1.0]])
    return M.headline(rec, 2.0, np.zeros(3), resolution=resolution)


@pytest.mark.parametrize("resolution", [0.0, 1e-10])
def test_closings_a_rounding_error_apart_are_one_impact_either_way(resolution):
    """Closings 1e-15 s apart in either order (a rounding error for any solve), and 1e-13 s
    apart at an rtol of 1e-10, are simultaneous: the middle vehicle's first impact is its rear
    contact's (contact 0, the lower index), from the first touch; so is the scene's."""
    gap = 1e-13 if resolution else 1e-15
    a, b = _headline([1.0, 1.0 - gap], resolution), _headline([1.0 - gap, 1.0], resolution)
    for h in (a, b):
        assert h["delta_v"][1] == 2.0 - 1.0          # contact 0, front side: v_sep - v_touch
        assert h["peak_acceleration"][1] == 2.0
        assert h["duration"] == pytest.approx(0.5, rel=1e-12)
    for name in ("delta_v", "peak_acceleration"):
        np.testing.assert_array_equal(a[name], b[name])


@pytest.mark.parametrize("late", [0.0, 1e-6, 1e-3])
def test_a_contact_pushed_shut_during_its_neighbours_impact_touches_with_it(late):
    """Contact 0 touching at no closing speed (pushed shut: its deformation grows from zero as
    a power of time, so a solve sees the touch only once that exceeds its rounding, a
    microsecond late for an integrator) while contact 1's impact goes on: one impact for the
    middle vehicle whatever the delay: contact 0's (the lower index), from contact 1's touch."""
    rec = _record([1.0 + late, 1.0], [1.5, 1.4], [[1.0, 1.0], [1.0, 0.0]],
                  [[0.0, 2.0], [-1.0, 1.0]])
    h = M.headline(rec, 2.0, np.zeros(3))
    assert h["delta_v"][1] == 2.0 - 1.0
    assert h["peak_acceleration"][1] == 2.0
    assert h["duration"] == 0.5


def test_closings_the_resolution_can_tell_apart_keep_their_order():
    """Closings 1e-6 s apart at an rtol of 1e-10: the earlier one is the vehicle's first
    impact (the front contact's here), as before."""
    h = _headline([1.0, 1.0 - 1e-6], 1e-10)
    assert h["delta_v"][1] == -1.0 - 1.0             # contact 1, rear side
    assert h["peak_acceleration"][1] == -3.0
    assert h["duration"] == pytest.approx(1.4 - (1.0 - 1e-6), rel=1e-12)


def _solves():
    yield lsc.solve(SCENE, method="exact-chain")
    yield lsc.solve(SCENE, method="scipy")
    yield lsc.solve(SCENE, method="scipy", integrator="RK45", rtol=1e-12)
    if have_diffrax():
        yield lsc.solve(SCENE, method="diffrax")


def test_every_backend_gives_the_simultaneous_closings_the_same_metrics():
    """Every backend agrees with exact-chain to its tolerance on every vehicle's ΔV and peak
    acceleration, the duration and the order of the impacts (the middle vehicle's ΔV from its
    rear contact); exact-chain closes both contacts at the same float."""
    exact, *others = _solves()
    closing = [ev.time for ev in exact.events if ev.kind == "contact"]
    assert closing == [1.0, 1.0]
    assert [m.contact for m in exact.impacts] == [0, 1]
    rear = exact.impacts[0]
    assert exact.delta_v[1] == rear.delta_v[1] and exact.duration == rear.duration
    for r in others:
        tol = 1e3 * r.tolerances["rtol"]
        np.testing.assert_allclose(r.delta_v, exact.delta_v, rtol=tol, atol=tol, err_msg=r.method)
        np.testing.assert_allclose(r.peak_acceleration, exact.peak_acceleration, rtol=tol,
                                   err_msg=r.method)
        assert r.duration == pytest.approx(exact.duration, rel=tol), r.method
        assert [m.contact for m in r.impacts] == [0, 1], r.method


#: The elastic chain (US) on which exact-chain hit its event limit: the rear two touching at the
#: same speed (contact 0: gap 0, no closing rate, stiff), contact 1 closing at t = 2.17 s; all
#: three backing at about 2 ft/s (the rounding of the positions at the touch decides whether
#: the trap sprang: at a front speed of 0, -1 or -3 ft/s it did not, at -0.5, -2 or -5 it did).
ELASTIC_CHAIN = chain([9.03, 1.0, 40.3], [0.465 / 2.17 - 2.0, 0.465 / 2.17 - 2.0, -2.0],
                      [{"loading": {"stiffness": 3.56e6}, "unloading": {"restitution": 1.0},
                        "gap": 0.0},
                       {"loading": {"stiffness": 20366.5}, "unloading": {"restitution": 1.0},
                        "gap": 0.465}], units="US")


def test_exact_chain_finishes_the_chain_pushed_shut_at_a_touch_as_the_integrators_do():
    """exact-chain has SciPy's and diffrax's 24 events, at their times to 1e-9 s, and every
    metric to 1e-9 of its scale (diffrax's peak accelerations to 1e-8). Contact 0 closes with contact 1 (its deformation grows as t³
    from then): a solve sees it up to microseconds late, when that passes its rounding.
    (exact-chain took the rounding-size force k D of the touch, 1.6e-9 lbf, for a
    falling closing rate and fired max deformation and reload at one instant, forever.)"""
    from lsc.result import METRICS

    exact = lsc.solve(ELASTIC_CHAIN, method="exact-chain")
    others = [lsc.solve(ELASTIC_CHAIN, method="scipy")]
    if have_diffrax():
        others.append(lsc.solve(ELASTIC_CHAIN, method="diffrax"))
    assert abs(exact.events[0].time - 2.17) < 1e-14 and abs(exact.events[1].time - 2.17) < 1e-5
    for r in others:
        assert [(e.kind, e.index) for e in r.events] == [(e.kind, e.index) for e in exact.events]
        late = [abs(a.time - b.time) for a, b in zip(r.events, exact.events)]
        assert late[1] < 1e-5 and max(late[:1] + late[2:]) < 1e-9, (r.method, late)
        for name in METRICS:
            ref = np.asarray(getattr(exact, name), float)
            scale = np.max(np.abs(ref[np.isfinite(ref)]), initial=0.0)
            # (diffrax's peak of the light car's acceleration, on its own dense output: 2.2e-9)
            tol = 1e-8 if name.startswith("peak_acc") and "diffrax" in r.method else 1e-9
            np.testing.assert_allclose(getattr(r, name), ref, rtol=0, atol=tol * scale,
                                       equal_nan=True, err_msg=f"{r.method}: {name}")


#: Three cars at rest but the front one backing into the middle one at 5 ft/s, every contact
#: touching: contact 1 is struck at t = 0 and pushes contact 0 shut (its deformation grows as
#: t³: an integrator sees that touch 16 µs late).
BACKED_INTO = chain([100.0, 100.0, 100.0], [0.0, 0.0, -5.0],
                    [{"loading": {"stiffness": 1e4}, "unloading": {"restitution": 0.5},
                      "gap": 0.0}] * 2, units="US")


@pytest.mark.parametrize("method", ["exact-chain", "scipy", "diffrax"])
def test_the_first_impact_is_the_duration_s_impact_where_a_contact_is_pushed_shut(method):
    """The impacts' order follows the headline rule for a contact pushed shut during its
    neighbour's impact (it touches with it, the rear contact first): ``first_impact`` is the
    impact whose duration ``duration`` reports, on every backend (an integrator, seeing the
    pushed touch 16 µs late, gave contact 1's 0.180 s impact as the first and 0.263 s as the
    duration)."""
    if method == "diffrax" and not have_diffrax():
        pytest.skip("diffrax is not installed")
    r = lsc.solve(BACKED_INTO, method=method)
    assert [m.contact for m in r.impacts] == [0, 1]
    assert [m.t_start for m in r.impacts] == [0.0, 0.0]
    assert r.first_impact.duration == r.duration
    touch = next(ev.time for ev in r.events if ev.kind == "contact" and ev.index == 0)
    assert touch < 1e-4   # (the event itself stays where the solve saw it)


#: Both contacts close at t = 1 s (masses 100, 100 and 1000 slug at 2, 1 and 0 ft/s, gaps of
#: 1 ft): diffrax saw whichever it did not fire first 4.47e-13 s late at every rtol (its restart
#: shift, 1e-12 of the event's scale), beyond the old tie window of 1.5e-13 s at rtol 1e-13; with
#: the cars at 6, 5 and 4 ft/s (a lighter front car), 1.14e-12 s late.
HEAVY_FRONT = chain([100.0, 100.0, 1000.0], [2.0, 1.0, 0.0],
                    [{"loading": {"stiffness": 1000.0}, "unloading": {"restitution": 1.0},
                      "gap": 1.0}] * 2, units="US")
FAST = chain([100.0, 100.0, 56.23413251903491], [6.0, 5.0, 4.0],
             [{"loading": {"stiffness": 1000.0}, "unloading": {"restitution": 1.0},
               "gap": 1.0}] * 2, units="US")


@pytest.mark.parametrize("scene", [HEAVY_FRONT, FAST], ids=["heavy-front", "fast"])
@pytest.mark.parametrize("method", ["scipy", "diffrax"])
def test_a_closing_the_restart_shift_delays_is_simultaneous_at_any_rtol(method, scene):
    """At rtol 1e-13 the integrators give exact-chain's ΔV (the middle car's was -1.7130 from
    diffrax against -1.6836, and 0.4538 against 0.4798) and order the impacts as it does."""
    if method == "diffrax" and not have_diffrax():
        pytest.skip("diffrax is not installed")
    exact = lsc.solve(scene, method="exact-chain")
    kw = {"integrator": "Dopri8"} if method == "diffrax" else {}
    r = lsc.solve(scene, method=method, rtol=1e-13, **kw)
    np.testing.assert_allclose(r.delta_v, exact.delta_v, rtol=1e-10)
    assert r.duration == pytest.approx(exact.duration, rel=1e-10)
    assert [m.contact for m in r.impacts] == [m.contact for m in exact.impacts] == [0, 1]


def test_the_tie_window_of_an_integrator_holds_its_restart_shift():
    """An integrator's window is at least 1e-9 of the larger of the touch time and the impact
    (its restart shift's delay), an exact solve's its rounding (1e-13), an integrator's at a
    looser rtol that rtol."""
    assert M.tie_window(1.0, 1.5, 1e-13) == pytest.approx(1.5e-9, rel=1e-15)
    assert M.tie_window(1.0, 1.5, 0.0) == pytest.approx(1.5e-13, rel=1e-15)
    assert M.tie_window(2.0, 1.5, 1e-8) == pytest.approx(2e-8, rel=1e-15)
