"""Every metric lsc reports for a chain (``lsc.result.METRICS``), computed from the independent
solution of tests/hard/modal_chain.py (its events, and its segments' closed-form motion) by the
definitions of docs/metrics.rst, sharing no code with lsc.

Peaks inside a segment (a vehicle's acceleration, a contact's force) are found by a bound-based
search, the same no-miss idea as the event search: the segment is sampled, and an interval whose
samples and the bound ``B`` on the function's second derivative (``max |h| <= max(|h(a)|,
|h(b)|) + B Δ² / 8``) cannot rule out a value beyond the best found is bisected until they can,
or until the bound on the third derivative shows ``h'`` monotone there, where its one root (if
any) is located to machine precision.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from hard.modal_chain import PER_RADIAN, ModalChain, _Series

#: A contact whose closing speed at touch is at most this fraction of the run's largest speed
#: (at its events) is pushed shut, not struck (docs/metrics.rst).
PUSHED = 1e-6
#: The least relative time resolution of a solve, for simultaneous touches (docs/metrics.rst).
TIE_ROUNDING = 1e-13
BRAKE_KINDS = ("stop", "reversal", "break_away")


def peak(h: _Series, T: float) -> float:
    """The value of largest magnitude (signed) of the scalar series ``h`` on ``[0, T]``."""
    hi, lo = extremes(h, T)
    return hi if hi >= -lo else lo


def extremes(h: _Series, T: float) -> tuple[float, float]:
    """The largest and the smallest value of the scalar series ``h`` on ``[0, T]``; the one of
    smaller magnitude only where it is within 1e-9 of the other's, else a sample's (what matters
    of it is whether the two tie)."""
    omax = float(np.max(h.omega, initial=0.0))
    n = max(int(np.ceil(T * PER_RADIAN * omax)), 1)
    tt = np.linspace(0.0, T, n + 1)
    g = h(tt)
    first = 1.0 if np.max(g) >= -np.min(g) else -1.0
    top = _largest(h, tt, g, first)
    other = _largest(h, tt, g, -first, (1 - 1e-9) * abs(top))
    return (top, -other) if first > 0 else (other, -top)


def _largest(h, tt, g, sign, floor=-np.inf):
    """The largest value of ``sign h`` (samples ``g`` at ``tt``), or the largest sample where
    it is below ``floor``."""
    best = float(np.max(sign * g))
    bar = max(best, floor)
    hd = h.derivative()
    hdd = hd.derivative()
    B2, B3 = float(h.curvature_bound()), float(hd.curvature_bound())
    todo = [(tt[i], tt[i + 1], sign * g[i], sign * g[i + 1], 0) for i in range(len(tt) - 1)]
    while todo:
        a, b, ga, gb, depth = todo.pop()
        if max(ga, gb) + B2 * (b - a) ** 2 / 8 <= bar:
            continue
        mid = 0.5 * (a + b)
        if abs(float(hdd(mid))) > B3 * (b - a) / 2 or depth > 60:   # h' monotone on [a, b]
            da, db = float(hd(a)), float(hd(b))
            if da * db < 0:
                val = sign * float(h(brentq(hd, a, b, xtol=1e-18, rtol=8.9e-16, maxiter=200)))
                best, bar = max(best, val), max(bar, val)
            continue
        gm = sign * float(h(mid))
        best, bar = max(best, gm), max(bar, gm)
        todo += [(a, mid, ga, gm, depth + 1), (mid, b, gm, gb, depth + 1)]
    return best


def _first_impacts(ch: ModalChain):
    """Per contact: first touch, its (rear, front) speeds, the end of that first impact, the
    speeds then (NaN where none); the run's largest speed at its events; the speeds at the end."""
    K = ch.K
    ct, end = np.full(K, np.nan), np.full(K, np.nan)
    vt, vs = np.full((K, 2), np.nan), np.full((K, 2), np.nan)
    ct[ch.touching0] = 0.0
    vt[ch.touching0] = np.stack([ch.v0[:-1], ch.v0[1:]], axis=1)[ch.touching0]
    vmax = float(np.max(np.abs(ch.v0)))
    v_last = ch.v0
    for t, (what, j), name, v in ch.log:
        vmax, v_last = max(vmax, float(np.max(np.abs(v)))), v
        if what != "c":
            continue
        if name == "contact" and np.isnan(ct[j]):
            ct[j], vt[j] = t, v[j: j + 2]
        if "separation" in name and not np.isnan(ct[j]) and np.isnan(end[j]):
            end[j], vs[j] = t, v[j: j + 2]
    return ct, vt, end, vs, vmax, v_last


def _peaks(ch: ModalChain, ct, end):
    """Per contact over its first impact: the peak force, and the (rear, front) accelerations'
    largest and smallest values (K, 2, 2: [..., 0] largest)."""
    K = ch.K
    fpk, apk = np.zeros(K), np.zeros((K, 2, 2))
    stop = np.where(np.isnan(end), np.inf, end)
    for t0, t1, X, (a, s, F0) in ch.segments:
        on = ~np.isnan(ct) & (ct <= t0) & (t1 <= stop)
        if not on.any():
            continue
        T = t1 - t0
        D = ch.deformations(X)
        A = X.derivative().derivative()
        acc = {}
        for j in np.flatnonzero(on):
            F = D[j].rebased(s[j], F0[j])
            fpk[j] = max(fpk[j], peak(F, T) if s[j] or F0[j] else 0.0)
            for side in (0, 1):
                i = j + side
                if i not in acc:
                    acc[i] = extremes(A[i], T)   # (0 for a stuck vehicle: constant)
                apk[j, side] = max(apk[j, side, 0], acc[i][0]), min(apk[j, side, 1], acc[i][1])
    return fpk, apk


def metrics(ch: ModalChain, resolution: float = 0.0) -> dict:
    """Every metric of ``lsc.result.METRICS`` (per docs/metrics.rst) of a chain ``ch`` that has
    run (:meth:`ModalChain.run`); ``resolution``: the solve's relative time resolution the tie
    rule uses (0 for an exact solve)."""
    K, N = ch.K, ch.N
    ct, vt, end, vs, vmax, v_last = _first_impacts(ch)
    fpk, apk = _peaks(ch, ct, end)
    touched, ended = ~np.isnan(ct), ~np.isnan(end)
    t_last = ch.log[-1][0] if ch.log else 0.0
    v_end = np.where(ended[:, None], vs, np.stack([v_last[:-1], v_last[1:]], axis=1))
    e_end = np.where(ended, end, t_last)
    closing = vt[:, 0] - vt[:, 1]
    struck = touched & (closing > PUSHED * vmax)
    pushed = touched & ~struck
    rest = np.where(struck, (v_end[:, 1] - v_end[:, 0]) / np.where(struck, closing, 1.0), np.nan)
    tie = np.maximum(resolution, TIE_ROUNDING) * np.maximum(np.abs(ct), e_end - ct)
    # a contact pushed shut during a neighbour's first impact touches with that neighbour
    eff = np.where(touched, ct, np.inf)
    for _ in range(K):
        for j in range(K):
            for n in (j - 1, j + 1):
                if 0 <= n < K and pushed[j] and touched[n] and ct[n] <= ct[j] <= e_end[n]:
                    eff[j] = min(eff[j], eff[n])
    dv, acc, other = np.zeros(N), np.zeros(N), np.zeros(N)
    for i in range(N):
        sides = [(j, i - j) for j in (i - 1, i) if 0 <= j < K and touched[j]]
        if not sides:
            continue
        if len(sides) == 2:
            (r, sr), (f, sf) = sides
            first = (r, sr) if ct[r] <= ct[f] else (f, sf)
            tied = abs(eff[r] - eff[f]) <= max(tie[r], tie[f])
            impact = (r, sr) if tied else first
        else:
            first = impact = sides[0]
        dv[i] = v_end[impact] - vt[first]
        hi, lo = apk[impact]
        acc[i], other[i] = (hi, lo) if hi >= -lo else (lo, hi)
    if touched.any():
        w0 = np.min(eff[touched])
        group = touched & (eff - w0 <= tie)
        k1 = int(np.argmax(group))
        duration = e_end[k1] - np.min(ct[group])
    else:
        duration = 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        e_energy = np.sqrt(ch.er / ch.ec)
    return {"delta_v": dv, "v_final": ch.v_post, "peak_acceleration": acc,
            "peak_acceleration_g": acc / ch.g, "duration": duration,
            "max_deformation": ch.M.copy(), "permanent_deformation": ch.perm.copy(),
            "peak_force": fpk, "restitution": rest, "restitution_energy": e_energy,
            "energy_absorbed": ch.ec.copy(), "energy_returned": ch.er.copy(),
            "failure_time": np.full(K, np.nan),
            # (not Result metrics: each contact's closing speed at its first touch; whether
            # the run ended with a contact held shut between two stuck vehicles; each
            # vehicle's extreme acceleration of the other sign, the peak where the two tie)
            "closing_speed": closing, "held": bool(np.any(ch.mode != 0)),
            "peak_acceleration_other": other}
