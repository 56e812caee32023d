"""Finite-difference sensitivities where a parameter is tiny against its scale: the step has a
floor at the solve's resolution, and a derivative that the floored stencil cannot resolve is
refused, never a wrong number.

A Hunt–Crossley crash at a target restitution of 1e-200: the relative step (1e-203) was far below
what a solve resolves (its ΔV is noisy at 1e-13), and the slope dΔV/de came out 4.8e187 where the
closed form gives the plastic ΔV (ΔV = (1 + e) times it: test_hunt_crossley_restitution.py)."""

import numpy as np
import pytest

import lsc
from lsc.analysis import sensitivity

M1, M2, V1 = 1000.0, 1500.0, 5.0
#: The slope of each vehicle's ΔV in e: the plastic ΔV [m/s].
PLASTIC_DV = np.array([-M2 * V1 / (M1 + M2), M1 * V1 / (M1 + M2)])


def _scene(e):
    return {"vehicles": [{"mass": M1, "speed": V1}, {"mass": M2, "speed": 0.0}],
            "contacts": [{"law": "hunt-crossley", "stiffness": 1e6, "exponent": 1.5,
                          "restitution": e}]}


@pytest.mark.parametrize("e", [1e-200, 1e-9])
def test_delta_v_slope_at_a_vanishing_restitution_is_the_plastic_delta_v(e):
    s = sensitivity(_scene(e), ["contacts.0.restitution"], method="finite-difference",
                    metrics=["delta_v"])
    np.testing.assert_allclose(s.derivatives["delta_v"][:, 0], PLASTIC_DV, rtol=1e-6)
    # the step: the floor, sqrt(rtol = 1e-12) of the restitution's scale (1)
    assert s.stats["steps"] == [1e-6]


def test_a_metric_the_floored_step_cannot_resolve_is_refused():
    """The pulse of a Hunt–Crossley contact at e = 1e-200 lasts 1e-80 s: its peak acceleration
    changes over a scale of e far below any resolvable step."""
    with pytest.raises(lsc.SimulationError) as err:
        sensitivity(_scene(1e-200), ["contacts.0.restitution"], method="finite-difference",
                    metrics=["delta_v", "peak_acceleration"])
    assert str(err.value) == (
        "contacts.0.restitution: the finite-difference derivative of peak_acceleration at "
        "1e-200 is not resolved: a solve resolves no step below 1e-06 there, and over that step "
        "the metric is not smooth (its fourth- and second-order differences disagree; a damping "
        "law's pulse at a vanishing restitution changes over a far smaller scale); give a "
        "larger value, or drop that metric")


def test_the_floor_leaves_an_ordinary_step_alone():
    """At e = 0.5 the relative step (5e-4) is above the floor: taken as before, and the slope
    of ΔV is still the plastic ΔV (the relation is linear in e)."""
    s = sensitivity(_scene(0.5), ["contacts.0.restitution"], method="finite-difference",
                    metrics=["delta_v"])
    assert s.stats["steps"] == [0.5 * 1e-3]
    np.testing.assert_allclose(s.derivatives["delta_v"][:, 0], PLASTIC_DV, rtol=1e-6)


def test_the_first_step_estimate_overflowing_is_no_warning():
    """SciPy's first-step estimate (its norm of the derivative) overflowed inside a
    Hunt–Crossley pulse at e = 1e-200 and a RuntimeWarning ('overflow encountered in dot')
    reached the user beside a right answer: the plastic ΔV, (1 + e) times it."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = lsc.solve(_scene(1e-200), method="scipy")
    np.testing.assert_allclose(r.delta_v, PLASTIC_DV, rtol=1e-9)


@pytest.mark.parametrize("e", [1e-9, 1e-6])
def test_an_overflowing_trial_step_is_no_warning(e):
    """At e = 1e-9 (and 1e-6) SciPy's trial steps across the Hunt–Crossley pulse overflowed the
    force (its damping ~1/e): SciPy rejected them and shortened the step, and some twenty
    RuntimeWarnings ('overflow encountered in scalar multiply', 'invalid value encountered in
    dot') reached the user beside a right answer, (1 + e) times the plastic ΔV. (DOP853 named:
    a solve that names none takes Radau at e = 1e-9, lsc.solvers.stiffness; Radau too.)"""
    import warnings

    for integrator in ("DOP853", "Radau"):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            r = lsc.solve(_scene(e), method="scipy", integrator=integrator)
        np.testing.assert_allclose(r.delta_v, (1 + e) * PLASTIC_DV, rtol=1e-8)
