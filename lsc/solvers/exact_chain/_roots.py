"""Zeros of event functions, with a guarantee that none is missed.

An event function of a segment is a :class:`~._modes.Series` ``g``: a sum of sinusoids (and
hyperbolic terms) with known frequencies plus a quadratic. Its second derivative is bounded on
``[0, T]`` by ``B`` in closed form (:meth:`~._modes.Series.curvature_bound`), and between two
samples ``Δ`` apart ``g`` differs from its chord by at most ``B Δ²/8``: where both samples exceed
that, ``g`` has no zero between them. The functions of a segment are sampled together at
:data:`PER_RADIAN` samples per radian of its fastest mode; an interval the bound cannot clear is
bisected until it can, a sample changes sign (a bracket, refined by Brent's method to a few ulps
of the time), or it is narrower than :data:`TOUCH` of the window: a tangency, where the function
dips below zero by at most ``B (TOUCH T)²/8``, far below rounding, so the contact only touches.
A function of the rigid modes alone is a quadratic, solved in closed form.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from ._modes import Modes, Series

__all__ = ["earliest", "first_crossing", "extrema", "PER_RADIAN", "TOUCH", "FLAT"]

#: Samples per radian of the fastest mode (the curvature bound does the rest).
PER_RADIAN = 4.0
#: An interval narrower than this fraction of its window that the bound cannot clear is a
#: tangency (a touch), not a crossing.
TOUCH = 1e-15
_EPS = float(np.finfo(float).eps)


def _grid(modes: Modes, lo: float, hi: float) -> np.ndarray:
    n = max(1, int(math.ceil((hi - lo) * PER_RADIAN * modes.fastest())))
    return np.linspace(lo, hi, n + 1)


def _stack(funcs):
    """``c`` (E,), ``alpha``, ``gamma`` (E, n) of a list of series on the same modes."""
    return (np.array([g.c for g in funcs]), np.array([g.alpha for g in funcs]),
            np.array([g.gamma for g in funcs]))


def earliest(funcs: list[Series], lo: float, hi: float) -> tuple[float | None, int | None]:
    """The first downward zero crossing in ``(lo, hi]`` of any of ``funcs`` (each positive at
    ``lo``): ``(τ, position in funcs)``, the first function on a tie; ``(None, None)`` if none."""
    modes = funcs[0].modes
    best, best_j = None, None
    if modes.fastest() == 0.0:
        for j, g in enumerate(funcs):
            tau = _quadratic_crossing(g, lo, hi)
            if tau is not None and (best is None or tau < best):
                best, best_j = tau, j
        return best, best_j
    tt = _grid(modes, lo, hi)
    S, C = modes.basis(tt)
    c, A, G = _stack(funcs)
    vals = c[:, None] + A @ S.T + G @ C.T
    margin = modes.curvature_bounds(A, G, hi) * (tt[1] - tt[0]) ** 2 / 8.0
    for j, g in enumerate(funcs):
        v = vals[j]
        end = len(tt) - 1 if best is None else int(np.searchsorted(tt, best, side="right"))
        end = min(end, len(tt) - 1)
        if end < 1:
            continue
        below = np.flatnonzero(v[1:end + 1] <= 0)
        last = below[0] if below.size else end - 1
        unclear = np.flatnonzero(np.minimum(v[:last + 1], v[1:last + 2]) <= margin[j])
        B = margin[j] * 8.0 / (tt[1] - tt[0]) ** 2
        for i in unclear:
            tau = _hunt(g, tt[i], tt[i + 1], v[i], v[i + 1], B, TOUCH * max(hi, 1e-300))
            if tau is not None:
                if best is None or tau < best:
                    best, best_j = tau, j
                break
    return best, best_j


def first_crossing(g: Series, lo: float, hi: float) -> float | None:
    """The first downward zero crossing of ``g`` in ``(lo, hi]`` (``lo`` itself where
    ``g(lo) <= 0``), or ``None``."""
    if not g(lo) > 0:
        return lo
    return earliest([g], lo, hi)[0]


def _hunt(g, a, b, ga, gb, B, width):
    """The first downward crossing in ``[a, b]`` (``g(a) = ga > 0``), or ``None`` where the
    bound shows there is none (bisecting where it cannot tell, down to ``width``)."""
    stack = [(a, b, ga, gb)]
    while stack:
        a, b, ga, gb = stack.pop()
        if gb <= 0:
            return _refine(g, a, b, ga, gb)
        if min(ga, gb) - B * (b - a) ** 2 / 8.0 > 0 or b - a <= width:
            continue
        mid = 0.5 * (a + b)
        gm = g(mid)
        stack.append((mid, b, gm, gb))   # (the left half on top: the earliest crossing wins)
        stack.append((a, mid, ga, gm))
    return None


def _refine(g, a, b, ga, gb):
    """The zero in ``[a, b]`` where ``g`` changes sign, to a few ulps of the time. (The sign
    change is that of the samples ``ga, gb``; where ``g`` evaluated on its own at the ends, in a
    different order of rounding, shows none, the zero is at the end nearer to it, to rounding.)"""
    if ga == 0 or gb == 0:
        return a if ga == 0 else b
    fa, fb = g(a), g(b)
    if fa * fb > 0 or fa == 0 or fb == 0:
        return a if abs(fa) <= abs(fb) else b
    return float(brentq(g, a, b, xtol=1e-300, rtol=4 * _EPS, maxiter=500))


def _quadratic_crossing(g: Series, lo: float, hi: float) -> float | None:
    """``g = c + p τ + r τ²/2`` (rigid modes only): its first downward root in ``(lo, hi]``,
    from the cancellation-free formula (a double root is a touch)."""
    c, p, r = g.c, float(np.sum(g.alpha)), float(np.sum(g.gamma))
    roots = []
    if r == 0.0:
        if p < 0:
            roots = [-c / p]
    else:
        disc = p * p - 2.0 * r * c
        if disc > 0:
            q = -0.5 * (p + math.copysign(math.sqrt(disc), p))
            roots = [2.0 * q / r] + ([c / q] if q != 0 else [])
    down = sorted(t for t in roots if lo < t <= hi and p + r * t < 0)
    return down[0] if down else None


def extrema(funcs: list[Series], T: float) -> list[list[float]]:
    """For each of ``funcs``, the times in ``[0, T]`` that hold its extreme values on it
    besides the ends: where its derivative changes sign (refined to a few ulps), and the ends
    of the intervals where ``g`` provably varies by less than :data:`FLAT` of its size (a
    derivative grazing zero there need not be resolved: any point of the interval gives the
    value to rounding)."""
    modes = funcs[0].modes
    out = [[] for _ in funcs]
    if T <= 0:
        return out
    ders = [g.derivative() for g in funcs]
    tt = _grid(modes, 0.0, T) if modes.fastest() > 0 else np.linspace(0.0, T, 3)
    S, C = modes.basis(tt)
    c, A, G = _stack(funcs)
    size = np.max(np.abs(c[:, None] + A @ S.T + G @ C.T), axis=1)
    c, A, G = _stack(ders)
    vals = c[:, None] + A @ S.T + G @ C.T
    bounds = modes.curvature_bounds(A, G, T)
    margin = bounds * (tt[1] - tt[0]) ** 2 / 8.0
    for j, d in enumerate(ders):
        if not (np.any(d.alpha) or np.any(d.gamma)):
            continue   # constant: no interior extremum
        v = vals[j]
        start = _taylor_clear(d, T, float(np.sum(np.abs(funcs[j].alpha))))
        unclear = (v[:-1] * v[1:] <= 0) | (np.minimum(np.abs(v[:-1]), np.abs(v[1:])) <= margin[j])
        for i in np.flatnonzero(unclear & (tt[1:] > start)):
            a = max(tt[i], start)
            out[j] += _sign_changes(d, a, tt[i + 1], v[i] if a == tt[i] else d(a), v[i + 1],
                                    bounds[j], FLAT * size[j])
    return out


def _taylor_clear(d: Series, T: float, rounding: float) -> float:
    """(``rounding``: the size of the terms whose sum is ``d(0)``.) A time up to which ``d`` provably keeps the sign of its first derivative at 0 that
    rounding does not hide (0 where ``d(0)`` itself is clear of rounding, or none is): there
    ``d ≈ d_p τ^p/p!`` and ``|d^(p+1)| <= B``, so ``d`` keeps its sign while
    ``|d_p| τ^p/p! > B τ^(p+1)/(p+1)!`` (the lower orders, rounding, are neglected). A function
    pushed into motion far down a chain is flat at the start (``τ^9``), where sampling cannot
    tell its sign."""
    n = 2 * d.alpha.size + 1
    if abs(d.c) > 64 * _EPS * rounding:
        return 0.0   # (clear of rounding at 0: the common case, decided without the series)
    noise = Series(rounding, np.abs(d.alpha), np.abs(d.gamma), d.modes)
    vals = d.derivatives_at_zero(n)
    scale = []
    for _ in range(n + 1):
        scale.append(noise.c)
        noise = Series(float(np.sum(noise.alpha)), noise.gamma,
                       np.abs(d.modes.kappa) * noise.alpha, d.modes)
    tol = [64 * _EPS * x for x in scale]
    if abs(vals[0]) > tol[0]:
        return 0.0
    p = next((k for k in range(1, n + 1) if abs(vals[k]) > tol[k]), None)
    if p is None:
        return 0.0
    lower = d
    for _ in range(p - 1):
        lower = lower.derivative()
    B = lower.curvature_bound(T)
    return min(0.5 * (p + 1) * abs(vals[p]) / B, T) if B > 0 else T


#: A function that provably varies by less than this fraction of its size over an interval
#: has its extreme values there at the interval's ends, to rounding (:func:`extrema`).
FLAT = 1e-15
#: Bisection depth of an interval whose derivative grazes zero, in :func:`extrema`.
DEPTH = 10


def _sign_changes(d, a, b, da, db, B, flat):
    """Times in ``[a, b]`` holding the extremes of the function whose derivative is ``d``: the
    zeros where ``d`` changes sign, one per sign change of the samples, after bisecting the
    intervals without one that the bound cannot clear; an interval over which the function
    varies by at most ``flat`` [its unit], or narrower than ``2^-DEPTH`` of the sample step,
    gives its ends instead: there the function is within ``(|d| + B w²/8) w`` of its value at
    the ends (``w`` the width, ``|d|`` below ``B w²/8`` where the bound could not clear it), a
    few 1e-10 of its variation over a sample step at most. (Between samples a quarter
    radian of the fastest mode apart a derivative changes sign at most once but where it grazes
    zero, which the bisection resolves.)"""
    found, stack = [], [(a, b, da, db)]
    finest = (b - a) / 2 ** DEPTH
    while stack:
        a, b, da, db = stack.pop()
        reach = B * (b - a) ** 2 / 8.0
        if (max(abs(da), abs(db)) + reach) * (b - a) <= flat or b - a <= finest:
            found += [a, b]
            continue
        if da * db <= 0 and da != db:
            found.append(_refine(d, a, b, da, db))
            continue
        if min(abs(da), abs(db)) - reach > 0:
            continue
        mid = 0.5 * (a + b)
        dm = d(mid)
        stack += [(mid, b, dm, db), (a, mid, da, dm)]
    return found
