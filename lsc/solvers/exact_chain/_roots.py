"""Zeros of event functions, with a guarantee that none is missed.

An event function of a segment is a :class:`~._modes.Series` ``g``: a sum of sinusoids (and
hyperbolic terms) with known frequencies plus a quadratic. Its second derivative is bounded on
``[0, T]`` by ``B`` in closed form (:meth:`~._modes.Series.curvature_bound`), and between two
samples ``Δ`` apart ``g`` differs from its chord by at most ``B Δ²/8``: where both samples exceed
that, ``g`` has no zero between them. The functions of a segment are sampled together at
:data:`PER_RADIAN` samples per radian of its fastest mode; an interval the bound cannot clear is
bisected until it can, a sample changes sign (a bracket, refined to a few ulps of the time by
Newton's method on the analytic derivative, kept inside it), or it is narrower than :data:`TOUCH` of the window: a tangency, where the function
dips below zero by at most ``B (TOUCH T)²/8``, far below rounding, so the contact only touches.
A function of the rigid modes alone is a quadratic, solved in closed form.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from ._modes import Modes, Series

__all__ = ["earliest", "first_crossing", "Stack", "PER_RADIAN", "TOUCH", "FLAT"]

#: Samples per radian of the fastest mode (the curvature bound does the rest).
PER_RADIAN = 4.0
#: An interval narrower than this fraction of its window that the bound cannot clear is a
#: tangency (a touch), not a crossing.
TOUCH = 1e-15
_EPS = float(np.finfo(float).eps)


def _grid(modes: Modes, lo: float, hi: float) -> np.ndarray:
    n = max(1, int(math.ceil((hi - lo) * PER_RADIAN * modes.fastest())))
    tt = lo + ((hi - lo) / n) * np.arange(n + 1.0)
    tt[-1] = hi
    return tt


#: First windows whose grid and basis a :class:`Modes` keeps (all dropped at once when full),
#: and the most points such a grid may have (a first window has about 8π).
GRIDS, GRID_POINTS = 4, 64


def _grid_basis(modes: Modes, lo: float, hi: float):
    """``(tt, S, C, times, step, weights)``: :func:`_grid`, its basis, its times as a list, its
    step (a float) and the weights of :meth:`Stack.bounds_on_grid` over ``[0, hi]``; those of a
    first window (from 0, small) kept on ``modes``: it is the same
    segment after segment of a set of slopes, whose modes the chains keep
    (:class:`~._modes.Shape`)."""
    grids = modes.__dict__.setdefault("_grids", {})
    got = grids.get((lo, hi))
    if got is None:
        tt = _grid(modes, lo, hi)
        times = tt.tolist()
        # (the weights of Stack.bounds_on_grid over [0, hi], as Modes.curvature_bounds's terms)
        weights = None if modes.neg.size else np.concatenate(
            (np.abs(modes.kappa) * np.minimum(hi, modes._inv_w), np.ones(modes.kappa.size)))
        got = (tt, *modes.basis(tt), times, times[1] - times[0], weights)
        if lo == 0.0 and tt.size <= GRID_POINTS:
            if len(grids) >= GRIDS:
                grids.clear()
            for a in got[:3]:
                a.flags.writeable = False   # (shared from call to call)
            grids[(lo, hi)] = got
    return got


class Stack:
    """Series on the same modes stacked for sampling them together: ``c`` (E,), ``alpha``,
    ``gamma`` (E, n); :meth:`series` gives each back (for the search between samples)."""

    def __init__(self, modes: Modes, c, alpha, gamma, funcs=None):
        self.modes, self.c, self.alpha, self.gamma = modes, c, alpha, gamma
        self._funcs = list(funcs) if funcs is not None else [None] * len(c)

    @classmethod
    def of(cls, funcs: list[Series]) -> "Stack":
        """The stack of ``funcs``."""
        return cls(funcs[0].modes, np.array([g.c for g in funcs]),
                   np.array([g.alpha for g in funcs]), np.array([g.gamma for g in funcs]),
                   funcs)

    def bounds_on_grid(self, weights, T: float):
        """:meth:`curvature_bounds` over ``[0, T]``, a grid's window (``T`` its end [s]), from
        its ``weights`` (2n,) (:func:`_grid_basis`): ``|α| @ (|κ| min(T, 1/ω)) + Σ |γ|`` in one
        product, the same bound to rounding (``None`` weights, a hyperbolic mode: the general
        bound)."""
        if weights is None:
            return self.curvature_bounds(T)
        ag = self.__dict__.get("_ag")
        if ag is None:
            ag = self._ag = np.abs(np.concatenate((self.alpha, self.gamma), axis=1))
        return ag @ weights

    def series(self, j: int) -> Series:
        """Function ``j`` as a :class:`Series`."""
        if self._funcs[j] is None:
            self._funcs[j] = Series(float(self.c[j]), self.alpha[j], self.gamma[j], self.modes)
        return self._funcs[j]

    def take(self, rows) -> "Stack":
        """The functions ``rows`` (indices) alone."""
        return Stack(self.modes, self.c[rows], self.alpha[rows], self.gamma[rows],
                     [self._funcs[j] for j in rows])

    def curvature_bounds(self, T: float):
        """Bounds on each ``|g''|`` (E,) over ``[0, T]`` (:meth:`Modes.curvature_bounds`)."""
        return self.modes.curvature_bounds(self.alpha, self.gamma, T)


def earliest(funcs, lo: float, hi: float,
             starts=None) -> tuple[float | None, int | None]:
    """The first downward zero crossing in ``(lo, hi]`` of any of ``funcs`` (a list of
    :class:`Series`, or their :class:`Stack`; each positive at ``lo``): ``(τ, position in
    funcs)``, the first function on a tie; ``(None, None)`` if none. ``starts``: where each
    function's search starts instead of ``lo`` (as :func:`first_crossing`: at the start itself
    where the function is not positive there)."""
    stack = funcs if isinstance(funcs, Stack) else Stack.of(funcs)
    modes = stack.modes
    starts = [lo] * len(stack.c) if starts is None else list(starts)
    best, best_j = None, None
    if modes.fastest() == 0.0:
        for j, start in enumerate(starts):
            g = stack.series(j)
            tau = start if start > lo and not g(start) > 0 else _quadratic_crossing(g, start, hi)
            if tau is not None and (best is None or tau < best):
                best, best_j = tau, j
        return best, best_j
    tt, S, C, times, step, weights = _grid_basis(modes, lo, hi)
    vals = stack.c[:, None] + stack.alpha @ S.T + stack.gamma @ C.T
    bounds = stack.bounds_on_grid(weights, hi)
    unclear = np.minimum(vals[:, :-1], vals[:, 1:]) <= (bounds * step ** 2 / 8.0)[:, None]
    for j, start in enumerate(starts):   # (the intervals before a function's start are not
        if start > lo:                   # its own)
            unclear[j, :bisect.bisect_right(times, start) - 1] = False
    width = TOUCH * max(hi, 1e-300)
    # the functions in the order of their first unclear interval: one whose interval starts
    # after the earliest crossing found is not searched
    rows, intervals = _unclear(unclear)
    for j in rows:
        v, B, g = vals[j].tolist(), float(bounds[j]), stack.series(j)
        for i in intervals(j):
            if best is not None and times[i] > best:
                break
            a, ga = times[i], v[i]
            if a < starts[j]:
                a, ga = starts[j], g(starts[j])
            tau = a if not ga > 0 else _hunt(g, a, times[i + 1], ga, v[i + 1], B, width)
            if tau is not None:
                if best is None or tau < best or tau == best and j < best_j:
                    best, best_j = tau, j
                break
    return best, best_j


#: Most samples in a window whose unclear intervals are listed on Python lists (cheaper than
#: NumPy calls on a first window's few dozen; a long window's are left to NumPy).
SHORT = 256


def _unclear(unclear):
    """``(rows, intervals)``: the rows of ``unclear`` (E, n) with an unclear interval, in the
    order of their first one (the first row on a tie), and a function giving a row's
    intervals."""
    if unclear.shape[1] <= SHORT:
        flags = unclear.tolist()
        rows = sorted((j for j, row in enumerate(flags) if True in row),
                      key=lambda j: flags[j].index(True))
        return rows, lambda j: [i for i, u in enumerate(flags[j]) if u]
    rows = np.flatnonzero(unclear.any(axis=1))
    rows = rows[np.argsort(unclear[rows].argmax(axis=1), kind="stable")].tolist()
    return rows, lambda j: np.flatnonzero(unclear[j]).tolist()


def first_crossing(g: Series, lo: float, hi: float) -> float | None:
    """The first downward zero crossing of ``g`` in ``(lo, hi]`` (``lo`` itself where
    ``g(lo) <= 0``), or ``None``."""
    if not g(lo) > 0:
        return lo
    return earliest([g], lo, hi)[0]


def _hunt(g, a, b, ga, gb, B, width):
    """The first downward crossing in ``[a, b]`` (``g(a) = ga > 0``), or ``None`` where the
    bound shows there is none (bisecting where it cannot tell, down to ``width``; an interval
    the chord's bound cannot clear is tried by :class:`_Taylor` before it is halved)."""
    stack, taylor = [(a, b, ga, gb)], None
    while stack:
        a, b, ga, gb = stack.pop()
        if gb <= 0:
            return _refine(g, a, b, ga, gb)
        if min(ga, gb) - B * (b - a) ** 2 / 8.0 > 0 or b - a <= width:
            continue
        if taylor is None:
            taylor = _Taylor(g, b)
        if taylor.clears(a, b, ga):
            continue
        mid = 0.5 * (a + b)
        gm = g(mid)
        stack.append((mid, b, gm, gb))   # (the left half on top: the earliest crossing wins)
        stack.append((a, mid, ga, gm))
    return None


class _Taylor:
    """Where a function is flat, near a zero of high order (a contact pushed into motion far
    down a chain leaves its surface as ``τ^p``: its value is far below its curvature bound's
    ``B Δ²/8`` on any interval a sample step wide, which the chord's test would halve down to
    ``sqrt(8 g / B)``, millions of evaluations), its Taylor polynomial at the interval's left
    end ``a`` with a bound on the next derivative clears the interval: for ``h <= b - a``,
    ``g(a + h) >= g(a) - Σ_{i<n} max(0, -g^(i)(a)) h^i/i! - B_n (b - a)^n/n!`` with
    ``B_n >= |g^(n)|`` on ``[0, T]`` (:meth:`~._modes.Series.curvature_bound` of
    ``g^(n-2)``): where it is positive, ``g`` has no zero in ``[a, b]``. A negative derivative
    only lowers the bound (a positive one is not counted), so the test trusts no more of the
    computed values than the chord's does (``g(a)``), and its bounds are on the exact
    function; the orders tried stop where the bound is no longer positive, or at
    :data:`TAYLOR_ORDER`."""

    def __init__(self, g: Series, T: float):
        self.T, self.derivs, self.bounds = T, [g], []
        self.order = min(TAYLOR_ORDER, 2 * g.alpha.size + 2)

    def _bound(self, n: int) -> float:
        """``B_n`` (``n >= 2``), a bound on ``|g^(n)|`` over ``[0, T]``."""
        while len(self.bounds) < n - 1:
            self._deriv(len(self.bounds))
            self.bounds.append(self.derivs[len(self.bounds)].curvature_bound(self.T))
        return self.bounds[n - 2]

    def _deriv(self, i: int) -> Series:
        while len(self.derivs) <= i:
            self.derivs.append(self.derivs[-1].derivative())
        return self.derivs[i]

    def clears(self, a: float, b: float, ga: float) -> bool:
        """True where the bound shows ``g`` (``g(a) = ga > 0``) has no zero in ``[a, b]``."""
        h, lower, term = b - a, ga, 1.0
        for i in range(1, self.order):
            term *= h / i
            d = self._deriv(i)(a)
            if d < 0:
                lower += d * term
                if not lower > 0:
                    return False
            if lower - self._bound(i + 1) * term * h / (i + 1) > 0:
                return True
        return False


#: Highest order of the Taylor test of :class:`_Taylor` (a zero of order up to about this,
#: ``2n + 1`` for ``n`` modes at most at a segment's start: :func:`._solve._start`).
TAYLOR_ORDER = 24


def _refine(g, a, b, ga, gb):
    """The zero in ``[a, b]`` where ``g`` changes sign, to a few ulps of the time: Newton's
    method on the analytic derivative (:meth:`~._modes.Series.with_slope`), kept inside the
    bracket (a step that leaves it, or that does not halve it three times running, bisects).
    (The sign change is that of the samples ``ga, gb``; where ``g`` evaluated on its own, in a
    different order of rounding, shows none near an end, the bracket closes on that end: the
    zero is there to rounding.)"""
    if ga == 0 or gb == 0:
        return a if ga == 0 else b
    up = gb > 0
    t = a - ga * (b - a) / (gb - ga)
    width, stalled = b - a, 0
    for _ in range(300):
        f, df = g.with_slope(t)
        if f == 0.0:
            return t
        if (f > 0) == up:
            b = t
        else:
            a = t
        if b - a <= 0.5 * width:
            width, stalled = b - a, 0
        else:
            stalled += 1
        new = t - f / df if df != 0.0 else math.nan
        if not a < new < b or stalled >= 3:
            new = 0.5 * (a + b)
        if abs(new - t) <= 2 * _EPS * abs(t) or b - a <= 4 * _EPS * max(abs(a), abs(b)):
            return new
        t = new
    return t


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


#: More sign changes than this in one search of the peaks (:mod:`._peaks`): they are refined
#: together (:func:`_refine_many`).
MANY = 16
#: How close :func:`_refine_many` puts a zero of a derivative, relative to its time.
EXTREMUM_RTOL = 1e-13


def _refine_many(g, a, b, ga, gb):
    """:func:`_refine` on many brackets at once (arrays; each a sign change of the samples
    ``ga, gb``, neither zero), by the same steps, to :data:`EXTREMUM_RTOL` of the time: these
    are the zeros of a derivative, where the function's value is off by the square of that
    (a ringing derivative's rounding moves its zeros by more than a few ulps: Newton's last
    steps would wander in it)."""
    up = gb > 0
    t = a - ga * (b - a) / (gb - ga)
    width, stalled = b - a, np.zeros(a.shape, int)
    out, active = t.copy(), np.ones(a.shape, bool)
    for _ in range(300):
        if not active.any():
            break
        f, df = g.with_slope(t)
        right = (f > 0) == up
        b, a = np.where(active & right, t, b), np.where(active & ~right, t, a)
        halved = b - a <= 0.5 * width
        width, stalled = np.where(halved, b - a, width), np.where(halved, 0, stalled + 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = t - f / df
        close = np.abs(new - t) <= EXTREMUM_RTOL * np.abs(t)
        new = np.where(~close & (~((a < new) & (new < b)) | (stalled >= 3)), 0.5 * (a + b), new)
        done = active & ((f == 0) | close
                         | (b - a <= 4 * _EPS * np.maximum(np.abs(a), np.abs(b))))
        out = np.where(done, np.where(f == 0, t, new), out)
        active &= ~done
        t = np.where(active, new, t)
    return np.where(active, t, out)


def _taylor_clear(d: Series, T: float, rounding: float) -> float:
    """A time up to which ``d`` provably keeps the sign of its first derivative at 0 that
    rounding does not hide (0 where ``d(0)`` itself is clear of rounding, or none is;
    ``rounding``: the size of the terms whose sum is ``d(0)``): there
    ``d ≈ d_p τ^p/p!`` and ``|d^(p+1)| <= B``, so ``d`` keeps its sign while
    ``|d_p| τ^p/p! > B τ^(p+1)/(p+1)!`` (the lower orders, rounding, are neglected). A function
    pushed into motion far down a chain is flat at the start (``τ^9``), where sampling cannot
    tell its sign."""
    n = 2 * d.alpha.size + 1
    if abs(d.c) > 64 * _EPS * rounding:
        return 0.0   # (clear of rounding at 0: the common case, decided without the series)
    terms = d.each_at_zero(rounding)
    value, size = next(terms)
    if abs(value) > 64 * _EPS * size:
        return 0.0
    for p in range(1, n + 1):
        value, size = next(terms)
        if abs(value) > 64 * _EPS * size:
            break
    else:
        return 0.0
    lower = d
    for _ in range(p - 1):
        lower = lower.derivative()
    B = lower.curvature_bound(T)
    return min(0.5 * (p + 1) * abs(value) / B, T) if B > 0 else T


#: A function that provably varies by less than this fraction of its size over an interval
#: has its extreme values there at the interval's ends, to rounding (:mod:`._peaks`).
FLAT = 1e-15
#: Bisection depth of an interval whose derivative grazes zero (:func:`_sign_changes`).
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
