"""Contacts that close at the same instant: a vehicle's metrics do not depend on the order in
which a solve's rounding or tolerance put the closings.

The scene (US: slug, ft/s, lbf/ft, ft): three vehicles of 1, 1 and 100 slug at 2, 1 and 0 ft/s,
both contacts linear (k = 100), elastic, 1 ft apart: both close at t = 1 s exactly (each closes
at 1 ft/s). The middle vehicle's first impact is then either contact's; the metrics take the rear
one (the lower contact index) for a tie (docs: metrics page). The integrators put the two closings
a rounding error or a tolerance apart, in either order (diffrax: contact 1 first by 1.4e-13 s;
exact-chain at the same float), and the middle vehicle's ΔV came out -2.083 or -2.049 ft/s.
"""

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
def test_closings_a_rounding_error_apart_are_one_tie_either_way(resolution):
    """The middle vehicle's ΔV, peak acceleration and the scene's duration are the rear
    contact's for closings 1e-15 s apart in either order (a rounding error for any solve), and
    1e-13 s apart at an rtol of 1e-10."""
    gap = 1e-13 if resolution else 1e-15
    a, b = _headline([1.0, 1.0 - gap], resolution), _headline([1.0 - gap, 1.0], resolution)
    for h in (a, b):
        assert h["delta_v"][1] == 2.0 - 1.0          # contact 0, front side: v_sep - v_touch
        assert h["peak_acceleration"][1] == 2.0
        assert h["duration"] == pytest.approx(0.5, rel=1e-12)


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
