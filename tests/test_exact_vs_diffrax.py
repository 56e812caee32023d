"""The exact piecewise backend against the tightest diffrax solve on random piecewise-linear
scenes (issue: ``exact`` agrees with the tightest SciPy *and* diffrax solves to 1e-10; the SciPy
half is in test_exact.py)."""

import pytest
from hypothesis import HealthCheck, given, settings
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
