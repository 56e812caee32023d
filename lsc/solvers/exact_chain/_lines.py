"""A rebound line narrower than a segment start resolves (exact-chain's
:meth:`~._solve._Chain._leaves_narrow_line`): where the pair is on it, and its force there.

Such a line (``hi - lo`` below the start's rounding of a deformation, a near-plastic rebound
``e² D_max`` wide, its slope up to ``1e20`` lbf/ft) is one the positions cannot place the pair
on: a force ``fa + s (D - da)`` from them is the positions' rounding times ``s``. The pair is at
one of its two ends, known from how it came onto the line and which of the line's events ended
the segment; its force there is the line's own, from the law's numbers: ``fa`` at the top (the
anchor, ``F_max`` on a rebound from ``D_max``), zero at the foot of the bottom piece. And the
series of a solved chain (:class:`Sampler`), its forces from the deformations carried.
"""

from __future__ import annotations

import math

import numpy as np

from ...laws import BIG, MODE_LOADING, MODE_OPEN, MODE_UNLOADING
from ..segments import _full, _Sampler
from ._carry import frame

__all__ = ["force", "places", "leave", "exact_forces", "rate_omega", "line_rows", "Sampler"]

#: What a line's discrete state is known by (the same line: the same numbers).
_LINE = ("mode", "seg", "da", "fa", "s", "wl")


def force(st, place: int) -> float:
    """The force [force] of unloading piece ``st`` at its top (``place`` 1: its anchor, ``fa``)
    or at its foot (0: zero on the bottom piece, where the law separates; ``fa - s wl`` on a
    piece above it), from the law's numbers alone."""
    if place:
        return float(st["fa"])
    return 0.0 if st["seg"] <= 0 else float(st["fa"]) - float(st["s"]) * float(st["wl"])


def exact_forces(contacts, D0, tol_d):
    """The contacts whose force at a segment's start is exact, not their slope times their
    deformation's rounding: those on an unloading line wider than ``tol_d`` [length] (one the
    solve follows; a narrower one's place is not resolved, :func:`places`) at its anchor,
    ``D0 == da`` (``D0``: the deformations carried [length]; the law anchored the line at that
    very deformation, at the turn or at a lock's release: the force is the anchor's, ``fa``).
    A set of contacts (``contacts`` their states, a list); or the batch's mask (b, K)
    (``contacts`` their numbers stacked (b, K) by key, ``D0`` (b, K), ``tol_d`` (b,))."""
    if isinstance(contacts, dict):
        return ((contacts["mode"] == MODE_UNLOADING) & (D0 == contacts["da"])
                & (contacts["hi"] - contacts["lo"] > tol_d[:, None]))
    return {k for k, st in enumerate(contacts) if st["mode"] == MODE_UNLOADING
            and st["hi"] - st["lo"] > tol_d and D0[k] == float(st["da"])}


def rate_omega(m, slopes, contacts, D0, tol_d, fastest, slowest):
    """The rate [1/s] at which the deformations' rounding ``tol_d`` [length] drives the closing
    rates' at a segment's start (a force ``s tol_d`` drives a rate's derivatives as ``ω tol_d``
    does its value): the chain's ``fastest`` mode, or, where some contacts' forces are exact
    (:func:`exact_forces`: their deformation's rounding drives none), a bound on the fastest
    mode with their slopes left out (Gershgorin's, ``ω² <= max_i 2 (s_(i-1) + s_i) / m_i``;
    ``m`` the masses, ``slopes`` the contacts'), at least ``slowest`` (``1 / t_scale``).
    Floats; or the batch's arrays, one value per member (``m`` (b, N), ``slopes`` (b, K),
    ``fastest`` and ``slowest`` (b,), the rest as :func:`exact_forces` has them)."""
    exact = exact_forces(contacts, D0, tol_d)
    if isinstance(exact, set):
        if not exact:
            return fastest
        s = [0.0, *(0.0 if k in exact else float(a) for k, a in enumerate(slopes)), 0.0]
        bound = math.sqrt(max(2.0 * (a + b) / float(mi) for a, b, mi in zip(s, s[1:], m)))
        return min(fastest, max(bound, slowest))
    some = exact.any(axis=1)
    if not some.any():
        return fastest
    s = np.pad(np.where(exact, 0.0, slopes), ((0, 0), (1, 1)))
    bound = np.sqrt(np.max(2.0 * (s[:, :-1] + s[:, 1:]) / m, axis=1))
    return np.where(some, np.minimum(fastest, np.maximum(bound, slowest)), fastest)


def places(chain, contacts, tol_d: float) -> dict:
    """``{contact: 1 at its top, 0 at its foot}`` at the start of ``chain``'s segment for each
    contact on a rebound line narrower than ``tol_d`` [length] (``hi - lo <= tol_d``), by the
    way it came onto it: from loading (its max deformation) or from the piece below it, at the
    top; from open (at its permanent set) or from the piece above, at the foot; released from
    a lock at the held deformation its line is anchored at, at the top; on the same line as in
    the last segment, where that one ended (:func:`leave`). A place not known (a lock released
    inside the line; the line followed over a segment that no event of its own ended) is left
    out, and the chain warns of it (``chain.unknown``)."""
    out = {}
    before = chain.before
    for k, st in enumerate(contacts):
        if st["mode"] != MODE_UNLOADING or st["hi"] - st["lo"] > tol_d:
            continue
        was = before[k] if before is not None else None
        if was is None:
            place = None
        elif all(was[n] == st[n] for n in _LINE):
            place = chain.places.get(k)
        elif was["mode"] in (MODE_LOADING, MODE_OPEN):
            place = 1 if was["mode"] == MODE_LOADING else 0
        elif was["hi"] < BIG:   # (another piece of its line; a locked contact's is BIG)
            place = 1 if was["seg"] > st["seg"] else 0
        else:   # (locked: lsc.locking; released at the held D_max onto its line's top)
            off = getattr(getattr(chain.parts, "_locking", None), "_lock_offset", None)
            lock = before[off + k] if off is not None else {}
            place = 1 if float(lock.get("dlock", math.nan)) == st["da"] else None
        if place is None:
            chain.unknown.setdefault(k, chain.t0)
        else:
            out[k] = place
    return out


def leave(chain, lines: dict, event, tau: float, disc) -> None:
    """Record the segment's narrow ``lines`` (:func:`places`) on ``chain``: the line's force at
    the end each contact starts at and at the end it ends at (the end its own event reached;
    where it started, for a segment of no length); ``None`` where that is not known (it ended
    inside the line)."""
    k_end, which = chain.parts.events[event] if event is not None else (None, None)
    ends, at = {}, {}
    for k, place in lines.items():
        end = which if k == k_end and which in (0, 1) else place if tau == 0.0 else None
        if end is None:
            chain.unknown.setdefault(k, chain.t0)
        else:
            at[k] = end
        ends[k] = (force(disc[k], place), None if end is None else force(disc[k], end))
    chain.lines.append(ends)
    chain.places, chain.before = at, disc


def line_rows(lines: list, rows, segments, model):
    """``rows`` (the event points': both ends of every segment) with the forces of the contacts
    on a narrow line the line's own (``lines``: each segment's ``{contact: (force at its start,
    at its end)}``, :func:`leave`) and the accelerations ``model``'s from them (its clusters'
    and brakes' terms); every other contact's force as it was, ``model``'s from the rows'
    deformations."""
    if rows is None or not any(lines):
        return rows
    for i, ends in enumerate(lines):
        for j, side in ((2 * i, 0), (2 * i + 1, 1)):
            given = {k: f[side] for k, f in ends.items() if f[side] is not None}
            if given:   # (the other contacts' forces from the rows' deformations: frame)
                y, p = frame(np.concatenate([rows["x"][j], rows["v"][j]]), model.params,
                             rows["deformation"][j])
                rows["force"][j], rows["a"][j] = _given(model, y, segments[i].disc, given, p)
    return rows


def _given(model, y, disc, given: dict, p):
    """``(forces, accelerations)`` of ``model`` at states ``y`` in discrete state ``disc``
    with the forces of the contacts in ``given`` (contact -> force, a float or an array over
    ``y``'s times) those: each such contact's law taken with slope 0 and its anchor that force;
    every other term (the other contacts', clusters', brakes') the model's own."""
    disc = [dict(st, fa=given[k], s=0.0) if k in given else st for k, st in enumerate(disc)]
    F, _, a = model.accelerations(y, disc, p)
    return np.asarray(F, float), np.asarray(a, float)


class Sampler(_Sampler):
    """The series (:class:`~lsc.solvers.segments._Sampler`) of a solved chain (``chain``, its
    :class:`~._solve._Chain`): the positions and velocities of each segment's motion; the
    deformations its start's, carried (not differences of the positions), plus the motion's
    closed-form change ``P q(τ)``; the forces and accelerations ``model``'s from those, a
    narrow line's contact's force the line's own (from the line's force at the segment's
    start, ``F(0) + s ΔD(τ)``, and its own at its two ends, :func:`leave`)."""

    def __init__(self, model, segments, y_final, n_samples: int, chain):
        super().__init__(model, segments, y_final, n_samples)
        self.chain = chain

    def values(self, j: int, s, tt, pp) -> dict:
        motion, n = self.chain.records[j][1], len(tt)
        t = np.asarray(tt, float) - s.t0
        S, C = motion.modes.basis(t)
        change = (S * motion.a + C * motion.b) @ motion.P.T                 # (n, K)
        D = np.asarray(self.chain.deformations[j][0], float)[:, None] + change.T
        y = np.asarray(s.dense(tt), float).reshape(self.model.n_state, n)
        given = {}
        for k, (f0, f1) in self.chain.lines[j].items():
            if f0 is None:
                continue
            f = f0 + float(s.disc[k]["s"]) * motion.deformation(k, 0.0)(t)
            f[0] = f0   # (the line's own at its ends: the first sample t0, the last t1)
            if f1 is not None:
                f[-1] = f1
            given[k] = f
        yd, p = frame(y, pp, D)
        F, a = _given(self.model, yd, s.disc, given, p)
        return {"y": y, "force": _full(F, (self.model.K, n)), "a": _full(a, (self.model.N, n)),
                "deformation": D}
