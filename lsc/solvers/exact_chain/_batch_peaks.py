"""The largest and smallest values of many chains' forces and accelerations over their
segments at once (the batch's :mod:`._peaks`), with the guarantee of :mod:`._roots`: samples
on windows of steps of ``1 / (PER_RADIAN ω)``, the derivative's sign changes refined
(:func:`._batch_roots.refine`), its grazing intervals bounded or sampled again, finer.
"""

from __future__ import annotations

import numpy as np

from ._batch_modes import Sums, many, mmax, mmin
from ._batch_roots import MAX_WINDOWS, WINDOW, refine
from ._roots import EXTREMUM_RTOL, PER_RADIAN

__all__ = ["extreme_values", "bars", "FLAT", "PEAK_LEVELS"]

#: An interval where a function's derivative may touch zero between samples of one sign is
#: left at its samples where the largest excess of the function over them that this allows
#: is below this fraction of the function's size there (:data:`._roots.FLAT`, relaxed from
#: 1e-15 to what :data:`._roots.DEPTH` bisections leave in the single solve).
FLAT = 1e-14
#: How many times at most :func:`extreme_values` samples an interval again, finer.
PEAK_LEVELS = 6
#: The first pass's windows, in steps: a member whose ``[0, T]`` takes no more steps than one
#: of these is sampled on the least that holds it (the same samples as on :data:`WINDOW`
#: steps, without the copies of ``T`` after them), where the pass has at least
#: :data:`_SPLIT` members.
_FIRST_WINDOWS = (WINDOW // 4, WINDOW // 2, WINDOW)
_SPLIT = 256


def extreme_values(g: Sums, T, largest, turns=None, bars=None):
    """Over ``[0, T]`` (T (b,) [s]) of each member, each function's largest and smallest
    values: ``(top (b, F), bottom (b, F), undecided (b,))``, exact for the largest value where
    ``largest`` (b, F) or (F,) (and for the value of largest magnitude where that is the
    largest, as it is for a force), for the value of largest magnitude elsewhere. The values
    are taken at every sample, at both ends and at every zero of the derivative, whose sign
    changes are found and refined as :func:`._batch_roots.earliest` finds zeros. Where the
    derivative may touch zero between two samples of one sign (the bound on the third
    derivative cannot clear it), the function can exceed its samples there by at most ``w (B
    w²/8 - min |g'|)`` (``w`` the width): such an interval is cleared where that is below
    :data:`FLAT` of the function's size, or where the derivative is provably monotone on it (a
    bound on the next derivative), else sampled again :data:`WINDOW` times finer, up to
    :data:`PEAK_LEVELS` times; a member with an interval still not cleared is *undecided* (the
    caller solves it alone). ``turns`` (b, F) bool, optional: the functions that may turn
    inside ``[0, T]``; the others are monotone (their extremes are at the ends, among the
    samples), and neither their derivative's zeros nor its grazing intervals are searched."""
    b, F = g.c.shape
    largest = np.broadcast_to(largest, (b, F))
    d = g.derivative()
    dd = d.derivative()
    Bd, Bdd = d.curvature_bound(), dd.curvature_bound()
    w_max = mmax(g.w)
    step = np.where(w_max > 0, 1.0 / (PER_RADIAN * np.where(w_max > 0, w_max, 1.0)),
                    np.maximum(T, 1e-300) / 2)
    top = np.full((b, F), -np.inf)
    bottom = np.full((b, F), np.inf)
    undecided = np.zeros(b, bool)
    late, zeros = [], []

    def one_pass(r, lo, hi, h, level, age, first, count, window, unique):
        """One pass over the intervals ``r, lo, hi, h, level, age`` (each interval's member,
        ends, step, level and age; ``first``: level 0) of ``count`` windows of ``window``
        steps: the values folded into ``top``, ``bottom``, the derivative's sign changes into
        ``zeros``, the intervals grazed at the last level into ``late``; returns the intervals
        still to sample (``unique``: ``r`` names each member once)."""
        tt, end = _windows(lo, hi, h, first, count, window)
        gl, dl = g.take(r), d.take(r)
        SC = gl.basis(tt)
        vals, dv = gl.on(SC), dl.on(SC)
        if unique:
            top[r] = np.fmax(top[r], mmax(vals))
            bottom[r] = np.fmin(bottom[r], mmin(vals))
        else:
            np.fmax.at(top, r, mmax(vals))
            np.fmin.at(bottom, r, mmin(vals))
        # the derivative's sign changes and grazing intervals, on the functions that may turn
        # only (the pairs ``pm, pj`` of row and function)
        pm, pj = np.nonzero(turns[r] if turns is not None else np.ones(dv.shape[:2], bool))
        dvp = dv[pm, pj]
        a, c = dvp[:, :-1], dvp[:, 1:]                                       # (P, W)
        w = tt[:, 1:] - tt[:, :-1]                                          # (m, W)
        wp = w[pm]
        margin = Bd[r[pm], pj][:, None] * wp ** 2 / 8.0
        change = (a * c <= 0) & (a != c)
        if change.any():
            # (a zero of g' whose value cannot beat the peak so far need not be refined:
            # there |g| <= min(|g(a)|, |g(b)|) + w (max |g'| + B w²/8))
            # (on the sign changes only)
            p, i = np.nonzero(change)
            m, j = pm[p], pj[p]
            am, cm = a[p, i], c[p, i]
            reach = (np.minimum(np.abs(vals[m, j, i]), np.abs(vals[m, j, i + 1]))
                     + w[m, i] * (np.maximum(np.abs(am), np.abs(cm)) + margin[p, i]))
            tm, bm = top[r[m], j], bottom[r[m], j]
            peak = np.where(largest[r[m], j], tm, np.maximum(np.abs(tm), np.abs(bm)))
            if bars is not None:
                peak = np.maximum(peak, bars[r[m], j])
            p, i = (x[~(reach < peak)] for x in (p, i))
            m, j = pm[p], pj[p]
            zeros.append((r[m], j, tt[m, i], tt[m, i + 1], a[p, i], c[p, i],
                          dl.take(m, j), gl.take(m, j)))
        low = np.minimum(np.abs(a), np.abs(c))
        grazing = ~change & (low <= margin)
        new = []
        if grazing.any():
            # (the rows that have some, each function's intervals there)
            some = many(grazing)
            rows = pm[some]                  # (in order: ``pm`` is)
            fresh = np.r_[True, rows[1:] != rows[:-1]]
            q = rows[fresh]
            rq, wq = r[q], w[q][:, None, :]
            at = (np.cumsum(fresh) - 1, pj[some])
            size = np.maximum(np.abs(top[rq]), np.abs(bottom[rq]))[:, :, None]
            excess = np.zeros((q.size,) + dv[..., 1:].shape[1:])
            excess[at] = wp[some] * (margin[some] - low[some])
            grazed = np.zeros(excess.shape, bool)
            grazed[at] = grazing[some]
            ddv = dd.take(rq).on(SC[q])
            e, f = ddv[..., :-1], ddv[..., 1:]
            monotone = (e * f > 0) & (np.minimum(np.abs(e), np.abs(f))
                                      > Bdd[rq][:, :, None] * wq ** 2 / 8.0)
            bad = grazed & ~monotone & (excess > FLAT * size)                 # (m, F, W)
            deep = bad & (level[q] >= PEAK_LEVELS)[:, None, None]
            if deep.any():   # (judged at the end, against the function's size on [0, T])
                m, j, i = np.nonzero(deep)
                late.append((rq[m], j, excess[m, j, i]))
            m, i = np.nonzero((bad & ~deep).any(axis=1))
            m = q[m]
            new.append((r[m], tt[m, i], tt[m, i + 1], (tt[m, i + 1] - tt[m, i]) / WINDOW,
                        level[m] + 1, age[m] + i // WINDOW + 1))
        go = first & (end < hi)
        new.append((r[go], end[go], hi[go], h[go], level[go], age[go] + count))
        return new

    # the intervals still to sample: member, start, end, step, level (0: the end is T), and
    # the pass one window at a time would sample it on (its age)
    r = np.arange(b)
    lo, hi, h, level = np.zeros(b), np.asarray(T, float), step, np.zeros(b, int)
    age = np.zeros(b, int)
    passes = MAX_WINDOWS * 4
    for k in range(passes):
        if not r.size:
            break
        # the level-0 intervals take windows that double (1, 2, 4, ... up to 64 a pass),
        # each placed as one window at a time would place it
        first = level == 0
        count = min(1 << k, 64, passes - int(age[first].min())) if first.any() else 1
        parts = [(slice(None), WINDOW)]
        if k == 0 and r.size >= _SPLIT:   # (pass 0: every member once, each at level 0)
            # (each member on the first window that holds it; the last holds the rest)
            fits = [hi <= window * h for window in _FIRST_WINDOWS[:-1]]
            least = np.full(r.size, len(fits))
            for i in reversed(range(len(fits))):
                least[fits[i]] = i
            parts = [(np.flatnonzero(least == i), window)
                     for i, window in enumerate(_FIRST_WINDOWS)]
        new = []
        for p, window in parts:
            if np.size(r[p]):
                new += one_pass(r[p], lo[p], hi[p], h[p], level[p], age[p], first[p], count,
                                window, k == 0)
        r, lo, hi, h, level, age = (np.concatenate(x) for x in zip(*new))
        late_pass = age >= passes      # (beyond the passes one window at a time would take)
        undecided[r[late_pass]] = True
        keep = ~late_pass
        r, lo, hi, h, level, age = r[keep], lo[keep], hi[keep], h[keep], level[keep], age[keep]
    undecided[r] = True
    if zeros:    # (the derivative's zeros of every pass refined at once, each on its own)
        m, j, ta, tb, fa, fb = (np.concatenate(x) for x in zip(*(q[:6] for q in zeros)))
        roots = refine(Sums.joined([q[6] for q in zeros]), ta, tb, fa, fb, rtol=EXTREMUM_RTOL)
        at = Sums.joined([q[7] for q in zeros]).each_at(roots[:, None])[:, 0]
        np.fmax.at(top, (m, j), at)
        np.fmin.at(bottom, (m, j), at)
    size = np.maximum(np.abs(top), np.abs(bottom))
    for m, j, excess in late:
        undecided[m[excess > FLAT * size[m, j]]] = True
    return top, bottom, undecided


def _windows(lo, hi, h, first, count, window=WINDOW):
    """Sample times (m, count window + 1) of the intervals ``[lo, hi]`` (m,) sampled every
    ``h``: where ``first``, ``count`` windows of ``window`` steps one after the other, each
    ending at ``min(its start + window h, hi)`` (the last one's end returned (m,)); elsewhere
    one window ending at ``hi``; the rest of a row is its end repeated (intervals of width 0)."""
    tt = np.empty((lo.size, count * window + 1))
    steps = h[:, None] * np.arange(window + 1)
    start = lo
    for j in range(count):
        end = np.where(first, np.minimum(start + window * h, hi), hi)
        block = tt[:, j * window:(j + 1) * window + 1]
        np.minimum(start[:, None] + steps, end[:, None], out=block)
        block[:, -1] = end
        start = end
    return tt, end


def bars(first, ongoing, r):
    """(m, K + N - 2) of members ``r``: what each contact's force and each middle vehicle's
    acceleration (magnitude) must exceed to change the first-impact record
    (:func:`lsc.metrics.fold_peaks`, which folds them into the contacts whose first impact is
    ``ongoing``; inf where none is): the peak force so far; the smaller magnitude of the
    vehicle's peak accelerations in its two contacts (front of one, rear of the next)."""
    ong = ongoing[r]
    force = np.where(ong, first["peak_force"][r], np.inf)
    acc = np.where(ong[..., None], np.abs(first["peak_acc"][r]), np.inf)     # (m, K, 2)
    return np.concatenate([force, np.minimum(acc[:, :-1, 1], acc[:, 1:, 0])], axis=1)
