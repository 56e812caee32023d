"""The peaks inside the segments of one chain, searched after the segment loop in one stacked
pass over every segment.

Each segment's contact forces and accelerations are series in closed form
(:class:`~._modes.Series`, on that segment's modes); their largest values over the segment are
at its ends or at a zero of their derivative. The derivatives of the quantities
:class:`~._modes.Shape` names (the others have their extrema at the same times) of every
segment are sampled together, each on its own segment's grid (:data:`~._roots.PER_RADIAN`
samples per radian of its fastest mode), in one NumPy evaluation; between two samples ``Δ``
apart a derivative differs from its chord by at most ``B Δ²/8`` (``B`` the bound on its own
second derivative), so an interval whose samples have one sign and both exceed that holds no
extremum. The sign changes of the samples are refined by Newton's method on the closed-form
derivative, kept inside its bracket (one at a time on Python floats, :func:`~._roots._refine`;
all at once where there are more than :data:`~._roots.MANY`, :func:`~._roots._refine_many`);
the few intervals the bound cannot clear without a sign change (a derivative grazing zero), and
a derivative flat at the segment's start (:func:`~._roots._taylor_clear`), go to the search of
:mod:`._roots` one at a time (:func:`~._roots._sign_changes`). The force of a contact whose
closing rate is an armed event of the segment is not searched: the event search proves that
rate keeps its sign inside the segment, so the force is monotone there; nor that of a contact
that starts the segment at the upper end of its piece, both ends armed (the top of its
unloading line, just past its largest deformation): it stays between them, ``|F|`` largest at
the start, where no acceleration follows its extremes beside a constant force
(:meth:`~._solve._Chain._unsearched`). Every quantity of a
segment is then evaluated at all the times found for it (and at both ends), once for all
segments.
"""

from __future__ import annotations

import math

import numpy as np

from ._modes import Series
from ._roots import (FLAT, MANY, PER_RADIAN, _refine, _refine_many, _sign_changes,
                     _taylor_clear)

__all__ = ["segment_peaks", "basis_of"]

_EPS = float(np.finfo(float).eps)


def basis_of(kind, w, tau, hyperbolic=None):
    """``S, C`` (..., n) at times ``tau`` (...) [s] for modes of kind ``kind`` (..., n) (1
    harmonic, 0 rigid, -1 hyperbolic) and ``w = sqrt|κ|`` (..., n) [1/s], each row on its own
    modes, from half angles as :meth:`~._modes.Modes.basis` computes them. ``hyperbolic``:
    whether ``kind`` holds a hyperbolic mode, if the caller knows."""
    tau = np.asarray(tau, float)[..., None]
    rigid = kind == 0
    ws = np.where(rigid, 1.0, w)
    h = (0.5 * ws) * tau
    if hyperbolic is None:
        hyperbolic = bool(np.less(kind, 0).any())
    if hyperbolic:
        with np.errstate(over="ignore", invalid="ignore"):
            hyper = kind < 0
            s = np.where(hyper, np.sinh(h), np.sin(h))
            c = np.where(hyper, np.cosh(h), np.cos(h))
            sw = s / ws   # (inf / inf where sinh and cosh overflow)
            twice = 2.0 * sw
            S, C = twice * c, twice * sw
    else:   # (finite values over ws > 0: nothing to silence)
        sw = np.sin(h) / ws
        twice = 2.0 * sw
        S, C = twice * np.cos(h), twice * sw
    # (the rigid modes' S = τ, C = τ²/2 written over the others', in place)
    np.copyto(S, tau, where=rigid)
    np.copyto(C, 0.5 * tau * tau, where=rigid)
    return S, C


def segment_peaks(records, K: int):
    """For each segment ``(motion, force (K,), τ, loading)`` of ``records``
    (:class:`~._modes.Motion`, the contact forces at its start, its length [s], the contacts
    whose largest force over it is at one of its ends, proven by the event search: their
    forces are not searched, :meth:`~._solve._Chain._unsearched`):
    ``(the largest force of each contact
    (K,), the acceleration of largest magnitude of each vehicle (N,), signed)`` over ``[0, τ]``
    (see the module docstring)."""
    # (a segment with locked pairs has fewer modes, its reduced chain's: each number of modes
    # is stacked on its own)
    out = [None] * len(records)
    by_size = {}
    for j, (motion, _, _, _) in enumerate(records):
        by_size.setdefault(motion.modes.kappa.size, []).append(j)
    for idx in by_size.values():
        some = [records[j] for j in idx]
        counts = [_intervals(motion.modes.fastest(), tau) for motion, _, tau, _ in some]
        found = _peaks(some, K, _packed([(j, 0, n, n) for j, n in enumerate(counts)]))
        for j, pk in zip(idx, found):
            out[j] = pk
    return out


def _packed(items, cut: bool = True):
    """``items`` ``(segment, first, size, ...)`` grouped so that a group's count times its
    largest ``size`` is at most :data:`PASS` (the smallest together); one larger than that
    alone (``cut``: cut into windows of ``PASS``, a long segment's grid: a ringing contact's)."""
    groups, group = [], []
    for item in sorted(items, key=lambda x: x[2]):
        j, _, n, *rest = item
        if n > PASS:
            groups += ([[(j, i, min(PASS, n - i), *rest)] for i in range(0, n, PASS)] if cut
                       else [[item]])
            continue
        if group and (len(group) + 1) * n > PASS:
            groups.append(group)
            group = []
        group.append(item)
    return groups + [group] if group else groups


def _intervals(fastest: float, tau: float) -> int:
    """How many sample intervals the segment's grid has (:data:`~._roots.PER_RADIAN` a
    radian of its fastest mode; 2 where all its modes are rigid)."""
    return max(1, math.ceil(tau * PER_RADIAN * fastest)) if fastest > 0 else 2


#: Most samples of one function in one pass of the search (the short segments of a chain in
#: one pass; a long one, a ringing contact's, in windows of this many samples).
PASS = 4096


def _peaks(records, K: int, passes):
    """:func:`segment_peaks` of ``records``, their grids searched in ``passes`` (each a list
    of windows ``(segment, first interval, number of intervals, the segment's intervals)``)."""
    shapes = [motion.shape for motion, _, _, _ in records]
    # (plus a sliding brake's constant deceleration: Motion.offset)
    c0 = np.array([s.peak_of_force @ force if m.offset is None else
                   s.peak_of_force @ force + m.offset
                   for s, (m, force, _, _) in zip(shapes, records)])
    rows = np.array([s.peak_rows for s in shapes])
    A = rows * np.array([m.a for m, _, _, _ in records])[:, None, :]     # (S, Q, n)
    G = rows * np.array([m.b for m, _, _, _ in records])[:, None, :]
    kappa = np.array([s.modes.kappa for s in shapes])                   # (S, n)
    w = np.array([s.modes.w for s in shapes])
    kind = np.sign(kappa).astype(int)
    hyper = any(s.modes.neg.size for s in shapes)   # (a falling table piece's mode)
    ends = [float(tau) for _, _, tau, _ in records]
    T = np.array(ends)
    times = [[] for _ in records]
    for windows in passes:
        _extremum_times(records, shapes, A, G, kappa, w, kind, T, windows, times, hyper)
    out = [None] * len(records)
    # (every quantity at every time found in its segment and at both ends; the segments with
    # few times together)
    for group in _packed([(j, 0, len(t) + 2) for j, t in enumerate(times)], cut=False):
        idx = sorted(j for j, _, _ in group)
        # (every segment in one group, the common case: the arrays themselves, not copies)
        sel = slice(None) if len(idx) == len(records) else idx
        width = max(n for _, _, n in group)
        tt = np.array([[0.0, ends[j]] + times[j] + [0.0] * (width - 2 - len(times[j]))
                       for j in idx])
        S, C = basis_of(kind[sel][:, None, :], w[sel][:, None, :], tt, hyper)     # (g, P, n)
        vals = (c0[sel][:, :, None] + A[sel] @ np.swapaxes(S, 1, 2)
                + G[sel] @ np.swapaxes(C, 1, 2))
        acc = vals[:, K:]
        # (np.max and take_along_axis as the reductions and the index they wrap)
        pick = acc[np.arange(len(idx))[:, None], np.arange(acc.shape[1])[None, :],
                   np.argmax(np.abs(acc), axis=2)]
        for j, force, a in zip(idx, np.maximum.reduce(vals[:, :K], axis=2), pick):
            out[j] = (force, a)
    return out


def _extremum_times(records, shapes, A, G, kappa, w, kind, T, windows, times, hyper=None):
    """Add to ``times`` (a list per segment) the times inside each window ``(segment, first
    interval, number of intervals, the segment's intervals)`` of ``windows`` where a searched quantity may have an
    extreme value (the zeros of its derivative, or the ends of intervals where it is flat);
    ``hyper``: whether some mode is hyperbolic (:func:`basis_of`)."""
    # (a segment of no length has no interior; a constant derivative is searched harmlessly)
    win, seg, q = [], [], []   # (each searched row's window, segment and quantity)
    for i, (j, _, _, _) in enumerate(windows):
        if records[j][2] > 0:
            for x in shapes[j].searched.tolist():
                if x not in records[j][3]:
                    win.append(i), seg.append(j), q.append(x)
    if not win:
        return
    segs, first, count, total = (list(x) for x in zip(*windows))
    win, seg, q, segs = (np.array(x, dtype=int) for x in (win, seg, q, segs))
    alpha = A[seg, q]
    # the derivatives (S' = 1 - κ C, C' = S): c + Σ da S + dg C
    k_seg = kappa[seg]
    dc, da, dg = alpha.sum(axis=1), G[seg, q], -k_seg * alpha
    # each window's grid: its segment's, from the window's first interval (the last point of
    # a segment's last window its end, exactly)
    Tw = T[segs]
    step = Tw / np.array(total, float)
    top = max(count)
    grid = np.minimum(step[:, None] * (np.array(first, float)[:, None] + np.arange(top + 1.0)),
                      Tw[:, None])
    for r, (f, n, size, end) in enumerate(zip(first, count, total, Tw.tolist())):
        if f + n == size:
            grid[r, n] = end
    Sg, Cg = basis_of(kind[segs][:, None, :], w[segs][:, None, :], grid,
                      hyper)   # (W, top + 1, n)
    dv = dc[:, None] + (Sg[win] @ da[:, :, None])[..., 0] + (Cg[win] @ dg[:, :, None])[..., 0]
    bound = _curvature_bounds(k_seg, kind[seg], w[seg], da, dg, T[seg], hyper)
    margin = (bound * step[win] ** 2 / 8.0)[:, None]
    left, right = dv[:, :-1], dv[:, 1:]
    change = left * right <= 0
    unclear = change | (np.minimum(np.abs(left), np.abs(right)) <= margin)
    if min(count) < top:   # (the windows shorter than the longest: their padding)
        unclear &= np.arange(top)[None, :] < np.array(count)[win][:, None]
    # a derivative within rounding of zero at the start: searched from where it provably
    # keeps a sign (its first derivative clear of rounding, with a bound on the next)
    rounding = np.add.reduce(np.abs(alpha), axis=1)
    start = np.zeros(seg.size)
    g_seg = grid[win]
    a_t, b_t = g_seg[:, :-1], g_seg[:, 1:]
    plain = unclear & change & (left != right)
    flat = np.flatnonzero(np.abs(dc) <= 64 * _EPS * rounding).tolist()
    for r in flat:
        d = Series(float(dc[r]), da[r], dg[r], shapes[seg[r]].modes)
        start[r] = _taylor_clear(d, float(T[seg[r]]), float(rounding[r]))
    if flat or not step.all():   # (else every start is 0, below every interval's end)
        unclear &= b_t > start[:, None]
        plain &= unclear & (a_t >= start[:, None])
    r, i = np.nonzero(plain)
    if r.size > MANY:
        d = _Rows(dc[r], da[r], dg[r], kind[seg[r]], w[seg[r]], kappa[seg[r]], hyper)
        found = _refine_many(d, a_t[r, i], b_t[r, i], left[r, i], right[r, i]).tolist()
    else:   # (a few: one at a time on Python floats, cheaper than NumPy on a few values)
        found = [_refine(Series(float(dc[j]), da[j], dg[j], shapes[seg[j]].modes), *ab)
                 for j, *ab in zip(r.tolist(), a_t[r, i].tolist(), b_t[r, i].tolist(),
                                   left[r, i].tolist(), right[r, i].tolist())]
    for j, t in zip(seg[r].tolist(), found):
        times[j].append(t)
    rest = unclear & ~plain
    if rest.any():   # (grazing derivatives, or a flat start: one interval at a time)
        _one_by_one(rest, seg, q, A, G, shapes=shapes, records=records,
                    dc=dc, da=da, dg=dg, bound=bound, start=start, a_t=a_t, b_t=b_t,
                    left=left, right=right, Sg=Sg[win], Cg=Cg[win], times=times)


def _one_by_one(rest, seg, q, A, G, *, shapes, records, dc, da, dg, bound, start,
                a_t, b_t, left, right, Sg, Cg, times):
    """:func:`~._roots._sign_changes` on each interval of ``rest`` (rows, intervals; ``Sg,
    Cg`` each row's grid basis, the function's size on it sets how flat is flat)."""
    for r in np.flatnonzero(rest.any(axis=1)).tolist():
        s = int(seg[r])
        force = records[s][1]
        shape = shapes[s]
        f = shape.peak_of_force[q[r]] @ force + Sg[r] @ A[s, q[r]] + Cg[r] @ G[s, q[r]]
        flat = FLAT * float(np.max(np.abs(f)))
        d = Series(float(dc[r]), da[r], dg[r], shape.modes)
        B, s0 = float(bound[r]), float(start[r])
        for i in np.flatnonzero(rest[r]).tolist():
            a = max(float(a_t[r, i]), s0)
            fa = float(left[r, i]) if a == a_t[r, i] else d(a)
            times[s] += _sign_changes(d, a, float(b_t[r, i]), fa, float(right[r, i]), B, flat)


def _curvature_bounds(kappa, kind, w, alpha, gamma, T, hyper=None):
    """Bounds on ``|g''|`` (R,) over ``[0, T]`` (R,) of series of coefficients ``alpha, gamma``
    (R, n), each on its own modes (as :meth:`~._modes.Modes.curvature_bounds`: ``|S| <=
    min(T, 1/ω)``, ``|S'| <= 1``, or ``sinh(λT)/λ``, ``cosh(λT)`` on a hyperbolic mode)."""
    harmonic = kind > 0
    s_max = np.minimum(T[:, None], 1.0 / np.where(harmonic, w, 0.5 / T[:, None]))
    if not (bool(np.less(kind, 0).any()) if hyper is None else hyper):
        return (np.add.reduce(np.abs(alpha * kappa) * s_max, axis=1)
                + np.add.reduce(np.abs(gamma), axis=1))
    hyper = kind < 0
    ws = np.where(hyper, w, 1.0)
    with np.errstate(over="ignore"):
        s_max = np.where(hyper, np.sinh(ws * T[:, None]) / ws, s_max)
        ds_max = np.where(hyper, np.cosh(ws * T[:, None]), 1.0)
    return (np.abs(alpha * kappa) * s_max).sum(axis=1) + (np.abs(gamma) * ds_max).sum(axis=1)


class _Rows:
    """Series ``c + Σ α S + γ C`` (rows), each on its own modes, for
    :func:`~._roots._refine_many` (all brackets at once)."""

    def __init__(self, c, alpha, gamma, kind, w, kappa, hyper=None):
        self.c, self.alpha, self.gamma, self.kind, self.w = c, alpha, gamma, kind, w
        self.hyper = hyper
        self.slope0, self.k_alpha = alpha.sum(axis=1), kappa * alpha

    def with_slope(self, t):
        """``(g(t), g'(t))`` (rows,) at one time per row ``t`` [s]."""
        S, C = basis_of(self.kind, self.w, t, self.hyper)
        return (self.c + (S * self.alpha).sum(axis=1) + (C * self.gamma).sum(axis=1),
                self.slope0 - (C * self.k_alpha).sum(axis=1) + (S * self.gamma).sum(axis=1))
