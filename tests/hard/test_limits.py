"""Physics that cannot be completed, and loops that must end: every backend raises
lsc.SimulationError with the reason and the remedy, never a result it knows to be wrong.

- a loading table that ends before the vehicles reach a common velocity (remedy: the force-scale
  calibration, or extending the table);
- a requested end time before the crash is over (remedy: raise t_end or leave it unset);
- a solver that failed (its own message, passed on);
- an event that was missed (the contact then never separates: said so);
- the event limit and the step limit (every loop is bounded: tiny limits end at once, clearly).

And every Result carries its method, tolerances and stats.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate

import lsc
from lsc.solvers import scipy_ode

from .common import have_diffrax, two_cars

LINEAR = two_cars(1.0, 1.0, 10.0, 0.0, {"stiffness": 1000.0}, {"restitution": 0.5})
TABLE = two_cars(1.0, 1.0, 10.0, 0.0, {"table": [[0, 0], [0.1, 100], [0.2, 300], [0.3, 600]]},
                 {"restitution": 0.5})
SHORT = two_cars(100.0, 100.0, 10.0, 0.0, {"table": [[0, 0], [0.1, 100], [0.2, 300]]},
                 {"restitution": 0.5})
CHAIN = {"units": "US", "vehicles": [{"mass": 1.0, "speed": 2.0}, {"mass": 1.0, "speed": 1.0},
                                     {"mass": 1.0, "speed": 0.0}],
         "contacts": [{"loading": {"stiffness": 1000.0}, "unloading": {"restitution": 0.5},
                       "gap": 0.1}] * 2}

TWO_CAR = ["closed-form", "exact", "scipy", "reference"]
TABLE_METHODS = ["exact", "scipy", "reference"]


def _diffrax(methods):
    return methods + (["diffrax"] if have_diffrax() else [])


@pytest.mark.parametrize("method", _diffrax(TABLE_METHODS))
def test_table_ending_before_common_velocity(method):
    with pytest.raises(lsc.SimulationError) as ei:
        lsc.solve(SHORT, method=method)
    msg = str(ei.value)
    assert "the loading table ends before the vehicles reach a common velocity" in msg
    assert "calibrate_force_scale" in msg and "Extend the table" in msg


@pytest.mark.parametrize("method", _diffrax(TWO_CAR))
def test_end_time_before_separation(method):
    scene = LINEAR if method == "closed-form" else TABLE
    r = lsc.solve(scene, method=method)
    with pytest.raises(lsc.SimulationError) as ei:
        lsc.solve(scene, method=method, t_end=0.5 * r.duration)
    assert "comes before the crash is over" in str(ei.value) and "t_end" in str(ei.value)
    # and one after it is fine, the series running on to it
    r2 = lsc.solve(scene, method=method, t_end=2 * r.duration)
    assert r2.t[-1] == pytest.approx(2 * r.duration)
    np.testing.assert_allclose(r2.delta_v, r.delta_v, rtol=1e-9, atol=1e-12)


def test_solver_failure_carries_the_backends_own_message(monkeypatch):
    class Failing(scipy.integrate.RK45):
        def _step_impl(self):
            return False, "the integrator's own words"

    monkeypatch.setattr(scipy.integrate, "RK45", Failing)
    with pytest.raises(lsc.SimulationError) as ei:
        lsc.solve(LINEAR, method="scipy", integrator="RK45")
    assert "SciPy RK45 failed" in str(ei.value) and "the integrator's own words" in str(ei.value)


def test_solver_that_cannot_start_says_why(monkeypatch):
    class Refusing(scipy.integrate.DOP853):
        def __init__(self, *args, **kw):
            raise ValueError("refused: its own reason")

    monkeypatch.setattr(scipy.integrate, "DOP853", Refusing)
    with pytest.raises(lsc.SimulationError, match="could not start.*refused: its own reason"):
        lsc.solve(LINEAR, method="scipy")


def test_missed_event_is_an_error_not_a_result(monkeypatch):
    """With its events hidden from the solver the contact never separates: the solve says so
    instead of returning a crash that never ended (the exact backend at its horizon; SciPy,
    ringing on the contact for ever, at its step limit)."""
    from lsc.model import HybridModel
    from lsc.solvers import exact

    def blind(xp, g, *args, **kw):
        return float("inf"), 0, False

    monkeypatch.setattr(exact.single, "_next_event", blind)
    with pytest.raises(lsc.SimulationError, match="no event before .* never separates"):
        lsc.solve(LINEAR, method="exact")
    monkeypatch.setattr(HybridModel, "active_events", lambda self, disc: [])
    with pytest.raises(lsc.SimulationError, match="steps in one segment .* and no event"):
        lsc.solve(LINEAR, method="scipy")


@pytest.mark.parametrize("method, scene", [("exact", TABLE), ("scipy", TABLE), ("scipy", CHAIN)])
def test_event_limit(method, scene):
    with pytest.raises(lsc.SimulationError, match=r"event limit reached \(2 events"):
        lsc.solve(scene, method=method, max_events=2)


@pytest.mark.parametrize("method, options", [("scipy", {"max_steps": 3}),
                                             ("scipy", {"max_steps": 3, "integrator": "LSODA"}),
                                             ("scipy", {"max_steps": 3, "integrator": "Radau"}),
                                             ("reference", {"max_steps": 10, "dt": 1e-4})])
def test_step_limit(method, options):
    with pytest.raises(lsc.SimulationError) as ei:
        lsc.solve(TABLE, method=method, **options)
    msg = str(ei.value)
    assert ("steps in one segment" in msg and "max_steps" in msg) or "no separation after" in msg


@pytest.mark.skipif(not have_diffrax(), reason="diffrax (the [jax] extra) is not installed")
def test_diffrax_limits():
    with pytest.raises(lsc.SimulationError):
        lsc.solve(TABLE, method="diffrax", max_events=2)
    with pytest.raises(lsc.SimulationError):
        lsc.solve(TABLE, method="diffrax", max_steps=3)


@pytest.mark.parametrize("method, scene", [("closed-form", LINEAR), ("exact", TABLE),
                                           ("scipy", TABLE), ("scipy", CHAIN),
                                           ("reference", TABLE)])
def test_every_result_says_how_it_was_computed(method, scene):
    r = lsc.solve(scene, method=method)
    assert r.method.startswith(method)
    assert isinstance(r.tolerances, dict) and isinstance(r.stats, dict)
    assert r.stats.get("wall_time", 0) >= 0
    if method == "scipy":
        assert r.tolerances["rtol"] == 1e-10 and r.stats["steps"] > 0
        assert r.stats["rhs_evaluations"] > 0
    if method == "reference":
        assert r.tolerances.get("dt") == 1e-5
