"""Hunt–Crossley by target restitution: ``a = α v0`` solves ``a (1 + e) = ln[(1 + a)/(1 - a e)]``
for every ``e`` in (0, 1] (the bracket used to stop short of the root below e ≈ 0.033), and a
scene with such a target rebounds at that restitution."""

import mpmath as mp
import numpy as np
import pytest

import lsc
from lsc.contact import hunt_crossley_a


def _root(e: float):
    """The root in 50-digit arithmetic, by bisection on ``L = -ln(1 - a e)`` (the relation
    ``L = a (1 + e) - ln(1 + a)``, ``a = (1 - e^{-L})/e``), independent of the code's method."""
    with mp.workdps(50):
        e = mp.mpf(e)

        def g(L):
            a = -mp.expm1(-L) / e
            return a * (1 + e) - mp.log1p(a) - L

        lo, hi = mp.mpf(10) ** -40, (1 + e) / e
        for _ in range(300):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if g(mid) > 0 else (lo, mid)
        return -mp.expm1(-lo) / e


@pytest.mark.parametrize("e", [*np.logspace(-6, 0, 25)[:-1], 0.5, 0.9, 0.999999, 1 - 1e-9])
def test_a_solves_the_restitution_relation(e):
    a = hunt_crossley_a(float(e))
    root = _root(float(e))
    assert abs(mp.mpf(a) - root) <= 1e-12 * root
    with mp.workdps(50):   # the relation itself, where float64 a resolves 1 - a e
        if 1 - a * e > 1e-3:
            a_, e_ = mp.mpf(a), mp.mpf(e)
            lhs, rhs = a_ * (1 + e_), mp.log((1 + a_) / (1 - a_ * e_))
            assert abs(lhs - rhs) <= 1e-12 * lhs


def test_elastic_and_plastic_ends():
    assert hunt_crossley_a(1.0) == 0.0
    with pytest.raises(ValueError, match=r"must be in \(0, 1\], got 0.0"):
        hunt_crossley_a(0.0)
    scene = {"vehicles": [{"mass": 1000, "speed": 5}, {"mass": 1000, "speed": 0}],
             "contacts": [{"law": "hunt-crossley", "stiffness": 1e6, "restitution": 0}]}
    with pytest.raises(lsc.SceneError, match="e = 0 needs an infinite damping"):
        lsc.solve(scene)


@pytest.mark.parametrize("e", [0.01, 1e-3])
def test_low_target_restitution_scene_rebounds_at_it(e):
    scene = {"vehicles": [{"mass": 1000, "speed": 5}, {"mass": 1500, "speed": 0}],
             "contacts": [{"law": "hunt-crossley", "stiffness": 1e6, "restitution": e}]}
    r = lsc.solve(scene, rtol=1e-12)
    assert r.restitution[0] == pytest.approx(e, rel=1e-8)
    # momentum, and ΔV = (1 + e) times the plastic one
    assert r.delta_v[1] == pytest.approx((1 + e) * 1000 * 5 / 2500, rel=1e-8)


def test_a_damping_law_that_chatters_at_its_event_limit_says_how_and_what_solves_it():
    """Hunt–Crossley at e = 1e-12: its restoring factor 1 + α dD/dt is far stiffer than DOP853
    (auto's integrator before it took Radau for such a contact: tests/test_auto_integrator.py)
    steps, and the turn and the recompression alternate to the event limit.
    The message said only "check the scene for contacts that chatter"; it now names the contact,
    its events and what solves it, and that does (ΔV the plastic one)."""
    from test_fd_step_floor import PLASTIC_DV, _scene

    with pytest.raises(lsc.SimulationError) as err:
        lsc.solve(_scene(1e-12), method="scipy", integrator="DOP853", max_events=40)
    assert str(err.value) == (
        "event limit reached (40 events by t = 1.09356e-05 s) and the crash is not over: raise "
        "solver.max_events, or check the scene for contacts that chatter; contact 0 chatters, "
        "its last 20 of 20 events: recompression x10, max_deformation x10 (its damping law's "
        "restoring factor is stiffer at this restitution than an explicit integrator steps: "
        "solve with integrator='Radau' or method='diffrax')")
    r = lsc.solve(_scene(1e-12), method="scipy", integrator="Radau")
    np.testing.assert_allclose(r.delta_v, PLASTIC_DV, rtol=1e-9)
