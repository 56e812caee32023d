"""Locked pairs (lsc/locking.py): a near-plastic contact of a chain that its neighbours keep
pressed shut moves as one body with its partner, instead of closing and separating to the event
limit (issue 13, item 5, SciPy side).

- Chains found by tests/hard/test_chains.py's ``chains`` strategy (e from 0 to 0.05, stiffness
  ratios up to 1:1e6 between neighbours), each of which reached the event limit before: they now
  finish with fewer than 200 events on DOP853 and RK45, conserve momentum to 1e-12 and close the
  energy balance (tests/hard/common.py: ``check_result``).
- A pair pushed shut from the start (two cars touching at rest, struck from behind) against the
  same crash with the pair replaced by one merged vehicle (the closed form of two cars, an
  independent solution): the difference is the stiff contact's own plastic work, ``O(k0/k1)``
  of the closing speed, so it must shrink in proportion as the pair's contact stiffens.
- The locked force: a cluster's force from its neighbours' forces and the masses
  (:func:`lsc.locking.cluster_forces`) against Newton's law written out by hand.
- Chains with restitutions from 0.05 up that SciPy finished before give the same events and
  metrics (to 1e-10) with the locks in the model as without them.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings

import lsc
import lsc.locking
from hard.common import chain, check_result, closing_scale
from hard.test_chains import chains as hard_chains

#: Fewer events than this (the brief's "a few events": the event limit was 10000).
FEW_EVENTS = 200

#: Near-plastic chains drawn by tests/hard/test_chains.py's ``chains(n_max=5, e_min=0,
#: e_max=0.05)`` that ran into the event limit (chatter) before locked pairs.
CHATTERING_CHAINS = json.loads(r'''[{"units": "US", "vehicles": [{"mass": 1.0, "speed": 1.0}, {"mass": 1.0, "speed": 0.0}, {"mass":
1.0, "speed": 0.0}], "contacts": [{"loading": {"table": [[0.0, 0.0], [0.001, 0.1], [0.002, 0.1],
[1000.0, 999998.1]]}, "unloading": {"restitution": 0.0}, "gap": 0.0}, {"loading": {"table":
[[0.0, 0.0], [0.001, 0.1], [0.002, 0.1], [1000.0, 999998.1]]}, "unloading": {"restitution":
0.0}, "gap": 0.0}]}, {"units": "US", "vehicles": [{"mass": 19.602864776451018, "speed":
0.4066572693680198}, {"mass": 2.350687125682806, "speed": 0.4066572693680198}, {"mass":
756.4884013783238, "speed": 0.4066572693680198}, {"mass": 26.418662489188655, "speed": 0.0}],
"contacts": [{"loading": {"table": [[0.0, 0.0], [0.049999999999999996, 29876.74577754425],
[0.09999999999999999, 29876.74577754425], [1000.0, 5974781497.339076]]}, "unloading":
{"restitution": 0.009999769744141627}, "gap": 0.0001000000000000001}, {"loading": {"stiffness":
11647.480311771056}, "unloading": {"restitution": 2.3113103430229777e-07}, "gap":
0.004597278872670903}, {"loading": {"table": [[0.0, 0.0], [0.009999769744141627,
94.514673546329], [0.019999539488283254, 94.514673546329], [1000.0, 94515054.07337098]]},
"unloading": {"restitution": 1e-15}, "gap": 0.0}]}, {"units": "US", "vehicles": [{"mass":
1.7782794100389228, "speed": 1.0}, {"mass": 100.0, "speed": 0.0}, {"mass": 9.263116555914255,
"speed": 0.0}, {"mass": 118.42331284413974, "speed": 0.0}, {"mass": 93.13731800332965, "speed":
0.0}], "contacts": [{"loading": {"stiffness": 1724.4615569999728}, "unloading": {"restitution":
0.03323653169365689}, "gap": 0.0}, {"loading": {"table": [[0.0, 0.0], [0.43677787560634157,
43.67879329043833], [0.8735557512126831, 43.67879329043833], [1000.0, 999193.1290435087]]},
"unloading": {"restitution": 0.0}, "gap": 0.0}, {"loading": {"table": [[0.0, 0.0],
[0.05156251301174242, 1896923.3263352325], [0.10312502602348483, 1896923.3263352325], [1000.0,
367852025879.5885]]}, "unloading": {"restitution": 5.5344414349209435e-09}, "gap": 0.0},
{"loading": {"stiffness": 889167.2466123292}, "unloading": {"restitution": 0.0}, "gap": 0.0}]},
{"units": "US", "vehicles": [{"mass": 132.4532426656715, "speed": 3.0}, {"mass": 1.0, "speed":
2.0}, {"mass": 329.46592644732743, "speed": 1.0}, {"mass": 4.221447032045464, "speed": 0.0}],
"contacts": [{"loading": {"table": [[0.0, 0.0], [0.05482514956306222, 5482.514956306222],
[0.10965029912612444, 5482.514956306222], [1000.0, 999895832.2158303]]}, "unloading":
{"restitution": 2.42562774637405e-08}, "gap": 0.003802217913970548}, {"loading": {"stiffness":
95151.30654528413}, "unloading": {"restitution": 0.024401259203239607}, "gap":
0.003802217913970548}, {"loading": {"table": [[0.0, 0.0], [0.3392265155529666,
530121.0698935665], [0.6784530311059332, 530121.0698935665], [1000.0, 15617275374.11387]]},
"unloading": {"restitution": 0.020518144815937455}, "gap": 0.003802217913970548}]}, {"units":
"US", "vehicles": [{"mass": 1.0, "speed": 51.469419581588}, {"mass": 44.10890939363327, "speed":
51.16152006980543}, {"mass": 91.48227675769708, "speed": 50.853620558022854}], "contacts":
[{"loading": {"stiffness": 2542.9006124087564}, "unloading": {"restitution": 1e-06}, "gap":
1.0}, {"loading": {"stiffness": 5365605.113904085}, "unloading": {"restitution": 1e-06}, "gap":
1.0}]}]''')


@pytest.mark.parametrize("integrator", ["DOP853", "RK45"])
@pytest.mark.parametrize("index", range(len(CHATTERING_CHAINS)))
def test_chattering_chains_finish_with_few_events(index, integrator):
    scene = CHATTERING_CHAINS[index]
    r = lsc.solve(scene, method="scipy", integrator=integrator, max_events=FEW_EVENTS)
    assert len(r.events) < FEW_EVENTS
    check_result(r)   # momentum to 1e-12, energy balance to the tolerance, all finite


M = (30.0, 40.0, 50.0)   # slug
V0 = 20.0                # ft/s
K_REAR = 2e3             # lbf/ft


def _pushed_pair(k_front: float, integrator: str):
    """Car 0 (e = 0.3) strikes cars 1 and 2, which touch at rest on a plastic contact of
    stiffness ``k_front``."""
    return lsc.solve(chain(list(M), [V0, 0.0, 0.0], [
        {"loading": {"stiffness": K_REAR}, "unloading": {"restitution": 0.3}, "gap": 0.0},
        {"loading": {"stiffness": k_front}, "unloading": {"restitution": 0.0}, "gap": 0.0}]),
        method="scipy", integrator=integrator)


@pytest.mark.parametrize("integrator", ["DOP853", "RK45"])
def test_pair_pushed_shut_moves_as_one_merged_vehicle(integrator):
    merged = lsc.solve(chain([M[0], M[1] + M[2]], [V0, 0.0], [
        {"loading": {"stiffness": K_REAR}, "unloading": {"restitution": 0.3}, "gap": 0.0}]),
        method="closed-form")
    offs = []
    for k_front in (2e5, 2e6, 2e7):
        r = _pushed_pair(k_front, integrator)
        check_result(r)
        assert len(r.events) < FEW_EVENTS
        assert any("lock" in e.kind for e in r.events)
        # the Result says the motion left the plain law (the other backends' model)
        locked = sorted({e.index for e in r.events if "lock" in e.kind.split("+")})
        assert r.warnings == (lsc.locking.warning(locked),) and locked == [1]
        # the pair leaves as one body
        assert abs(r.v_final[1] - r.v_final[2]) <= 1e-9 * V0
        dv = np.array([r.delta_v[0], r.delta_v[1]])
        off = float(np.max(np.abs(dv - merged.delta_v))) / closing_scale(r.scene)
        assert off <= 0.1 * K_REAR / k_front, (k_front, off)
        offs.append(off)
    # the pair's own contact work shrinks as it stiffens, and with it the difference
    assert offs[0] > 5 * offs[1] > 25 * offs[2]


def test_locked_force_is_newtons_law():
    from lsc.locking import cluster_forces, clusters

    m = np.array([2.0, 3.0, 5.0, 7.0, 11.0])
    F = np.array([13.0, 0.0, 0.0, 17.0])        # contacts 1 and 2 locked (their rows replaced)
    groups = clusters([1, 2], 5)
    assert groups == [(1, 3)]
    rows, accels = cluster_forces(F, m, groups, 4)
    (a, b, acc), = accels
    assert (a, b) == (1, 3)
    # the cluster (vehicles 1..3) pushed by contact 0 from behind and held by contact 3 in front
    assert acc == pytest.approx((13.0 - 17.0) / (3.0 + 5.0 + 7.0), rel=1e-15)
    # each vehicle of the cluster: its net force is its mass times the shared acceleration
    net = [F[0] - rows[1], rows[1] - rows[2], rows[2] - F[3]]
    assert np.allclose(net, m[1:4] * acc, rtol=1e-14, atol=1e-14)


# ------------------------------------------------------------------ chains that never locked
def _without_locks(monkeypatch):
    """SciPy solving the plain model, as before locked pairs (no LockingModel)."""
    import lsc.solvers.scipy_ode as scipy_ode

    monkeypatch.setattr(scipy_ode, "locking_model", lambda model: model)


#: The metrics compared with the solve before locked pairs.
SAME_METRICS = ("delta_v", "v_final", "peak_acceleration", "max_deformation",
                "permanent_deformation", "peak_force", "duration", "energy_absorbed")


@settings(max_examples=5, deadline=None)
@given(hard_chains(n_max=4, e_min=0.05).map(lambda case: case[1]))
def test_chains_that_did_not_chatter_are_unchanged(scene):
    """A chain the plain model solves (no event limit) gives the same metrics to 1e-10 with
    locks: the locks engage only where the plain model chatters (restitutions of 0.05 or more
    never lock at a max deformation; a slow closing again only locks a pressed turning point)."""
    with pytest.MonkeyPatch.context() as mp:
        _without_locks(mp)
        try:
            before = lsc.solve(scene, method="scipy", max_events=FEW_EVENTS)
        except lsc.SimulationError:
            return   # (chatters or rings: what the locks are for)
    after = lsc.solve(scene, method="scipy", max_events=FEW_EVENTS)
    assert [(e.time, e.kind, e.index) for e in after.events] == \
        [(e.time, e.kind, e.index) for e in before.events]
    for name in SAME_METRICS:
        a, b = np.asarray(getattr(after, name), float), np.asarray(getattr(before, name), float)
        assert np.all(np.abs(a - b) <= 1e-10 * np.max(np.abs(b), initial=1e-300)), name
