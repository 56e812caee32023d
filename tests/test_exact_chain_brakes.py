"""Braking (stick and slip) in the exact chain backend: closed forms (a stuck car is a wall
whose contact force stays below its static limit; a sliding car stops v/(μ g) after it
separates, v²/(2 μ g) further on), the energy balance with the friction work, agreement with the
tightest SciPy solve on random braked chains (the same events, every metric), the modes of a
chain with held vehicles against an independent eigensolve, and what ``auto`` picks.
(tests/test_exact_chain.py holds braked chains to the independent modal solution.)
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, reject, settings

import lsc
from lsc.model import HybridModel
from lsc.solvers.exact_chain._modes import Shape, deformation_map

from hard.modal_compare import (after_touching, metric_errors, reference, tie_order,
                                without_touches)
from helpers import HARD
from test_exact_chain import PRESSED, chains, pushed_at_break_away

#: Random braked chains against the tightest SciPy solve (--hard: 60).
SCIPY_CASES = 60 if HARD else 4


def _scene(vehicles, contacts):
    return {"units": "US", "vehicles": vehicles, "contacts": contacts}


def _friction_balance(r) -> float:
    """``|KE(0) - KE(end) - Σ (absorbed - returned) - Σ μ m g (path slid)|`` relative to KE(0),
    over the whole run (every contact open at its end): the path of each braked vehicle is the
    sum of ``|Δx|`` over the samples, exact since every stop and reversal is a sample (its
    velocity keeps one sign in between); a stuck vehicle does not move (static friction does
    no work)."""
    m, g = r.scene.masses, r.scene.g
    assert np.all(r.force[-1] == 0.0)
    ke0 = 0.5 * m @ r.scene.speeds ** 2
    friction = sum(v.brake.mu * m[i] * g * np.sum(np.abs(np.diff(r.x[:, i])))
                   for i, v in enumerate(r.scene.vehicles) if v.brake is not None)
    lost = ke0 - 0.5 * m @ r.v[-1] ** 2
    return abs(lost - float(np.sum(r.energy_absorbed - r.energy_returned)) - friction) / ke0


def test_a_stuck_car_is_a_wall_its_contact_force_below_the_static_limit():
    """A car (100 slug, 5 ft/s) strikes a braked one whose static limit (5 m g = 12,870 lbf) its
    peak force (v sqrt(k m) = 7,746 lbf) stays below: the struck car never moves (x = 0 and
    v = 0 at every sample, no break-away, acceleration 0), the third car 1 ft ahead is never
    reached, and the striking car rebounds from a wall: max deformation v sqrt(m/k), peak force
    v sqrt(k m), permanent set (1 - e²) of the max, ΔV -(1 + e) v, duration (1 + e) π/2
    sqrt(m/k) (loading, then unloading on the line of slope k/e²)."""
    m, v, k, e = 100.0, 5.0, 24000.0, 0.4
    scene = _scene([{"mass": m, "speed": v},
                    {"mass": 80.0, "speed": 0.0, "brake": {"mu": 0.7, "mu_static": 5.0}},
                    {"mass": 120.0, "speed": 0.0}],
                   [{"loading": {"stiffness": k}, "unloading": {"restitution": e}},
                    {"loading": {"stiffness": 5000.0}, "unloading": {"restitution": 0.5},
                     "gap": 1.0}])
    r = lsc.solve(scene)
    assert r.method == "exact-chain"
    limit = 5.0 * 80.0 * r.scene.g
    assert [(ev.index, ev.kind) for ev in r.events] == [(0, "contact"), (0, "max_deformation"),
                                                        (0, "separation")]
    assert np.all(r.x[:, 1] == 0.0) and np.all(r.v[:, 1] == 0.0) and np.all(r.a[:, 1] == 0.0)
    assert r.peak_acceleration[1] == 0.0
    assert np.max(r.force[:, 0]) <= r.peak_force[0] < limit
    dmax = v * np.sqrt(m / k)
    assert r.max_deformation[0] == pytest.approx(dmax, rel=1e-13)
    assert r.peak_force[0] == pytest.approx(v * np.sqrt(k * m), rel=1e-13)
    assert r.permanent_deformation[0] == pytest.approx((1 - e * e) * dmax, rel=1e-13)
    assert r.delta_v[0] == pytest.approx(-(1 + e) * v, rel=1e-13)
    assert r.duration == pytest.approx((1 + e) * np.pi / 2 * np.sqrt(m / k), rel=1e-13)
    assert r.max_deformation[1] == 0.0


def test_sliding_cars_stop_v_over_mu_g_after_they_separate():
    """A car strikes a braked one at rest (it breaks away once the force passes μ_s m g),
    both braked; after the separation each slides on at its speed there, decelerating at μ g:
    each stops |v|/(μ g) later, |v|²/(2 μ g) further on, at rest exactly (the rear car, braked
    harder, never reaches the front one again; the third car is 40 ft ahead). The energy lost
    is the bumpers' net absorbed energy plus the friction work μ m g times each path; each
    car's peak acceleration carries its friction's constant deceleration."""
    mu = (0.9, 0.3)
    scene = _scene([{"mass": 100.0, "speed": 12.0, "brake": {"mu": mu[0]}},
                    {"mass": 70.0, "speed": 0.0, "brake": {"mu": mu[1], "mu_static": 0.4}},
                    {"mass": 100.0, "speed": 0.0}],
                   [{"loading": {"stiffness": 30000.0}, "unloading": {"restitution": 0.5}},
                    {"loading": {"stiffness": 5000.0}, "unloading": {"restitution": 0.5},
                     "gap": 40.0}])
    r = lsc.solve(scene, n_samples=50)
    assert r.method == "exact-chain"
    g = r.scene.g
    kinds = [(ev.index, ev.kind) for ev in r.events]
    assert kinds[:4] == [(0, "contact"), (1, "break_away"), (0, "max_deformation"),
                         (0, "separation")]
    t_sep = r.events[3].time
    stops = {ev.index: ev.time for ev in r.events[4:]}
    assert sorted(kinds[4:]) == [(0, "stop"), (1, "stop")]
    at_sep = np.flatnonzero(r.t == t_sep)[-1]
    for i in (0, 1):
        v = r.v[at_sep, i]
        assert v == r.v_final[i]
        at_stop = np.flatnonzero(r.t == stops[i])[-1]
        assert stops[i] - t_sep == pytest.approx(abs(v) / (mu[i] * g), rel=1e-12)
        assert r.x[at_stop, i] - r.x[at_sep, i] == pytest.approx(
            np.sign(v) * v * v / (2 * mu[i] * g), rel=1e-12)
        assert r.v[at_stop, i] == 0.0 and np.all(r.v[at_stop:, i] == 0.0)
    assert r.v_final[1] > r.v_final[0] > 0
    assert _friction_balance(r) <= 1e-12
    # the peak accelerations, both cars sliding forward at the peak force: the contact force's
    # and the friction's together (-F/m - μ g behind, F/m - μ g in front)
    F, m = r.peak_force[0], r.scene.masses
    assert r.peak_acceleration[0] == pytest.approx(-F / m[0] - mu[0] * g, rel=1e-12)
    assert r.peak_acceleration[1] == pytest.approx(F / m[1] - mu[1] * g, rel=1e-12)


def test_two_stuck_cars_pressed_together_every_metric_against_the_modal_solution():
    """PRESSED (tests/test_exact_chain.py: it ends with the second contact shut between two
    stuck cars) by exact-chain, what ``auto`` picks: the independent solution's events, every
    metric to 1e-10 of its scale, and the friction holding that contact shut (the front car
    stuck, its force below μ_s m g)."""
    events, ref = reference(PRESSED)
    assert ref["held"]
    r = lsc.solve(PRESSED)
    assert r.method == "exact-chain"
    same = without_touches(after_touching([(e.time, e.index, e.kind) for e in r.events],
                                          [0.0, 0.0]), events[-1][0])
    assert [e[1:] for e in same] == [e[1:] for e in without_touches(
        after_touching(events, [0.0, 0.0]), events[-1][0])]
    errors = metric_errors(r, r, ref, ref["closing_speed"])
    assert max(errors.values()) <= 1e-10, errors
    assert 0 < r.force[-1, 1] <= 0.8 * 100.0 * r.scene.g
    assert np.all(r.v[-1] == [r.v[-1, 0], 0.0, 0.0])


def _sequence(r, t_last):
    gaps = [c.gap for c in r.scene.contacts]
    return [e[1:] for e in tie_order(without_touches(after_touching(
        [(e.time, e.index, e.kind) for e in r.events], gaps), t_last), t_last)]


def _rounding_decides(scene, sequence, t_last) -> bool:
    """Whether moving one car's speed by 1e-14 of the fastest car's (each car in turn) changes
    exact-chain's ``sequence`` of events up to ``t_last`` [s] (or stops it): then rounding,
    not the physics, decides it. (The rear car alone is not enough: a six-car chain whose
    braked car, static and sliding friction alike, stops and breaks away again and again; only
    its own nudge, from rest, moves its break-aways, as SciPy's, 0.07 s apart by t = 3 s.)"""
    fastest = max(abs(v["speed"]) for v in scene["vehicles"])
    for car in range(len(scene["vehicles"])):
        moved = copy.deepcopy(scene)
        moved["vehicles"][car]["speed"] += 1e-14 * fastest
        try:
            if _sequence(lsc.solve(moved, max_events=300), t_last) != sequence:
                return True
        except lsc.SimulationError:
            return True
    return False


@settings(max_examples=SCIPY_CASES)
@given(chains(tables=True, e_min=0.2, pushed_shut=False, brakes=True))
def test_braked_chains_match_the_tightest_scipy_solve(scene):
    """Random braked chains: exact-chain and SciPy's DOP853 at rtol 1e-12 give the same sequence
    of events (stops and break-aways included) and every metric to 1e-8 of its scale, or within
    SciPy's own spread (its 1e-12 and 2.5e-14 solves' difference) where it has not converged;
    where every contact ends open, the energy balance with the friction work to 1e-12. (A
    chain either cannot finish in 300 events, a clear SimulationError, is not compared; nor
    one whose event sequence a relative change of 1e-14 in the rear car's speed changes:
    rounding's; nor one with a contact pushed on at a break-away, see
    test_exact_chain.pushed_at_break_away.)"""
    try:
        r = lsc.solve(scene, max_events=300)
    except lsc.SimulationError:
        # (cars rattling for ever between two stuck ones, each bounce elastic along an
        # unloading line below its max, the stuck cars' static limits never reached: the
        # event limit, a clear error)
        reject()
    assert r.method == "exact-chain"
    if pushed_at_break_away(r):
        reject()   # (SciPy records that contact a moment late: see pushed_at_break_away)
    try:
        s = lsc.solve(scene, method="scipy", integrator="DOP853", rtol=1e-12, max_events=300,
                      max_steps=3000)
    except lsc.SimulationError:
        reject()
    t_last = r.events[-1].time
    if _sequence(r, t_last) != _sequence(s, t_last):
        if _rounding_decides(scene, _sequence(r, t_last), t_last):
            reject()
        assert _sequence(r, t_last) == _sequence(s, t_last)
    closing = np.array([np.nan if m is None else m.closing_speed for m in
                        [next((i for i in r.impacts if i.contact == k), None)
                         for k in range(len(r.scene.contacts))]])
    tighter = None
    for name, err in metric_errors(r, r, s, closing).items():
        if err > 1e-8 and tighter is None:
            tighter = lsc.solve(scene, method="scipy", integrator="DOP853", rtol=2.5e-14,
                                max_steps=10**6, max_events=300)
        spread = 0.0 if tighter is None else metric_errors(r, s, tighter, closing)[name]
        assert err <= 1e-8 + 2 * spread, (name, getattr(r, name), getattr(s, name), err, spread)
    if np.all(r.force[-1] == 0.0):
        assert _friction_balance(r) <= 1e-12


def test_the_modes_of_a_chain_with_held_vehicles_are_those_of_the_free_ones():
    """``Shape`` with held vehicles: their rows of ``T`` vanish (they do not move), and the
    modes are the generalized eigenproblem of the free vehicles alone (``K_ff φ = κ M_ff φ``,
    scipy.linalg.eigh), with a rigid mode only for a group of free vehicles joined to no held
    one by a contact of non-zero slope: 5 vehicles, vehicle 2 held, contacts 0 and 1 sloped (the
    group {0, 1} grounded by contact 1: no rigid mode), contact 2 open and 3 sloped (the group
    {3, 4} free: one rigid mode, its common translation)."""
    m = np.array([100.0, 60.0, 80.0, 150.0, 90.0])
    slope = np.array([2.0e4, 5.0e5, 0.0, 3.0e3])
    C = deformation_map(5)
    shape = Shape(m, slope, -C.T, (2,))
    free = [0, 1, 3, 4]
    K = (C.T * slope) @ C
    kappa = scipy.linalg.eigh(K[np.ix_(free, free)], np.diag(m[free]), eigvals_only=True)
    assert np.all(shape.T[2] == 0.0)
    assert shape.modes.kappa.size == 4
    assert np.sort(shape.modes.kappa) == pytest.approx(np.sort(kappa), rel=1e-12, abs=1e-9)
    assert shape.modes.rigid.tolist() == [0]
    rigid = shape.T[:, 0]
    assert rigid[[0, 1, 2]].tolist() == [0.0, 0.0, 0.0] and rigid[3] == rigid[4] != 0.0
    # (orthonormal in the mass metric: Tᵀ M T = I)
    assert shape.T.T @ (m[:, None] * shape.T) == pytest.approx(np.eye(4), abs=1e-13)


def test_auto_picks_exact_chain_for_braked_chains_and_exact_for_two_vehicles():
    """A braked chain: exact-chain declares it (``auto`` picks it), its batch path does not
    (braking is not batched); a braked two-vehicle scene keeps the exact backend."""
    chain = HybridModel(lsc.Scene.load(PRESSED))
    assert "effect:brake" in chain.features()
    exact_chain = lsc.solvers.backend("exact-chain")
    assert exact_chain.missing(chain) == []
    assert lsc.solvers.pick(chain, "auto") == "exact-chain"
    assert exact_chain.missing(chain, batch=True) == ["it does not solve braking"]
    pair = _scene(PRESSED["vehicles"][:2], PRESSED["contacts"][:1])
    assert lsc.solvers.pick(HybridModel(lsc.Scene.load(pair)), "auto") == "exact"
    assert lsc.solve(pair).method == "exact"


def test_two_braked_cars_that_end_pressed_together_finish_in_exact():
    """Two braked cars (the rear one at 1 ft/s, the front one stuck, the contact force below
    its static friction): the rear car stops at the max deformation and the pair stays pressed,
    a crash that is over (HybridModel.is_over). The two-vehicle exact backend (auto's pick)
    asked the model only once every contact was open, and stopped at the event limit at
    t = 0.0387 s; it now ends there as SciPy does, with the same events."""
    scene = {"units": "US",
             "vehicles": [{"mass": 100.0, "speed": 1.0, "brake": {"mu": 0.8}},
                          {"mass": 100.0, "speed": 0.0, "brake": {"mu": 0.8}}],
             "contacts": [{"loading": {"stiffness": 1000.0}, "unloading": {"restitution": 1.0}}]}
    r = lsc.solve(scene)
    ref = lsc.solve(scene, method="scipy", rtol=1e-12)
    assert r.method == "exact"
    assert [(e.kind, e.index) for e in r.events] == [(e.kind, e.index) for e in ref.events]
    assert [e.kind for e in r.events][-2:] == ["max_deformation", "stop"]
    assert abs(r.events[-1].time - ref.events[-1].time) <= 1e-9
    assert np.array_equal(r.v_final, [0.0, 0.0])
