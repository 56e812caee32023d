"""Locked pairs in diffrax (issue 13, item 5: "in the exact backend and in the integrators
alike"): the transitions of lsc.locking.LockingModel run inside the compiled segment loop
(``xp = jax.numpy``, each condition a select), the same rules as SciPy's.

- Diffrax against SciPy (both at rtol 1e-12) on stored chattering chains: the same events
  (kind and contact, the lock, release and separation events included, events at one instant
  in either order; the times of the locks, releases and separations to 1e-9 of the duration), every metric to the integrators' tolerance (tests/hard/common.py
  ``check_agrees``), momentum to 1e-14, the energy balance (``check_result``), and the lock
  warning on the Result, the same as SciPy's.
- A chain the plain law finishes (PLAIN_CHAIN, e = 0.001: a contact that may lock, no lock
  fires) is, in diffrax, the plain law's solve bit for bit (the model without locks).
- The batch path hands the members whose pairs may lock to the single solve: their metrics are
  the single solve's.

All default tests share one scene structure (three cars, linear loading, restitution, the
default solver options): one compile, kept by the persistent compilation cache.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("diffrax")

import lsc  # noqa: E402
import lsc.locking  # noqa: E402
from hard.common import HARD, chain, check_agrees, check_result, momentum_error  # noqa: E402
from test_exact_chain_locks import TIED_RELEASE, _events, _pushed  # noqa: E402
from test_locked_pairs import (CHATTERING_CHAINS, FEW_EVENTS, PLAIN_CHAIN, V0,  # noqa: E402
                               _locks)

RTOL = 1e-12   # both integrators' tolerance in the comparisons


def _against_scipy(scene):
    """The diffrax and SciPy solves of ``scene`` agree: events, metrics, conservation, the
    lock warning (the module)."""
    r = lsc.solve(scene, method="diffrax", rtol=RTOL)
    ref = lsc.solve(scene, method="scipy", rtol=RTOL, max_events=FEW_EVENTS)
    assert r.method == "diffrax-Dopri8" and _locks(r)
    # (events at one instant, to rounding, may be listed in either order: contacts closing
    # together; a cluster's release and its pusher's separation, TIED_RELEASE)
    assert sorted(_events(r)) == sorted(_events(ref)) and len(r.events) < FEW_EVENTS
    for kind_index in set(_events(r)):
        if "lock" in kind_index[0] or "separation" in kind_index[0]:
            times = [[e.time for e in x.events if (e.kind, e.index) == kind_index]
                     for x in (r, ref)]
            assert np.allclose(*times, rtol=0, atol=1e-9 * ref.duration), (kind_index, times)
    check_agrees(r, ref)   # ΔV, energies, max deformations to the integrators' tolerance
    check_result(r)
    assert momentum_error(r) <= 1e-14
    assert r.warnings == ref.warnings == (lsc.locking.warning(_locks(r)),)
    return r


#: Three cars that lock by rule 1 (a pair pushed shut, e = 0; e = 1e-6 behind a gap) and by
#: rule 2 (a pair pressed on its line, e = 0.03, locks after 8 closings): one scene structure.
@pytest.mark.parametrize("scene", [_pushed(2e6), CHATTERING_CHAINS[4], _pushed(2e5, 0.03)],
                         ids=["pushed-pair", "e1e-6-gaps", "counted"])
def test_diffrax_locks_where_scipy_locks(scene):
    _against_scipy(scene)


#: CHATTERING_CHAINS[4]'s contact 1 (e = 1e-6) rebounds on a line of 5.4e18 lbf/ft, 7e-16 ft
#: wide, 167 ft from where the cars started: one ulp of the absolute positions (2.8e-14 ft) is
#: 1.5e5 lbf on that line. diffrax's Result reported a peak force of 3.09e5 lbf there (SciPy
#: and the event rows: F_max = 3891.5 lbf), found inside a segment on its dense output; a rise
#: above the segment's ends within the positions' rounding is no peak now
#: (lsc.solvers.segments._rounding_floor). So is _pushed(2e6) at e = 1e-6 (2814 for 2370 lbf).
@pytest.mark.parametrize("scene", [_pushed(2e6), CHATTERING_CHAINS[4], _pushed(2e5, 0.03),
                                   _pushed(2e6, 1e-6)],
                         ids=["pushed-pair", "e1e-6-gaps", "counted", "pushed-e1e-6"])
def test_peak_forces_against_scipy(scene):
    r = lsc.solve(scene, method="diffrax", rtol=RTOL)
    ref = lsc.solve(scene, method="scipy", rtol=RTOL, max_events=FEW_EVENTS)
    assert np.allclose(r.peak_force, ref.peak_force, rtol=1e-8, atol=0)


def test_a_locked_pair_holds_its_deformation_and_shares_one_acceleration():
    """While locked, the pair's vehicles have one acceleration exactly, so its deformation
    moves only by the residual closing rate at the lock (the max deformation located to the
    tolerance, ``rtol`` of the speed scale: SciPy's drifts the same, 7e-13 ft in 6 ms)."""
    rtol = 1e-10
    r = lsc.solve(_pushed(2e6), method="diffrax", rtol=rtol)
    spans = [(a.time, b.time) for a, b in zip(r.events, r.events[1:])
             if a.kind == "max_deformation+lock" and b.kind == "unlock"]
    t_lock, t_free = max(spans, key=lambda span: span[1] - span[0])
    inside = (r.t > t_lock) & (r.t < t_free)
    held = r.deformation[inside, 1]
    assert held.size > 3 and np.ptp(held) <= rtol * V0 * (t_free - t_lock)
    assert np.array_equal(r.a[inside, 1], r.a[inside, 2])


def test_a_chain_the_plain_law_finishes_is_the_plain_law_bit_for_bit(monkeypatch):
    m, v, k, e, gaps = PLAIN_CHAIN
    scene = chain(m, v, [{"loading": {"stiffness": ki}, "unloading": {"restitution": ei},
                          "gap": gi} for ki, ei, gi in zip(k, e, gaps)])
    r = lsc.solve(scene, method="diffrax")
    import lsc.solvers.diffrax_ode.single as single

    monkeypatch.setattr(single, "locking_model", lambda model: model)
    plain = lsc.solve(scene, method="diffrax")
    assert r.warnings == () and not _locks(r)
    assert [(e.time, e.kind, e.index) for e in r.events] == \
        [(e.time, e.kind, e.index) for e in plain.events]
    for name in ("v_final", "delta_v", "peak_force", "max_deformation", "energy_absorbed"):
        assert np.array_equal(getattr(r, name), getattr(plain, name)), name


def test_the_batch_hands_pairs_that_may_lock_to_the_single_solve():
    scene = _pushed(2e6)
    e = np.array([0.0, 1e-6])   # (rule 1 both: each solve fits the first dense record)
    out = lsc.solvers.backend("diffrax").solve_batch(
        lsc.model.HybridModel(lsc.Scene.load(scene)), {"contacts.1.unloading.restitution": e})
    assert list(out["status"]) == ["ok", "ok"]
    for j, ej in enumerate(e):
        scene["contacts"][1]["unloading"]["restitution"] = float(ej)
        r = lsc.solve(scene, method="diffrax")
        assert _locks(r)
        for name, arr in out["metrics"].items():
            assert np.array_equal(arr[j], getattr(r, name), equal_nan=True), name


def test_diffrax_declares_locked_pairs():
    d = lsc.solvers.backend("diffrax")
    assert lsc.locking.FEATURE in d.solves and lsc.locking.FEATURE in d.batch


# ------------------------------------------------------------------ hard mode: more structures
@pytest.mark.skipif(not HARD, reason="hard mode only (pytest --hard): a compile per structure")
@pytest.mark.parametrize("scene", [CHATTERING_CHAINS[0], CHATTERING_CHAINS[3], TIED_RELEASE],
                         ids=["e0-tables", "counted-4cars", "tied-release"])
def test_diffrax_locks_where_scipy_locks_other_structures(scene):
    _against_scipy(scene)
