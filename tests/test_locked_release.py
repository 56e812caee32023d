"""A locked pair's release in the integrators (SciPy, diffrax): the deformation held, the force
at the release the line's own.

A lock (lsc/locking.py) holds a cluster's relative acceleration at zero. SciPy and diffrax locked
with the residual closing rate of the event that locked the pair (a turning point located to
rounding, -2e-12 ft/s), so the held deformation drifted: the five-car UNTURNED chain
(tests/test_exact_chain_balance.py) held contact 1 for 109 ms, 2.3e-13 ft below the top of its
1e15 lbf/ft unloading line, and SciPy released it with a force of -158 lbf (a pull from a
compression-only contact) where exact-chain has the top's +74.69 lbf; SciPy's ΔV was 1.0e-6 ft/s
off exact-chain's with every integrator and rtol. Each locked cluster now starts every segment
at its mass-weighted mean velocity (:meth:`lsc.locking.LockingModel.project`), as exact-chain
starts it.
"""

from __future__ import annotations

import numpy as np
import pytest

import lsc
from hard.common import check_agrees
from lsc.lock_law import joined_velocities
from test_exact_chain_balance import UNTURNED
from test_exact_chain_locks import _pushed


def _release(r):
    """The time of UNTURNED's four events at one instant (two separations, two releases)."""
    return next(e.time for e in r.events if (e.kind, e.index) == ("separation", 3))


def test_scipy_releases_the_held_pair_with_the_force_of_its_line():
    """Right after the release, SciPy's contact 1 pushes with exact-chain's force (the top of
    its line, +74.69 lbf), and no force of the run is a pull (main: -158 lbf), both to the
    positions' rounding on that line (4 ulps of 0.4 ft at 1e15 lbf/ft: 0.2 lbf; measured: the
    same 74.6904103 lbf, the least force -0.01 lbf)."""
    r = lsc.solve(UNTURNED, method="scipy", rtol=1e-12)
    ref = lsc.solve(UNTURNED, method="exact-chain")
    t, f = r.t, r.force[:, 1]
    after = f[t == _release(r)][-1]
    top = ref.force[:, 1][ref.t == _release(ref)][-1]
    assert 74.6 < top < 74.7
    assert abs(after - top) < 1.0, (after, top)
    assert np.min(r.force) > -1.0


def test_scipy_agrees_with_exact_chain_on_the_unturned_chain():
    """SciPy (DOP853, rtol 1e-12) agrees with exact-chain to its tolerance (measured: 3e-12 of
    the closing speed; main: 1.0e-6 ft/s on ΔV, 1e-6 of the closing speed). The chain's end,
    a tangle of near-plastic contacts closing and separating within 400 ns, is sensitive to
    SciPy's restart shift: other integrators and tolerances agree as well (to 1e-10) or stop on
    a grazing impact too brief for the clock or at their step limit."""
    check_agrees(lsc.solve(UNTURNED, method="scipy", rtol=1e-12),
                 lsc.solve(UNTURNED, method="exact-chain"))


def test_the_pushed_pair_agrees_with_exact_chain_to_rounding():
    """A pair pushed shut (rule 1, e = 0): SciPy and diffrax agree with exact-chain on ΔV to
    1e-12 of the closing speed (measured 3e-14, 7e-15; main: 4e-12 for both, the residual
    closing rate at the lock)."""
    scene = _pushed(2e6)
    ref = lsc.solve(scene, method="exact-chain")
    w = abs(scene["vehicles"][0]["speed"] - scene["vehicles"][1]["speed"])
    for method in ("scipy", "diffrax"):
        if method == "diffrax":
            pytest.importorskip("diffrax")
        r = lsc.solve(scene, method=method, rtol=1e-12)
        assert np.max(np.abs(r.delta_v - ref.delta_v)) < 1e-12 * w, method


def test_a_cluster_is_joined_at_its_mean_velocity():
    """:func:`joined_velocities`: each cluster's vehicles at its mass-weighted mean velocity,
    its momentum kept, a cluster moving alike kept exactly, a vehicle in no cluster untouched;
    the same numbers with a traced mask (``jax.numpy``, diffrax's loop)."""
    m = np.array([2.0, 1.0, 3.0, 0.7, 5.0])
    v = np.array([1.0, 1.0 + 1e-12, -0.5, 0.3, 0.3 - 2e-12])
    mask = [True, False, False, True]
    out = joined_velocities(v, m, mask)
    assert out[0] == out[1] and out[3] == out[4] and out[2] == v[2]
    assert abs(m[:2] @ out[:2] - m[:2] @ v[:2]) <= 4e-16 * (m[:2] @ np.abs(v[:2]))
    assert abs(m[3:] @ out[3:] - m[3:] @ v[3:]) <= 4e-16 * (m[3:] @ np.abs(v[3:]))
    alike = np.array([0.1, 0.1, 0.1, -2.0, 7.0])
    np.testing.assert_array_equal(joined_velocities(alike, m, [True, True, False, False]),
                                  alike)
    jax = pytest.importorskip("jax")
    import jax.numpy as jnp
    with jax.enable_x64(True):
        traced = jax.jit(lambda v, m, mask: joined_velocities(v, m, list(mask), jnp))
        np.testing.assert_array_equal(np.asarray(traced(v, m, np.array(mask))), out)
