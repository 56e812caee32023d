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
rate keeps its sign inside the segment, so the force is monotone there. Every quantity of a
segment is then evaluated at all the times found for it (and at both ends), once for all
segments.
"""

from __future__ import annotations

import numpy as np

from ._modes import Series
from ._roots import (FLAT, MANY, PER_RADIAN, _refine, _refine_many, _sign_changes,
                     _taylor_clear)

__all__ = ["segment_peaks", "basis_of"]

_EPS = float(np.finfo(float).eps)


def basis_of(kind, w, tau):
    """``S, C`` (..., n) at times ``tau`` (...) [s] for modes of kind ``kind`` (..., n) (1
    harmonic, 0 rigid, -1 hyperbolic) and ``w = sqrt|κ|`` (..., n) [1/s], each row on its own
    modes, from half angles as :meth:`~._modes.Modes.basis` computes them."""
    tau = np.asarray(tau, float)[..., None]
    ws = np.where(kind != 0, w, 1.0)
    h = (0.5 * ws) * tau
    if (kind < 0).any():
        with np.errstate(over="ignore", invalid="ignore"):
            hyper = kind < 0
            s = np.where(hyper, np.sinh(h), np.sin(h))
            c = np.where(hyper, np.cosh(h), np.cos(h))
    else:
        s, c = np.sin(h), np.cos(h)
    with np.errstate(invalid="ignore"):
        sw = s / ws
        S, C = 2.0 * sw * c, 2.0 * sw * sw
    rigid = kind == 0
    return np.where(rigid, tau, S), np.where(rigid, 0.5 * tau * tau, C)


def segment_peaks(records, K: int):
    """For each segment ``(motion, force (K,), τ, loading)`` of ``records``
    (:class:`~._modes.Motion`, the contact forces at its start, its length [s], the contacts
    that keep closing all along it: their forces, monotone, are not searched):
    ``(the largest force of each contact
    (K,), the acceleration of largest magnitude of each vehicle (N,), signed)`` over ``[0, τ]``
    (see the module docstring)."""
    if not records:
        return []
    shapes = [motion.shape for motion, _, _, _ in records]
    c0 = np.array([s.peak_of_force @ force for s, (_, force, _, _) in zip(shapes, records)])
    rows = np.array([s.peak_rows for s in shapes])
    A = rows * np.array([m.a for m, _, _, _ in records])[:, None, :]     # (S, Q, n)
    G = rows * np.array([m.b for m, _, _, _ in records])[:, None, :]
    kappa = np.array([s.modes.kappa for s in shapes])                   # (S, n)
    w = np.array([s.modes.w for s in shapes])
    kind = np.sign(kappa).astype(int)
    T = np.array([float(tau) for _, _, tau, _ in records])
    times = _extremum_times(records, shapes, A, G, kappa, w, kind, T)
    width = max(len(t) for t in times)
    tt = np.array([[0.0, tau] + t + [0.0] * (width - len(t)) for tau, t in zip(T.tolist(), times)])
    S, C = basis_of(kind[:, None, :], w[:, None, :], tt)                # (S, P, n)
    vals = (c0[:, :, None] + A @ np.swapaxes(S, 1, 2) + G @ np.swapaxes(C, 1, 2))
    force = vals[:, :K].max(axis=2)
    acc = vals[:, K:]
    pick = np.argmax(np.abs(acc), axis=2)[:, :, None]
    return list(zip(force, np.take_along_axis(acc, pick, axis=2)[:, :, 0]))


def _extremum_times(records, shapes, A, G, kappa, w, kind, T):
    """The times inside each segment (a list per segment) where a searched quantity may have
    an extreme value (the zeros of its derivative, or the ends of intervals where it is flat)."""
    times = [[] for _ in records]
    # (a segment of no length has no interior; a constant derivative is searched harmlessly)
    which = [[q for q in s.searched.tolist() if q not in rec[3]] if rec[2] > 0 else []
             for s, rec in zip(shapes, records)]
    seg = np.array([i for i, qs in enumerate(which) for _ in qs], dtype=int)
    if not seg.size:
        return times
    q = np.array([q for qs in which for q in qs], dtype=int)
    alpha = A[seg, q]
    # the derivatives (S' = 1 - κ C, C' = S): c + Σ da S + dg C
    k_seg = kappa[seg]
    dc, da, dg = alpha.sum(axis=1), G[seg, q], -k_seg * alpha
    fastest = w.max(axis=1)
    count = np.where(fastest > 0, np.ceil(T * PER_RADIAN * fastest), 2.0)
    count = np.maximum(count, 1.0).astype(int)
    step = T / count
    top = int(count.max())
    grid = np.minimum(step[:, None] * np.arange(top + 1.0), T[:, None])
    grid[np.arange(T.size), count] = T
    Sg, Cg = basis_of(kind[:, None, :], w[:, None, :], grid)            # (S, top + 1, n)
    dv = dc[:, None] + (Sg[seg] @ da[:, :, None])[..., 0] + (Cg[seg] @ dg[:, :, None])[..., 0]
    bound = _curvature_bounds(k_seg, kind[seg], w[seg], da, dg, T[seg])
    margin = (bound * step[seg] ** 2 / 8.0)[:, None]
    left, right = dv[:, :-1], dv[:, 1:]
    change = left * right <= 0
    valid = np.arange(top)[None, :] < count[seg][:, None]
    unclear = (change | (np.minimum(np.abs(left), np.abs(right)) <= margin)) & valid
    # a derivative within rounding of zero at the start: searched from where it provably
    # keeps a sign (its first derivative clear of rounding, with a bound on the next)
    rounding = np.abs(alpha).sum(axis=1)
    start = np.zeros(seg.size)
    for r in np.flatnonzero(np.abs(dc) <= 64 * _EPS * rounding).tolist():
        d = Series(float(dc[r]), da[r], dg[r], shapes[seg[r]].modes)
        start[r] = _taylor_clear(d, float(T[seg[r]]), float(rounding[r]))
    g_seg = grid[seg]
    a_t, b_t = g_seg[:, :-1], g_seg[:, 1:]
    unclear &= b_t > start[:, None]
    plain = unclear & change & (left != right) & (a_t >= start[:, None])
    r, i = np.nonzero(plain)
    if r.size > MANY:
        d = _Rows(dc[r], da[r], dg[r], kind[seg[r]], w[seg[r]], kappa[seg[r]])
        found = _refine_many(d, a_t[r, i], b_t[r, i], left[r, i], right[r, i]).tolist()
    else:   # (a few: one at a time on Python floats, cheaper than NumPy on a few values)
        found = [_refine(Series(float(dc[j]), da[j], dg[j], shapes[seg[j]].modes), *ab)
                 for j, *ab in zip(r.tolist(), a_t[r, i].tolist(), b_t[r, i].tolist(),
                                   left[r, i].tolist(), right[r, i].tolist())]
    for s, t in zip(seg[r].tolist(), found):
        times[s].append(t)
    rest = unclear & ~plain
    if rest.any():   # (grazing derivatives, or a flat start: one interval at a time)
        _one_by_one(rest, seg, q, A, G, shapes=shapes, records=records,
                    dc=dc, da=da, dg=dg, bound=bound, start=start, a_t=a_t, b_t=b_t,
                    left=left, right=right, Sg=Sg, Cg=Cg, times=times)
    return times


def _one_by_one(rest, seg, q, A, G, *, shapes, records, dc, da, dg, bound, start,
                a_t, b_t, left, right, Sg, Cg, times):
    """:func:`~._roots._sign_changes` on each interval of ``rest`` (rows, intervals)."""
    for r in np.flatnonzero(rest.any(axis=1)).tolist():
        s = int(seg[r])
        force = records[s][1]
        shape = shapes[s]
        f = shape.peak_of_force[q[r]] @ force + Sg[s] @ A[s, q[r]] + Cg[s] @ G[s, q[r]]
        flat = FLAT * float(np.max(np.abs(f)))
        d = Series(float(dc[r]), da[r], dg[r], shape.modes)
        B, s0 = float(bound[r]), float(start[r])
        for i in np.flatnonzero(rest[r]).tolist():
            a = max(float(a_t[r, i]), s0)
            fa = float(left[r, i]) if a == a_t[r, i] else d(a)
            times[s] += _sign_changes(d, a, float(b_t[r, i]), fa, float(right[r, i]), B, flat)


def _curvature_bounds(kappa, kind, w, alpha, gamma, T):
    """Bounds on ``|g''|`` (R,) over ``[0, T]`` (R,) of series of coefficients ``alpha, gamma``
    (R, n), each on its own modes (as :meth:`~._modes.Modes.curvature_bounds`: ``|S| <=
    min(T, 1/ω)``, ``|S'| <= 1``, or ``sinh(λT)/λ``, ``cosh(λT)`` on a hyperbolic mode)."""
    harmonic = kind > 0
    s_max = np.minimum(T[:, None], 1.0 / np.where(harmonic, w, 0.5 / T[:, None]))
    if not (kind < 0).any():
        return (np.abs(alpha * kappa) * s_max).sum(axis=1) + np.abs(gamma).sum(axis=1)
    hyper = kind < 0
    ws = np.where(hyper, w, 1.0)
    with np.errstate(over="ignore"):
        s_max = np.where(hyper, np.sinh(ws * T[:, None]) / ws, s_max)
        ds_max = np.where(hyper, np.cosh(ws * T[:, None]), 1.0)
    return (np.abs(alpha * kappa) * s_max).sum(axis=1) + (np.abs(gamma) * ds_max).sum(axis=1)


class _Rows:
    """Series ``c + Σ α S + γ C`` (rows), each on its own modes, for
    :func:`~._roots._refine_many` (all brackets at once)."""

    def __init__(self, c, alpha, gamma, kind, w, kappa):
        self.c, self.alpha, self.gamma, self.kind, self.w = c, alpha, gamma, kind, w
        self.slope0, self.k_alpha = alpha.sum(axis=1), kappa * alpha

    def with_slope(self, t):
        """``(g(t), g'(t))`` (rows,) at one time per row ``t`` [s]."""
        S, C = basis_of(self.kind, self.w, t)
        return (self.c + (S * self.alpha).sum(axis=1) + (C * self.gamma).sum(axis=1),
                self.slope0 - (C * self.k_alpha).sum(axis=1) + (S * self.gamma).sum(axis=1))
