"""The exact piecewise backend against the tightest diffrax solve on random piecewise-linear
scenes (issue: ``exact`` agrees with the tightest SciPy *and* diffrax solves to 1e-10; the SciPy
half is in test_exact.py)."""

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

pytest.importorskip("diffrax")

import lsc  # noqa: E402

from lsc.model import HybridModel  # noqa: E402
from lsc.scene import Restitution  # noqa: E402
from lsc.solvers import diffrax_ode, exact  # noqa: E402
from test_exact import _energy_check, _table_ends_first, assert_metrics_close, table_scenes  # noqa: E402

# One scene structure (four loading segments, an extending end, a restitution unloading), so the
# diffrax solve compiles once and every example reuses it.
_unloading = st.builds(Restitution, st.sampled_from([0.0, 0.4, 1.0]) | st.floats(0.05, 1.0))


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(table_scenes(n_seg=4, extends=True, unloading=_unloading))
def test_exact_matches_diffrax_on_random_tables(sc):
    assert not _table_ends_first(sc)  # the table extends: the crash always completes
    model = HybridModel(sc)
    try:
        ex = exact.solve(model)
    except lsc.SimulationError as err:
        # (a restitution line from a dip that would need a negative permanent set: diffrax must
        # refuse the same scene with the same reason, at the same time)
        with pytest.raises(lsc.SimulationError) as dx_err:
            diffrax_ode.solve(model, integrator="Dopri8", rtol=1e-13)
        ex_t, ex_msg = str(err).split(" s: ", 1)
        dx_t, dx_msg = str(dx_err.value).split(" s: ", 1)
        assert dx_msg == ex_msg and dx_t == ex_t
        return
    _energy_check(sc, ex)
    dx = diffrax_ode.solve(model, integrator="Dopri8", rtol=1e-13)
    assert_metrics_close(ex, dx, sc.masses, 1e-10)
    assert [(e.kind, e.index) for e in ex.events] == [(e.kind, e.index) for e in dx.events]
    for a, b in zip(ex.events, dx.events):
        assert abs(a.time - b.time) <= 1e-10 * ex.duration


# ------------------------------------------------------------------ chains (exact-chain)
from hard.common import log_uniform  # noqa: E402
from helpers import HARD  # noqa: E402
from lsc.result import METRICS  # noqa: E402

import numpy as np  # noqa: E402


@st.composite
def three_car_chains(draw):
    """A US three-car chain on linear contacts (one compiled diffrax shape for them all): masses
    within 1:20, stiffnesses 1e3 to 1e7 lbf/ft, restitutions 0.2 to 1, gaps of 1e-3 to 1 ft (no
    contact touching at no closing speed, which an integrator closes a moment late), the middle
    car closing on the front one or not."""
    m = [draw(log_uniform(50.0, 1000.0)) for _ in range(3)]
    v2 = draw(st.floats(-10.0, 20.0))
    v1 = v2 + draw(st.one_of(st.just(0.0), log_uniform(0.1, 30.0)))
    v0 = v1 + draw(log_uniform(0.1, 30.0))
    contacts = [{"loading": {"stiffness": draw(log_uniform(1e3, 1e7))},
                 "unloading": {"restitution": draw(st.floats(0.2, 1.0))},
                 "gap": draw(log_uniform(1e-3, 1.0))} for _ in range(2)]
    return {"units": "US", "vehicles": [{"mass": mi, "speed": vi} for mi, vi in
                                        zip(m, (v0, v1, v2))], "contacts": contacts}


#: Found by this test (the middle car's two near-equal peaks: test_metrics.py)
from hard.modal_compare import metric_scale, tie_order, without_touches  # noqa: E402
from test_metrics import TWO_PEAKS  # noqa: E402


@settings(max_examples=300 if HARD else 30, deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(three_car_chains())
@example(TWO_PEAKS)
def test_exact_chain_matches_the_tightest_diffrax_solve_on_random_chains(scene):
    """exact-chain against diffrax (Dopri8, rtol 1e-13) on random three-car chains: the same
    events, their times to 1e-8 of the run (a contact closing after a long flight at a small
    closing rate, a difference of speeds each known to ~1e-11, is timed to that over the rate:
    2e-8 of a 166 s run measured), every metric to 1e-10 of its scale (the peaks, which
    diffrax locates on its dense output, an interpolant less accurate than its steps, to 1e-8:
    up to 1.9e-9 measured on peak forces and accelerations next to a contact of 1e6 lbf/ft,
    where SciPy at rtol 1e-13 is 6e-11 from exact-chain's value)."""
    ex = lsc.solve(scene, method="exact-chain")
    # (a light middle car rattling between heavy ones: 286 events, past diffrax's default 256)
    dx = lsc.solve(scene, method="diffrax", integrator="Dopri8", rtol=1e-13, max_events=1024)
    t_run = ex.events[-1].time
    # (simultaneous events in rounding's order, and a contact reloaded back exactly to its max
    # deformation, a tangency rounding reads either way: as the modal comparison takes them)
    ours, theirs = (tie_order(without_touches([(e.time, e.index, e.kind) for e in r.events],
                                                t_run), t_run) for r in (ex, dx))
    assert [e[1:] for e in ours] == [e[1:] for e in theirs]
    assert max(abs(a[0] - b[0]) for a, b in zip(ours, theirs)) <= 1e-8 * t_run
    for name in METRICS:
        a, b = (np.asarray(getattr(r, name), float) for r in (ex, dx))
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
        scale = metric_scale(ex, name)
        if name.startswith("peak_acceleration"):
            # (a middle car's is the difference of its two contacts' forces over its mass: on
            # their scale, 10 ft/s² where the difference peaked at 1.78)
            pushes = np.max(np.maximum(np.r_[0.0, ex.peak_force], np.r_[ex.peak_force, 0.0])
                            / ex.scene.masses)
            scale = max(scale, pushes / (ex.scene.g if name.endswith("_g") else 1.0))
        tol = (1e-8 if name.startswith("peak") else 1e-10) * scale
        np.testing.assert_allclose(a, b, rtol=0, atol=tol, equal_nan=True, err_msg=name)
