"""Zeros and extrema of the event functions of many chains at once, with the guarantee of
:mod:`._roots`.

Each member's functions (:class:`~._batch_modes.Sums`) are sampled together on windows of
steps of ``1 / (PER_RADIAN ω)`` (``ω`` its fastest mode; :data:`WINDOW` / 2 steps first, twice
as many each window after, up to 64 :data:`WINDOW`), every member on its own window, all members
in one NumPy evaluation. Between two samples ``Δ`` apart a function differs from its chord by
at most ``B Δ²/8`` (``B`` the bound on ``|g''|``), so an interval whose samples both exceed
that holds no zero; the first interval of a member that does not is either a sign change (a
bracket, refined to a few ulps by Newton's method kept inside it, every window's brackets
at once) or is sampled again :data:`WINDOW` times finer, until narrower than :data:`._roots.TOUCH`
of its time, where it is a touch (as the single solve decides). A member whose intervals the
bound still cannot clear after :data:`LEVELS` finer samplings is handed back as *undecided*:
the caller solves it alone, with :mod:`._roots`' own search.
"""

from __future__ import annotations

import numpy as np

from ._batch_modes import Sums, first_true, half_angle, many, many_rows, mmax, msum
from ._roots import PER_RADIAN, TOUCH
from ._solve import fastest_entering, start_noise, start_rounding, taylor_lower, taylor_span

__all__ = ["start_times", "earliest", "refine", "WINDOW", "LEVELS"]

#: Sample steps per window of the batch search.
WINDOW = 16
#: How many times at most an interval the bound cannot clear is sampled again, finer (16^13:
#: below :data:`._roots.TOUCH` of any window, where it is a touch).
LEVELS = 13
#: Most windows one segment of a member is searched over before it is handed back.
MAX_WINDOWS = 256
_EPS = float(np.finfo(float).eps)


def start_times(g: Sums, tol, omega, limit):
    """Where to start searching each function (b, F) [s]: :func:`._solve._start`'s rule, its
    rounding (:func:`._solve.start_rounding`), fastest mode and Taylor interval the same
    functions, on every function at once: 0 normally; NaN where it stays on its surface all
    along the segment; where it starts within ``tol`` (b, F) of zero, judged by its first
    derivative clear of its rounding (``omega`` (b,) [1/s] the start state's rate): 0 going
    down (it fires now where ``g(0) <= 0``), going up within the interval over which its
    Taylor polynomial and a bound on the next derivative keep it positive, where that bound
    clears the computed value's rounding (:func:`_clear_of_rounding`)."""
    c = g.c
    out = np.zeros(c.shape)
    on = np.abs(c) <= tol
    if not on.any():
        return out
    rows, cols = np.nonzero(on)
    h = g.take(rows, cols)
    # (the sizes of the derivatives' terms at 0, as :meth:`._modes.Series.each_at_zero` gives
    # them: the derivatives of the function of coefficients |c|, |α|, |γ| on modes -|κ|)
    size = Sums(np.abs(h.c), np.abs(h.alpha), np.abs(h.gamma), -np.abs(h.kappa), h.w)
    order = 2 * g.alpha.shape[-1] + 1
    om = omega[rows]
    thr = tol[rows, cols]
    fastest = fastest_entering(h.alpha[:, 0], h.gamma[:, 0], h.w)
    T = taylor_span(limit[rows], fastest, om)
    s = np.full(rows.size, np.nan)
    todo = np.ones(rows.size, bool)
    lower, lows = h, []
    for p in range(1, order + 1):
        d = lower.derivative()
        size = size.derivative()
        dp = d.c[:, 0]
        hit = todo & (np.abs(dp) > start_rounding(thr, om, fastest, p, size.c[:, 0]))
        if hit.any():
            B = lower.curvature_bound(T[:, None])[:, 0]
            clear = np.where(B > 0, (p + 1) * dp / np.where(B > 0, B, 1.0), T)
            s = np.where(hit, 0.0, s)
            up = np.flatnonzero(hit & (dp >= 0))
            if up.size:
                s[up] = _clear_of_rounding(h, up, dp[up], B[up], p, clear[up], T[up],
                                           [x[up] for x in lows])
            todo &= ~hit
        if not todo.any():
            break
        lower = d
        lows.append(dp)
    out[rows, cols] = s
    return out


def _clear_of_rounding(h: Sums, up, dp, B, p: int, clear, T, low):
    """:func:`._solve._start`'s start of the functions ``up`` of ``h`` going up (their ``p``-th
    derivative ``dp`` the first clear one, ``B`` a bound on the next, ``low`` the ones below):
    where the Taylor bound clears what the computed value has beside it
    (:func:`._solve.start_noise`), at half or ``p/(p+1)`` of the interval it proves, else that
    interval's end."""
    sub = Sums(h.c[up], h.alpha[up], h.gamma[up], h.kappa[up], h.w[up])
    terms = Sums(np.zeros_like(sub.c), np.abs(sub.alpha), np.abs(sub.gamma), sub.kappa, sub.w)
    out = np.minimum(clear, T)
    for tau in (np.minimum(p / (p + 1) * clear, T), np.minimum(0.5 * clear, T)):
        clears = taylor_lower(dp, B, p, tau) > start_noise(sub.c[:, 0], low, tau,
                                                           terms.each_at(tau)[:, 0])
        out = np.where(clears, tau, out)   # (the earlier candidate, last, wins)
    return out


def earliest(g: Sums, armed, start, limit):
    """The first downward zero of each member's armed functions (b, F) searched from ``start``
    (b, F) up to ``limit`` (b,) [s]: ``(τ (b,), function (b,) or -1, undecided (b,) bool)``; -1
    where none is found before ``limit`` (or, with ``undecided``, where the search gave up)."""
    search = armed & ~np.isnan(start)
    F = g.c.shape[1]
    M = max(int(search.sum(axis=1).max(initial=0)), 1)
    if M < F:
        # (the functions searched, packed into M columns in their order: one event's few)
        order = _searched_first(search)[:, :M]
        tau, which, undecided = _earliest(_columns(g, order),
                                          np.take_along_axis(search, order, axis=1),
                                          np.take_along_axis(start, order, axis=1), limit)
        got = which >= 0
        which[got] = order[np.flatnonzero(got), which[got]]
        return tau, which, undecided
    return _earliest(g, search, start, limit)


def _searched_first(search):
    """Each row's columns, those ``search`` (b, F) first, each part in order:
    ``np.argsort(~search, axis=1, kind="stable")``, looked up by the row's pattern where the
    rows outnumber the patterns (NumPy sorts each short row at a cost of some hundred ns)."""
    b, F = search.shape
    if b < (1 << F):
        return np.argsort(~search, axis=1, kind="stable")
    code = np.zeros(b, np.int64)
    for j in range(F):
        code |= search[:, j].astype(np.int64) << j
    bits = ((np.arange(1 << F)[:, None] >> np.arange(F)) & 1).astype(bool)
    return np.argsort(~bits, axis=1, kind="stable")[code]


def _columns(g: Sums, order) -> Sums:
    """The functions ``order`` (b, M) of each member."""
    rows = np.arange(order.shape[0])[:, None]
    return Sums(np.take_along_axis(g.c, order, axis=1), g.alpha[rows, order],
                g.gamma[rows, order], g.kappa, g.w)


def _earliest(g: Sums, search, start, limit):
    """:func:`earliest` of the functions ``search`` (b, F) of each member."""
    b, F = g.c.shape
    tau = np.full(b, np.nan)
    which = np.full(b, -1)
    undecided = np.zeros(b, bool)
    start = np.where(search, start, np.inf)
    # (a function searched from 0 starts at its constant: the series' terms vanish there; the
    # others, and any member whose coefficients are not all finite (nor their sum), at their
    # value)
    g_start = np.where(search, g.c, np.inf)
    finite = np.isfinite(np.sum(g.alpha, axis=(1, 2)) + np.sum(g.gamma, axis=(1, 2)))
    rows, cols = np.nonzero(search & ((start != 0) | ~finite[:, None]))
    if rows.size:
        g_start[rows, cols] = g.take(rows, cols).each_at(start[rows, cols][:, None])[:, 0]
    # a function at or below zero where its search starts fires there
    now = search & (g_start <= 0)
    now_any = many(now)
    if now.any():
        t_now = np.where(now, start, np.inf)
        j = np.argmin(t_now, axis=1)
        got = now_any
        tau[got], which[got] = t_now[got, j[got]], j[got]
    B = g.curvature_bound()
    rigid = mmax(g.kappa) == 0
    quad = rigid & ~now_any
    if quad.any():
        tau[quad], which[quad] = _quadratic(g.take(quad), search[quad], start[quad], limit[quad])
    live = np.flatnonzero(~now_any & ~rigid & many(search))
    step = 1.0 / (PER_RADIAN * mmax(g.w))
    lo = np.zeros(b)
    brackets = []
    for k in range(MAX_WINDOWS):
        if not live.size:
            break
        # (windows that double from half a window, up to 128 times the first: most events
        # lie within the first few samples, and a member whose event is far away takes few)
        count = (WINDOW // 2) << min(k, 7)
        whole = live.size == b      # (every member, in order: no copies)
        got, cleared, stuck = _window(*((g, B, start, g_start, lo, step, limit, search) if whole
                                        else (g.take(live), B[live], start[live], g_start[live],
                                              lo[live], step[live], limit[live], search[live])),
                                      count, brackets, live)
        undecided[live[stuck]] = True
        lo[live] = cleared
        live = live[~got & ~stuck & (cleared < limit[live])]
    undecided[live] = True
    if brackets:
        # every window's brackets refined at once (each on its own: the same zeros as one
        # window at a time, in one pass of Newton's method)
        mem, jj, ta, tb, fa, fb = (np.concatenate(x) for x in zip(*(q[:6] for q in brackets)))
        h = Sums.joined([q[6] for q in brackets])
        order = np.argsort(mem, kind="stable")
        root = refine(h, ta, tb, fa, fb)[order]
        mem, jj = mem[order], jj[order]
        # (each member's earliest zero, the first function of it)
        starts = np.flatnonzero(np.r_[True, mem[1:] != mem[:-1]])
        best = np.minimum.reduceat(root, starts)
        jbest = np.minimum.reduceat(
            np.where(root == np.repeat(best, np.diff(np.r_[starts, mem.size])), jj, F_BIG),
            starts)
        tau[mem[starts]], which[mem[starts]] = best, jbest
    return tau, which, undecided



def _window(g, B, start, g_start, lo, step, limit, search, count, brackets, members):
    """One window of each member (see :func:`earliest`): ``(found (a bracket), where the
    search has cleared up to, stuck)``, over ``count`` steps. The first interval a member's
    bound cannot clear is sampled again :data:`WINDOW` times finer (up to :data:`LEVELS`
    times). The brackets found are appended to ``brackets``: ``(member (its entry of
    ``members``), function, ends, values at the ends, the function (Sums))``, for
    :func:`refine`."""
    n = g.c.shape[0]
    found = np.zeros(n, bool)
    stuck = np.zeros(n, bool)
    a, h, end = lo, step, np.minimum(lo + count * step, limit)
    cleared = end.copy()
    todo = np.arange(n)
    steps = count
    for level in range(LEVELS + 1):
        # (level 0: every member, as they come, no copies)
        sub = slice(None) if level == 0 else todo
        gg = g if level == 0 else g.take(todo)
        m = todo.size
        tt = np.minimum(a[:, None] + h[:, None] * np.arange(steps + 1), end[:, None])
        tt[:, -1] = end
        vals = gg.at(tt)                                              # (m, F, steps + 1)
        ok0, s0, gs = search[sub], start[sub], g_start[sub]
        margin = (B[sub] * h[:, None] ** 2 / 8.0)[:, :, None]
        left, right = vals[..., :-1], vals[..., 1:]
        # an interval is hit where its function may be zero in it: a sign change (``right <=
        # 0``: a crossing) or samples the bound cannot clear (unclear)
        hit = np.minimum(left, right) <= margin
        hit |= right <= 0
        hit &= ok0[:, :, None]
        # (a searched function that starts inside the window (``inside``, the pairs ``pm,
        # pj``): its intervals before its start masked (infinite samples), the one its start is
        # in taken from its value there)
        inside = ok0 & (s0 > tt[:, :1])
        pm, pj = np.nonzero(inside) if inside.any() else (None, None)
        if pm is not None:
            t0, t1, sl = tt[pm, :-1], tt[pm, 1:], s0[pm, pj][:, None]
            l_in = np.where(t0 < sl, np.where(t1 > sl, gs[pm, pj][:, None], np.inf),
                            left[pm, pj])
            r_in = np.where(t1 <= sl, np.inf, right[pm, pj])
            h_in = np.minimum(l_in, r_in) <= margin[pm, pj]
            h_in |= r_in <= 0
            hit[pm, pj] = h_in
        # each member's first interval hit by any function
        i = first_true(many_rows(hit), steps)                           # (m,)
        none = i == steps
        ic = np.minimum(i, steps - 1)
        rows = np.arange(m)
        at = hit[rows, :, ic] & ~none[:, None]
        lc, rc = left[rows, :, ic], right[rows, :, ic]                      # (m, F)
        if pm is not None:
            p = np.arange(pm.size)
            lc[pm, pj], rc[pm, pj] = l_in[p, ic[pm]], r_in[p, ic[pm]]
        crossing = rc <= 0
        cr = at & crossing
        deeper = many(at & ~crossing)
        brack = many(cr) & ~deeper
        # an interval narrower than TOUCH of its time that the bound cannot clear is a
        # tangency, not a crossing (as :func:`._roots._hunt` decides): the search goes on
        # after it
        touch = deeper & (tt[rows, ic + 1] - tt[rows, ic]
                          <= TOUCH * np.maximum(tt[:, -1], 1e-300))
        cleared[todo[touch]] = tt[touch, ic[touch] + 1]
        deeper &= ~touch
        if brack.any():
            r = np.flatnonzero(brack)
            rr, jj = np.nonzero(cr[r])
            mem = r[rr]
            ta = np.maximum(tt[mem, ic[mem]], start[todo[mem], jj])
            brackets.append((members[todo[mem]], jj, ta, tt[mem, ic[mem] + 1],
                             lc[mem, jj], rc[mem, jj], gg.take(mem, jj)))
            found[todo[r]] = True
        if level == LEVELS:
            stuck[todo[deeper]] = True
            break
        sel = np.flatnonzero(deeper)
        if not sel.size:
            break
        a, end = tt[sel, ic[sel]], tt[sel, ic[sel] + 1]
        cleared[todo[sel]] = end     # (a finer window covers the unclear interval only)
        steps = WINDOW
        h = (end - a) / steps
        todo = todo[sel]
    return found, cleared, stuck


F_BIG = np.iinfo(np.int64).max
#: Brackets so few that :func:`refine` computes on its closed ones rather than compacting its
#: arrays (a compaction costs what several iterations on so few do).
_SHORT_REFINE = 64


def refine(g: Sums, a, b, fa, fb, iterations: int = 100, rtol: float = 4 * _EPS):
    """The zero (m,) of each single function ``g`` (m, 1) in its bracket ``[a, b]`` where it
    changes sign (``fa, fb`` its values at the ends), to a few ulps of the time: Newton's
    method on the closed-form derivative from the chord's zero (as :func:`._roots._refine`),
    kept inside the bracket (a step that leaves it bisects), until the step is ``rtol`` of
    the time (or of the bracket's width, for a zero at the start). The brackets still open
    are the only ones computed on. ``rtol``: :data:`._roots.EXTREMUM_RTOL` for the zeros of a
    derivative, as the single solve's :func:`._roots._refine_many` (the function's value
    there is off by the square of it)."""
    fa, fb = np.asarray(fa), np.asarray(fb)
    a, b = np.array(a, float), np.array(b, float)
    x = np.where(np.abs(fa) < np.abs(fb), a, b)
    x[fa == 0] = a[fa == 0]
    live = np.flatnonzero((fb != 0) & (fa != 0))
    if not live.size:
        return x
    # the open brackets' own arrays, compacted as brackets close
    # (the function made positive at ``a`` by its sign, which rounds alike; the basis as
    # :func:`._batch_modes.basis` computes it, its per-mode constants taken once)
    w = (g.w[:, 0, :] if g.w.ndim == 3 else g.w)[live]
    # (mode 0 rigid in every member, as :func:`._batch_modes.basis` has it: its sines skipped)
    first = 1 if w.shape[1] > 1 and not w[:, 0].any() else 0
    rigid = w[:, first:] == 0
    ws = np.where(rigid, 1.0, w[:, first:])
    half, inv = 0.5 * ws, 1.0 / ws
    S, C = np.empty(w.shape), np.empty(w.shape)
    sign = np.where(fa[live] > 0, 1.0, -1.0)[:, None]
    al, ga = sign * g.alpha[live, 0], sign * g.gamma[live, 0]
    kal = g.kappa[live] * al
    c = sign[:, 0] * g.c[live, 0]
    lo, hi = a[live], b[live]
    # (Newton's start: the chord's zero, inside the bracket)
    with np.errstate(all="ignore"):
        fl, fh = fa[live], fb[live]
        xl = np.clip(lo - fl * ((hi - lo) / (fh - fl)), lo, hi)
    xl = np.where(np.isfinite(xl), xl, x[live])
    floor = max(0.25 * rtol, _EPS) * (hi - lo)
    # the state two steps back: a step that comes back to it (a cycle between two floats
    # round the zero, where the function is rounding) repeats for good, so the state the last
    # step would leave is known at once (by the parity of the steps left)
    back = (np.full(live.size, np.nan),) * 3
    some_rigid = bool(rigid.any())
    with np.errstate(all="ignore"):
        return _newton(x, live, iterations, first, some_rigid, rigid, inv, half, al, ga, kal, c,
                       lo, hi, xl, floor, back, S, C, rtol)


def _newton(x, live, iterations, first, some_rigid, rigid, inv, half, al, ga, kal, c, lo, hi, xl,
            floor, back, S, C, rtol):
    """The iterations of :func:`refine` (its arrays; ``x`` filled in and returned)."""
    act = np.ones(live.size, bool)     # (the brackets still open)
    for k in range(iterations):
        x_k = xl
        tau = xl[:, None]
        Se, Ce = half_angle(half * tau, inv)
        half_tt = 0.5 * tau * tau
        S[:, :first], C[:, :first] = tau, half_tt
        S[:, first:], C[:, first:] = Se, Ce
        if some_rigid:
            np.copyto(S[:, first:], tau, where=rigid)
            np.copyto(C[:, first:], half_tt, where=rigid)
        f = c + msum(al * S + ga * C)
        df = msum(al + ga * S - kal * C)
        pos = f > 0     # (the zero lies above x where the function, made positive first, is)
        state = (xl, lo, hi)
        lo, hi = np.where(pos, xl, lo), np.where(pos, hi, xl)
        new = xl - f / df
        tol = rtol * np.abs(xl) + floor
        zero = f == 0
        done = zero | (np.abs(new - xl) <= tol) | (hi - lo <= tol)
        inside = (new >= lo) & (new <= hi) & np.isfinite(new)
        new = np.where(inside, new, 0.5 * (lo + hi))
        xl = np.where(zero, xl, new)
        done &= act
        cycle = xl == back[0]
        if cycle.any():
            cycle &= act & ~done & (lo == back[1]) & (hi == back[2])
        if cycle.any():
            x[live[cycle]] = (xl if (iterations - k - 1) % 2 == 0 else x_k)[cycle]
            done |= cycle
        back = state
        if done.any():
            at = live[done]
            x[at] = np.where(cycle[done], x[at], xl[done])
            act &= ~done
            # (the brackets closed are compacted away once they are half the arrays, and the
            # arrays longer than :data:`_SHORT_REFINE`; until then they are computed on, unread)
            n_act = int(np.count_nonzero(act))
            if not n_act:
                return x
            if act.size > _SHORT_REFINE and 2 * n_act <= act.size:
                keep = act
                live, rigid, inv, half, al, ga, kal, c, S, C = (
                    live[keep], rigid[keep], inv[keep], half[keep], al[keep], ga[keep],
                    kal[keep], c[keep], S[keep], C[keep])
                lo, hi, xl, floor = lo[keep], hi[keep], xl[keep], floor[keep]
                back = tuple(a[keep] for a in back)
                act = np.ones(n_act, bool)
    x[live[act]] = xl[act]
    return x


def _quadratic(g: Sums, search, start, limit):
    """``(τ, function)`` of members whose modes are all rigid: each function is ``c + p τ +
    r τ²/2``, its first downward root after its start in closed form (as
    :func:`._roots._quadratic_crossing`; a double root is a touch)."""
    c = g.c
    p = msum(g.alpha)
    r = msum(g.gamma)
    with np.errstate(all="ignore"):
        disc = p * p - 2.0 * r * c
        q = -0.5 * (p + np.copysign(np.sqrt(np.maximum(disc, 0.0)), p))
        lin = np.where(p < 0, -c / p, np.nan)
        r1 = np.where(r == 0, lin, np.where(disc > 0, 2.0 * q / r, np.nan))
        r2 = np.where((r != 0) & (disc > 0) & (q != 0), c / q, np.nan)
    best = np.full(c.shape, np.inf)
    for root in (r1, r2):
        good = (root > start) & (root <= limit[:, None]) & (p + r * root < 0) & search
        best = np.where(good & (root < best), root, best)
    j = np.argmin(best, axis=1)
    t = best[np.arange(c.shape[0]), j]
    return np.where(np.isfinite(t), t, np.nan), np.where(np.isfinite(t), j, -1)
