"""The diffrax batch metrics (``lsc.sweep(method="diffrax")``, the autodiff sensitivities) are
the Result's: each vehicle's and each contact's first impact, member by member."""

import numpy as np
import pytest

pytest.importorskip("diffrax")

import lsc  # noqa: E402
from lsc.result import METRICS  # noqa: E402
from helpers import paper_scene  # noqa: E402

# a struck car braking to a stop before the bullet (braked too) reaches it across a 3 ft gap
BRAKED = {"units": "US", "g": "32.2 ft/s^2",
          "vehicles": [{"weight": 3500, "speed": 15, "brake": {"mu": 0.3}},
                       {"weight": 3000, "speed": 5, "brake": {"mu": 0.7, "mu_static": 0.8}}],
          "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4},
                        "gap": 3.0}]}
# the light middle car rebounds off the front car into the bullet: both contacts close twice
# (with no gap before the front car, contact 1 is pushed shut instead: restitution NaN)
CHAIN = {"units": "SI",
         "vehicles": [{"mass": 1500, "speed": 5.0}, {"mass": 800, "speed": 0.0},
                      {"mass": 2000, "speed": 0.0}],
         "contacts": [{"loading": {"stiffness": 2e5}, "unloading": {"restitution": 0.8}},
                      {"loading": {"stiffness": 2e5}, "unloading": {"restitution": 0.3},
                       "gap": 0.3}]}
CASES = {"braked": (BRAKED, {"vehicles.0.speed": [15.0, 12.0]}),
         "chain": (CHAIN, {"vehicles.0.speed": [5.0, 4.0], "contacts.1.gap": [0.3, 0.0]}),
         "paper": (paper_scene(), {"vehicles.0.speed": [10.0, 14.0],
                                   "contacts.0.unloading.restitution": [0.1, 0.7]})}


def _close(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.array_equal(np.isnan(a), np.isnan(b)) and \
        np.allclose(a[~np.isnan(a)], b[~np.isnan(b)], rtol=1e-9, atol=0)


@pytest.mark.parametrize("case", list(CASES))
def test_sweep_members_equal_single_solves(case):
    scene, params = CASES[case]
    s = lsc.sweep(scene, params, method="diffrax")
    assert list(s.status) == ["ok", "ok"]
    base = lsc.Scene.load(scene)
    for j in range(2):
        member = base.with_values({p: float(v[j]) for p, v in params.items()})
        r = lsc.solve(member, method="diffrax")
        for name in METRICS:
            assert _close(getattr(s, name)[j], getattr(r, name)), (j, name)
        first = r.first_impact
        assert s.duration[j] == pytest.approx(first.duration, rel=1e-9)
        if case == "braked":   # the struck car stopped before the touch: ΔV from rest
            assert abs(first.v_start[1]) < 1e-12
            assert s.delta_v[j][1] == pytest.approx(r.v_final[1], rel=1e-9)
            assert abs(s.delta_v[j][1] - r.delta_v_total[1]) > 4.0
        if case == "chain" and params["contacts.1.gap"][j] > 0:
            touches = [ev.index for ev in r.events if ev.kind == "contact"]
            assert touches.count(0) == 2
            m0 = next(m for m in r.impacts if m.contact == 0)
            assert s.duration[j] == pytest.approx(m0.t_end, rel=1e-9) and m0.t_start == 0.0
            assert r.duration_total > 2 * r.duration
            assert np.all(np.isfinite(s.restitution[j]))
        if case == "chain" and params["contacts.1.gap"][j] == 0:   # pushed shut
            assert np.isnan(s.restitution[j][1]) and np.isfinite(s.restitution[j][0])
