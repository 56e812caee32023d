"""Locked pairs in the exact chain (:mod:`lsc.locking`): the reduced system of a segment with
locked contacts, the locks' event functions, and the transitions that lock and release.

A locked contact is a rigid link: the vehicles it joins (a cluster, :func:`~lsc.locking.clusters`)
share one displacement, ``x = E X`` (``E`` (N, N_r): vehicle ``i`` belongs to cluster
``c(i)``). The clusters form a chain of ``N_r`` bodies of masses ``M_r = Eᵀ m`` joined by the
unlocked contacts, ``M_r X'' = -K_r X + f_r`` (``K_r = Eᵀ K E``: the locked contacts are the
zero rows of ``C E``; ``f_r = Eᵀ f``, their forces cancel inside a cluster), solved in its
modes as any chain (:class:`~._modes.Shape` of the reduced chain) and expanded back: ``Δx = E
T_r q``. The locked contacts' deformations are then held exactly (their rows of ``C E T_r``
vanish identically), and their forces follow from the unlocked contacts' forces by the cluster
law written once in :func:`lsc.locking.cluster_forces` (a matrix ``H`` (K, K) taken from it), so
each is a :class:`~._modes.Series` like every other event function, and the releases (the
force's zero and its upper limit ``F_top``) are found by the same search that misses no root.
A cluster's vehicles start a locked segment at the cluster's mass-weighted mean velocity
(their difference, a rounding error of the turning point, is not carried: momentum is kept).

When to lock and where to release is :class:`lsc.locking.LockingModel`'s, as for SciPy; the
laws' own transitions stay the exact backend's on Python floats, so a chain in which no lock
fires is, bit for bit, the plain law's solve (:class:`LockTransitions`).
"""

from __future__ import annotations

import numpy as np

from ...lock_law import force_rounding
from ...locking import cluster_forces, clusters
from ._carry import spanning
from ._modes import Motion, Series, Shape, deformation_map

__all__ = ["LockTransitions", "LockedShape", "locked", "project", "motion", "event_function",
           "first_of_ties"]


class LockTransitions:
    """The transitions of a chain whose pairs may lock (what the segment loop drives): the
    laws' on Python floats (``fast``, as without locks), then the locks' rule, counts and
    releases (``locking``, a :class:`lsc.locking.LockingModel`'s). Everything else is the
    locking model's (its events: the plain model's, then three per lock)."""

    def __init__(self, fast, locking):
        self._fast, self._locking = fast, locking
        self.params = fast.params
        self._off = locking._lock_offset

    def __getattr__(self, name):
        return getattr(self._locking, name)

    def initial(self):
        """The laws' initial state (as without locks), every lock open."""
        y0, disc = self._fast.initial()
        return y0, disc + [lock.init() for lock in self._locking.locks]

    def is_over(self, y, disc, t=0.0, horizon=None):
        """Never while a contact is closed (a locked one is), else the model's."""
        if any(st["mode"] for st in disc[: self._locking.K]):
            return False
        return self._locking.is_over(y, disc, t, horizon)

    def apply_event(self, i, t, y, disc, p, xp=None):
        """A law event by the laws' own transition (on floats), then the locks
        (:meth:`lsc.locking.LockingModel._relock`)."""
        off = self._off
        if self._locking.events[i][0] < off:
            new = list(self._fast.apply_event(i, t, y, disc[:off], p)) + list(disc[off:])
        else:
            new = list(disc)
        return self._locking.to_python(self._locking._relock(i, y, disc, new, p))


def locked(parts, disc) -> tuple[int, ...]:
    """The locked contacts in ``disc`` (none where ``parts``, the transitions the segment loop
    drives, has no locks)."""
    if not isinstance(parts, LockTransitions):
        return ()
    off = parts._off
    return tuple(k for k in range(parts.K) if disc[off + k]["mode"])


class LockedShape:
    """The modes and maps of a chain with the contacts ``lock`` locked, with the attributes of a
    :class:`~._modes.Shape` for the full chain (``T`` (N, n), ``P`` (K, n), ``from_velocity``,
    ``from_force``, the peak maps) and ``H`` (K, K): every contact's force from the others'
    (a locked contact's by :func:`lsc.locking.cluster_forces`, the others' their own)."""

    def __init__(self, m, slope, lock):
        m, slope = np.asarray(m, float), np.asarray(slope, float)
        N, K = m.size, slope.size
        groups = clusters(lock, N)
        E = _members(lock, N)
        free = [k for k in range(K) if k not in lock]
        select = np.zeros((len(free), K))
        select[np.arange(len(free)), free] = 1.0
        m_r = E.T @ m
        reduced = Shape(m_r, slope[free], -deformation_map(E.shape[1]).T)
        self.modes = reduced.modes
        self.T = E @ reduced.T
        self.P = deformation_map(N) @ self.T      # (a locked contact's row: exactly 0)
        self.minus_kappa_P = -self.modes.kappa * self.P   # (as :class:`~._modes.Shape`'s)
        self.spanning = spanning(self.P, self.modes.kappa)
        self.from_velocity = reduced.from_velocity @ ((E.T * m[None, :]) / m_r[:, None])
        self.from_force = reduced.from_force @ select
        rows, _ = cluster_forces(np.eye(K), m, groups, K)
        self.H = np.array(rows, float)
        accel = E @ ((-deformation_map(E.shape[1]).T @ select) / m_r[:, None])
        moving = self.H @ (slope[:, None] * self.P)
        self.peak_of_force = np.concatenate([self.H, accel])
        self.peak_rows = np.concatenate([moving, accel @ (slope[:, None] * self.P)])
        self.searched = np.flatnonzero(np.any(self.peak_rows != 0, axis=1))


def _members(lock, N: int) -> np.ndarray:
    """``E`` (N, N_r): 1 where vehicle ``i`` belongs to cluster ``c`` (in chain order)."""
    member = list(range(N))
    for a, b in clusters(lock, N):
        member[a:b + 1] = [a] * (b + 1 - a)
    heads = sorted(set(member))
    E = np.zeros((N, len(heads)))
    E[np.arange(N), [heads.index(c) for c in member]] = 1.0
    return E


def project(chain, y0, lock):
    """``y0`` with each cluster's vehicles at the cluster's mass-weighted mean velocity."""
    E, N = _members(lock, chain.N), chain.N
    y = np.array(y0, float)
    y[N:2 * N] = E @ ((E.T @ (chain.m * y[N:2 * N])) / (E.T @ chain.m))
    return y


def _shape(chain, slope, lock) -> LockedShape:
    """The chain's :class:`LockedShape` for these slopes and locks (kept per chain)."""
    key = ("lock", lock, tuple(slope.tolist()))
    if key not in chain.shapes:
        chain.shapes[key] = LockedShape(chain.m, slope, lock)
    return chain.shapes[key]


def motion(chain, x0, v0, slope, force, lock) -> Motion:
    """The closed-form motion of a segment with the contacts ``lock`` locked (``force``: the
    laws' forces at the start, 0 for a locked contact)."""
    return Motion(chain.m, x0, v0, slope, force, chain.incidence, _shape(chain, slope, lock))


def event_function(chain, motion, disc, k: int, which: int, force, W0, tol_w):
    """``(Series, tolerance at the start)`` of lock ``k``'s event ``which`` (0: its force
    through zero, 1: through ``F_top``, 2: the closing rate through zero, the turning point a
    watch waits for; each crossing downward, :class:`lsc.locking.LockPart`); a force function
    starts on its surface within the rounding :func:`lsc.lock_law.force_rounding` gives it."""
    if which == 2:
        return motion.closing_rate(k, W0[k]), tol_w
    shape = motion.shape
    slopes = np.array([float(st["s"]) for st in disc[: chain.K]])
    row = (shape.H[k] * slopes) @ shape.P
    c = float(shape.H[k] @ force)
    # (the rounding of the forces as lsc.locking.pressed judges a press, and a few ulps of c)
    tol = float(force_rounding(float(chain.model.force_scale()), motion.x0, slopes)) \
        + 16 * np.finfo(float).eps * abs(c)
    if which == 0:
        return Series(c, row * motion.a, row * motion.b, motion.modes), tol
    top = float(disc[chain.K + k]["ftop"])
    return Series(top - c, -row * motion.a, -row * motion.b, motion.modes), tol


def first_of_ties(chain, funcs, tau: float, event: int) -> int:
    """The event that ends a segment at ``tau`` with locks: ``event``, or where it is a lock's
    release and a law's event function is on its surface at ``tau`` too (within its start
    tolerance), that law event (the first in event order). A cluster pushed from one side
    only is released at the instant its pusher separates: both roots are the same to rounding,
    and the pusher's separation, which then releases the cluster (as SciPy's transitions do),
    must come first."""
    if chain.parts.events[event][0] < chain.K:
        return event
    for i, g, tol in funcs:
        # (one that came down to its surface, not one that stays on it all along)
        if chain.parts.events[i][0] < chain.K and g.c > tol and g(tau) <= tol:
            return i
    return event
