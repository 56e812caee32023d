"""The locked pair's force law (:mod:`lsc.locking`), and the selects its transitions run on.

A cluster of vehicles joined by locked contacts moves as one body: :func:`cluster_forces` (the
law, for the clusters of a known set of locked contacts: SciPy and exact-chain) and
:func:`locked_forces` (the same law for a mask of locked contacts that may be traced: diffrax's
compiled loop, where each contact's cluster bounds are traced indices).

The selects (:func:`pick`, :func:`if_`) run a transition written once on NumPy, where each
condition is known and only the branch taken runs (the same operations as a plain ``if``), and
on ``jax.numpy``, where a traced condition evaluates both branches and selects field by field.
"""

from __future__ import annotations

import numpy as np

from .laws._common import select

__all__ = ["clusters", "cluster_forces", "locked_forces", "joined_velocities", "project",
           "concrete", "not_", "pick", "if_", "none", "force_rounding", "PRESS_TOL"]

#: A force within this fraction of the force scale (and its positions' rounding) of zero is on
#: its surface: pressed where it rises (:func:`lsc.locking.pressed`).
PRESS_TOL = 1e-13
_EPS = float(np.finfo(float).eps)


def force_rounding(scale, x, s, xp=np):
    """How far from zero rounding can put a contact force near zero [force]: :data:`PRESS_TOL`
    of the force ``scale``, and 16 ulps of the positions ``x`` through the slopes ``s`` (a
    pusher at its permanent set on a near-plastic line 1.5e14 lbf/ft stiff carries 3e-3 lbf of
    either sign)."""
    return PRESS_TOL * scale + 16 * _EPS * xp.max(xp.abs(x)) * xp.sum(xp.abs(s))


def concrete(c) -> bool:
    """Whether the condition ``c`` is known now (a Python or NumPy boolean), not traced."""
    return isinstance(c, (bool, np.bool_)) or (isinstance(c, np.ndarray) and c.ndim == 0)


def not_(c):
    """``not c``, traced or not."""
    return (not c) if concrete(c) else ~c


def pick(c, a, b, xp):
    """``a`` where ``c`` else ``b``: the one taken where ``c`` is known now."""
    if concrete(c):
        return a if c else b
    return xp.where(c, a, b)


def if_(c, a, b, xp) -> list:
    """The discrete state ``a()`` where ``c`` else ``b()`` (thunks): only the one taken where
    ``c`` is known now (NumPy: the same operations as a plain ``if``); both, then selected field
    by field, where it is traced (an entry the two share is kept as it is)."""
    if concrete(c):
        return a() if c else b()
    A, B = a(), b()
    return [x if x is y else select(c, x, y, xp) for x, y in zip(A, B)]


def none(mask) -> bool:
    """Whether the lock mask ``mask`` is known to hold no lock."""
    return all(concrete(c) and not c for c in mask)


def clusters(locked, N: int) -> list[tuple[int, int]]:
    """The vehicle ranges ``(a, b)`` (inclusive) joined by the locked contacts ``locked``."""
    out = []
    for k in sorted(locked):
        if out and out[-1][1] == k:
            out[-1] = (out[-1][0], k + 1)
        else:
            out.append((k, k + 1))
    return out


def _link(mass, rear, left, right):
    """A locked contact's force and its cluster's acceleration (the module: ``M``, ``M_rear``,
    ``F_L``, ``F_R``)."""
    return ((mass - rear) * left + rear * right) / mass, (left - right) / mass


def cluster_forces(F, m, groups, K: int):
    """The contact forces (K, ...) with each locked contact's force from its cluster's motion,
    and each cluster's acceleration: ``[(a, b, accel)]``. ``F``: the contact forces (K, ...)
    [force] (the locked contacts' rows are replaced); ``m`` (N,) [mass]."""
    rows = list(F)
    accels = []
    for a, b in groups:
        left = F[a - 1] if a > 0 else 0.0 * F[0]
        right = F[b] if b < K else 0.0 * F[0]
        mass = float(np.sum(m[a:b + 1]))
        rear = 0.0
        for k in range(a, b):
            rear += float(m[k])
            rows[k] = _link(mass, rear, left, right)[0]
        accels.append((a, b, _link(mass, 0.0, left, right)[1]))
    return rows, accels


def locked_forces(F, m, mask, K: int, xp=np):
    """:func:`cluster_forces` for the locked contacts where ``mask`` (K booleans, traced or
    not) is true: ``(rows, join)``, the contact forces (K) and ``join(a)``, the accelerations
    ``a`` (N) with each cluster's vehicles at its one acceleration. A traced mask (one state,
    ``F`` (K,)): each vehicle's cluster as a traced number (the unlocked contacts before it),
    its mass, ends and rear mass as masked sums, the same formula (:func:`_link`)."""
    if all(concrete(c) for c in mask):
        rows, accels = cluster_forces(F, m, clusters([k for k in range(K) if mask[k]], K + 1),
                                      K)

        def join(a):
            acc = list(a)
            for lo, hi, shared in accels:
                acc[lo:hi + 1] = [shared] * (hi + 1 - lo)
            return acc
        return rows, join
    locked, cluster, inside = _members(mask, xp)
    N = K + 1
    same = cluster[:, None] == cluster[None, :]                               # (N, N)
    mass = xp.sum(xp.where(same, m[None, :], 0.0), axis=1)
    lo = xp.argmax(same, axis=1)
    hi = N - 1 - xp.argmax(same[:, ::-1], axis=1)
    ext = xp.concatenate([xp.zeros(1), F, xp.zeros(1)])   # (ext[j + 1]: contact j)
    left, right = ext[lo], ext[hi + 1]
    behind = xp.arange(N)[None, :] <= xp.arange(K)[:, None]                   # (K, N)
    rear = xp.sum(xp.where(same[:K] & behind, m[None, :], 0.0), axis=1)
    row, _ = _link(mass[:K], rear, left[:K], right[:K])
    _, shared = _link(mass, 0.0, left, right)
    return xp.where(locked, row, F), lambda a: xp.where(inside, shared, xp.asarray(a))


def joined_velocities(v, m, mask, xp=np):
    """The velocities ``v`` (N,) [velocity] with each cluster of the locked contacts where
    ``mask`` (K booleans, traced or not) is true at its mass-weighted mean velocity (``m`` (N,)
    [mass]); a vehicle in no cluster keeps its own. Each cluster's momentum is kept (to
    rounding) and its relative velocities are zero exactly: a locked pair's shared acceleration
    then holds its deformation (an integrator's residual closing rate at the lock, an event
    located to rounding, would move it: 2e-12 ft/s over 0.1 s, on a 1e15 lbf/ft line, a pull of
    158 lbf at its release). The mean is taken from the cluster's first vehicle's velocity,
    so a cluster whose vehicles move alike keeps their velocity exactly."""
    _, cluster, inside = _members(mask, xp)
    N = cluster.shape[0]
    E = xp.where(cluster[:, None] == xp.arange(N)[None, :], 1.0, 0.0)        # (N, N)
    first = xp.argmax(cluster[:, None] == cluster[None, :], axis=1)           # (N,)
    mass = xp.matmul(E.T, m)
    dv = v - v[first]
    mean = v[first] + xp.matmul(E, xp.matmul(E.T, m * dv) / xp.where(mass > 0, mass, 1.0))
    return xp.where(inside, mean, v)


def project(y, N: int, m, mask, xp=np):
    """The state ``y`` (n,) [length, velocity, ...] with each cluster of the locked contacts
    where ``mask`` (K booleans) is true at one velocity (:func:`joined_velocities`; ``y``
    itself where none is locked): where SciPy and diffrax start a segment, as exact-chain does
    (the lock holds the relative accelerations at zero; this, the relative velocities)."""
    if none(mask):
        return y
    return xp.concatenate([y[:N], joined_velocities(y[N:2 * N], m, mask, xp), y[2 * N:]])


def _members(mask, xp):
    """``(locked, cluster, inside)`` for the lock mask ``mask`` (K booleans, traced or not):
    the mask as an array (K,), each vehicle's cluster (N,) as a number (the unlocked contacts
    before it), and whether each vehicle is in a cluster of locked contacts (N,)."""
    locked = xp.stack([xp.asarray(c, dtype=bool) for c in mask])
    cluster = xp.concatenate([xp.zeros(1, int), xp.cumsum(~locked)])
    no = xp.zeros(1, bool)
    return locked, cluster, xp.concatenate([locked, no]) | xp.concatenate([no, locked])
