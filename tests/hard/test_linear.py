"""Hard cases, two vehicles with a linear loading branch: every backend against the closed form.

Restitution 0, 1e-6, 1 (and anything between), mass ratios 1:1000 to 1000:1, stiffness 1e2 to
1e9 lbf/ft, closing speeds 1e-4 to 150 ft/s, the front vehicle at rest or moving either way, with
the unloading given as a restitution or as a stiffness. Backends: closed form (the truth), exact,
SciPy (DOP853, RK45, LSODA), diffrax (Dopri8) where it is installed.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import lsc

from .common import (check_agrees, check_result, closing_speeds, front_speeds, hard_settings,
                     have_diffrax, masses, restitutions, scipy_runs, stiffnesses, two_cars)


@st.composite
def linear_scenes(draw, unloading_kinds=("restitution", "stiffness")):
    (m1, m2), k, w, v2 = draw(masses), draw(stiffnesses), draw(closing_speeds), draw(front_speeds)
    e = draw(restitutions)
    kind = draw(st.sampled_from(unloading_kinds))
    if kind == "stiffness" and e > 0:
        unloading = {"stiffness": k / e**2}
    else:
        unloading = {"restitution": e}
    return two_cars(m1, m2, v2 + w, v2, {"stiffness": k}, unloading)


@hard_settings(150)
@given(linear_scenes())
def test_linear_every_backend_matches_the_closed_form(scene):
    ref = lsc.solve(scene, method="closed-form")
    check_result(ref)
    runs = [("exact", dict(method="exact"))] + scipy_runs()
    for name, kw in runs:
        r = lsc.solve(scene, **kw)
        check_result(r)
        check_agrees(r, ref)
        # every event the closed form has, at its time (relative to the pulse duration)
        kinds = [e.kind for e in r.events]
        assert kinds == [e.kind for e in ref.events], (name, kinds, ref.events)


@pytest.mark.skipif(not have_diffrax(), reason="diffrax (the [jax] extra) is not installed")
@hard_settings(60)
@given(linear_scenes(unloading_kinds=("restitution",)))
def test_linear_diffrax_matches_the_closed_form(scene):
    ref = lsc.solve(scene, method="closed-form")
    r = lsc.solve(scene, method="diffrax")
    check_result(r)
    check_agrees(r, ref)
