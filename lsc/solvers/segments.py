"""The segment loop shared by the event-driven NumPy backends, and sampling into a Result.

A backend supplies ``advance(t0, y0, disc, horizon)``: integrate the frozen-mode system from
``(t0, y0)`` until the earliest armed event or ``horizon``, returning a :class:`Step`. This module
applies the event's transition (the model's, never the backend's), checks the physics status,
stops when no contact can close any more, and builds the Result from the event points (each
segment's ends) and the peaks located inside segments; the piecewise solution is sampled into
the series only when the Result's series are first read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import SimulationError
from ..result import Event, Result

__all__ = ["Step", "Segment", "run_segments", "build_result", "event_rows", "interior_peaks"]

#: Widest spacing of the probes of :func:`interior_peaks`, in radians of a segment's fastest
#: oscillation (a sinusoid's samples then fall within 1 - cos(0.25) = 3 % of its peak: each of
#: its maxima is a local maximum of the samples, bracketed by their neighbours).
PROBE_ANGLE = 0.5
#: Most probes of one segment in :func:`interior_peaks`.
MAX_PROBES = 20_001


@dataclass
class Step:
    """What one backend integration of a segment returns."""

    t: float                      # end time [time]
    y: np.ndarray                 # state at the end (2N,)
    event: int | None             # index of the event that ended it, None at the horizon
    dense: Callable               # dense(t_array) -> y (2N, n)
    steps: int = 0                # accepted steps
    nfev: int = 0                 # right-hand side evaluations


@dataclass
class Segment:
    """A piece of the solution with a frozen discrete state."""

    t0: float
    t1: float
    disc: list
    dense: Callable


def run_segments(model, advance, *, t_end=None, max_events=10_000):
    """Run ``advance`` from segment to segment until the crash is over (or until ``t_end``).

    Returns ``(segments, events, y_final, disc_final, totals)`` with ``totals`` the summed
    ``steps`` and ``nfev`` and, under ``"y_post"``, the state at the last separation (the
    post-crash state; braked vehicles may go on sliding after it). Raises :class:`SimulationError` when the event limit is reached, the
    physics cannot go on (see :data:`lsc.contact.STATUS`) or ``t_end`` comes before the crash is over.
    """
    y, disc = model.initial()
    disc = model.to_python(disc)
    model.check_status(disc, 0.0)
    t = 0.0
    horizon = float(t_end) if t_end is not None else model.crash_horizon
    # a contact that would close again only after this has no crash left in it
    # (HybridModel.contacts_apart); a t_end beyond the crash horizon extends it
    over_by = max(model.crash_horizon, horizon)
    segments, events = [], []
    totals = {"steps": 0, "nfev": 0}
    for k, st in enumerate(disc[: model.K]):
        if int(st["mode"]):
            events.append(Event(0.0, "contact", k))
    y_post = None
    while not model.is_over(y, disc, t, over_by):
        if len(events) >= max_events:
            raise SimulationError(
                f"event limit reached ({max_events} events by t = {t:.6g} s) and the crash is not "
                "over: raise solver.max_events, or check the scene for contacts that chatter"
                + _chatter(model, events))
        step = advance(t, y, disc, horizon)
        totals["steps"] += step.steps
        totals["nfev"] += step.nfev
        if not all(map(math.isfinite, np.ravel(step.y).tolist())):
            raise SimulationError(f"the solution became non-finite near t = {step.t:.6g} s")
        segments.append(Segment(t, step.t, disc, step.dense))
        t, y = step.t, np.asarray(step.y, float)
        if step.event is None:
            if t_end is not None and model.contacts_apart(y, disc, t, over_by):
                break  # only braked vehicles still slide: the crash itself is over
            if t_end is not None:
                raise SimulationError(
                    f"the requested end time t_end = {t_end:g} s comes before the crash is over "
                    "(a contact is still loaded or closing): raise solver.t_end or leave it unset")
            raise SimulationError(
                f"no event before t = {t:.6g} s although the crash is not over: the contact "
                "never separates (check the unloading branch)")
        # (the parts the event left alone keep their dicts, already on Python scalars)
        new = [st if st is was else model.to_python([st])[0] for st, was in
               zip(model.apply_event(step.event, t, y, disc, model.params), disc)]
        name = model.event_name(step.event, disc, new)
        events.append(Event(t, name, model.event_index(step.event)))
        # (a locked pair released by another part's event: lsc.locking)
        side = model.side_events(step.event, disc, new)
        events += [Event(t, kind, k) for kind, k in side]
        if "separation" in name or any("separation" in kind for kind, _ in side):
            y_post = y
        model.check_status(new, t)
        disc = new
    if t_end is not None and t_end > t:
        step = advance(t, y, disc, float(t_end))
        if step.event is not None:  # pragma: no cover - the crash is over, nothing can fire
            raise SimulationError("an event fired after the crash was over")
        segments.append(Segment(t, step.t, disc, step.dense))
        t, y = step.t, np.asarray(step.y, float)
    totals["y_post"] = y if y_post is None else y_post
    return segments, events, y, disc, totals


#: How many of a run's last events :func:`_chatter` reads.
CHATTER_TAIL = 20


def _chatter(model, events) -> str:
    """What the last :data:`CHATTER_TAIL` events of a run at its event limit tell, where most
    are one contact's: that contact and its events; and, where they are a damping law's turn
    and recompression over and over (its restoring factor, ``1 + α Ḋ`` or ``k + c Ḋ``, stiffer
    at a tiny restitution than an explicit integrator steps: Hunt–Crossley at e = 1e-12 with
    DOP853), the integrators that follow it ("" otherwise)."""
    from collections import Counter

    from ..laws import SpringDashpotLaw

    tail = events[-CHATTER_TAIL:]
    (k, most), = Counter(e.index for e in tail).most_common(1) or [(None, 0)]
    laws = getattr(model, "laws", ())
    if k is None or most < 0.8 * len(tail) or not 0 <= k < len(laws):
        return ""
    kinds = Counter(e.kind for e in tail if e.index == k)
    text = (f"; contact {k} chatters, its last {most} of {len(tail)} events: "
            + ", ".join(f"{kind} x{n}" for kind, n in kinds.items()))
    if isinstance(laws[k], SpringDashpotLaw) and set(kinds) <= {"max_deformation",
                                                                "recompression"}:
        text += (" (its damping law's restoring factor is stiffer at this restitution than an "
                 "explicit integrator steps: " + (
                     "solve with integrator='Radau' or method='diffrax')" if model.N == 2 else
                     "in a chain no integrator of lsc is known to follow it: Radau and BDF finish "
                     "but rounding may part a pair touching at rest and its first impact is then "
                     "misread, a car's delta_v 0; a larger restitution is followed)"))
    return text


def contact_records(model, disc) -> list[dict]:
    """Each contact's record (max and permanent deformation, absorbed and returned energy)."""
    return [{k: float(st[k]) for k in ("dmax", "fmax", "dperm", "ec", "er")}
            for st in disc[: model.K]]


def build_result(model, segments, events, y_final, disc_final, *, method, tolerances, stats,
                 n_samples=1000, y_post=None, peaks=(), rows=None,
                 interior=True) -> Result:
    """The :class:`Result` of a segment run: impacts and metrics from every segment's ends
    (:func:`event_rows`) and the peaks inside segments (a damping law's force, a chain's middle
    vehicle: :func:`interior_peaks`; plus ``peaks``, spans ``(t0, t1, force (K,), acceleration
    (N,))`` a backend located itself); the series (``n_samples`` points over the run, both ends
    of every segment included) sampled from the dense outputs when first read. ``rows``: the
    rows at the event points, if the backend has them (else :func:`event_rows`); ``interior``:
    search the peaks inside segments (``False`` where ``peaks`` holds them all, exactly)."""
    N = model.N
    post = np.asarray(y_final if y_post is None else y_post)
    rows = event_rows(model, segments, y_final) if rows is None else rows
    spans = list(peaks)
    if interior and segments:
        turns = _turning(rows)
        inside = [j for j, turn in enumerate(turns.any(axis=1).tolist())
                  if turn or model.work or N > 2]
        if inside:
            spans += interior_peaks(model, [segments[j] for j in inside], turns[inside])
    return Result.build(model.scene, rows=rows,
                        sampler=_Sampler(model, segments, y_final, n_samples), peaks=spans,
                        events=events, contacts=contact_records(model, disc_final),
                        v_final=post[N:2 * N], method=method, tolerances=tolerances, stats=stats)


def _turning(rows) -> np.ndarray:
    """Per segment and contact (S, K), from :func:`event_rows`: whether the deformation turns
    inside the segment (closing at its start, opening at its end, each by more than
    :data:`TURNING` of the largest speed: a contact reloaded along its unloading line, whose
    largest deformation is no event)."""
    v = rows["v"]
    closing = v[:, :-1] - v[:, 1:]
    tol = TURNING * float(np.max(np.abs(v), initial=0.0))
    return (closing[0::2] > tol) & (closing[1::2] < -tol)


#: A deformation turns inside a segment when its closing rate changes sign by more than this
#: fraction of the run's largest speed (less: an event located to rounding, or a turn whose
#: crush above the segment's ends is below rounding).
TURNING = 1e-6


def _columns(p) -> dict:
    """The model parameters ``p`` for states given as columns (the gaps as a column)."""
    return dict(p, gap=p["gap"][:, None])


def _full(x, shape) -> np.ndarray:
    """``x`` as a float array of ``shape`` (broadcast where a law gave a constant)."""
    x = np.asarray(x, float)
    return x if x.shape == shape else np.broadcast_to(x, shape)


def _values(model, s, tt, pp) -> dict:
    """Segment ``s``'s state ``y`` (n, len(tt)), contact forces (K, ·), accelerations (N, ·) and
    deformations (K, ·) at times ``tt``, in its frozen discrete state (``pp``: the parameters,
    :func:`_columns`)."""
    n = len(tt)
    yy = np.asarray(s.dense(tt), float).reshape(model.n_state, n)
    F, _, acc = model.accelerations(yy, s.disc, pp)
    D, _ = model.deformation(yy, pp)
    return {"y": yy, "force": _full(F, (model.K, n)), "a": _full(acc, (model.N, n)),
            "deformation": np.asarray(D, float)}


def _rows_of(model, parts, times) -> dict:
    """Rows (``t, x, v, a, deformation, force``) from per-segment :func:`_values`."""
    N = model.N
    Y = np.concatenate([q["y"].T for q in parts])
    return {"t": np.concatenate(times), "x": Y[:, :N], "v": Y[:, N:2 * N],
            "a": np.concatenate([q["a"].T for q in parts]),
            "deformation": np.concatenate([q["deformation"].T for q in parts]),
            "force": np.concatenate([q["force"].T for q in parts])}


def _at_rest(model, y_final) -> dict:
    """The single row of a run with no segment (cannot occur for a validated scene)."""
    y = np.asarray(y_final, float)
    return {"t": np.zeros(1), "x": y[None, :model.N], "v": y[None, model.N:2 * model.N],
            "a": np.zeros((1, model.N)), "deformation": np.zeros((1, model.K)),
            "force": np.zeros((1, model.K))}


def event_rows(model, segments, y_final) -> dict:
    """The rows at the event points: both ends of every segment, each in the segment's own
    discrete state (so both sides of every event), as the series would hold them."""
    if not segments:
        return _at_rest(model, y_final)
    times = [np.array([s.t0, s.t1]) for s in segments]
    pp = _columns(model.params)
    return _rows_of(model, [_values(model, s, tt, pp) for s, tt in zip(segments, times)], times)


class _Sampler:
    """The series of a segment run: ``n_samples`` points spread over the segments by their
    length, both ends of every segment included (a Result's ``sampler``)."""

    def __init__(self, model, segments, y_final, n_samples: int):
        self.model, self.segments, self.y_final, self.n_samples = (model, segments, y_final,
                                                                   n_samples)

    def __call__(self) -> dict:
        segments = self.segments
        if not segments:
            return _at_rest(self.model, self.y_final)
        total = max(sum(s.t1 - s.t0 for s in segments), 1e-300)
        times = [np.linspace(s.t0, s.t1,
                             max(2, int(round(self.n_samples * (s.t1 - s.t0) / total)) + 1))
                 for s in segments]
        pp = _columns(self.model.params)
        return _rows_of(self.model, [self.values(j, s, tt, pp)
                                     for j, (s, tt) in enumerate(zip(segments, times))], times)

    def values(self, j: int, s, tt, pp) -> dict:
        """Segment ``j`` (``s``)'s :func:`_values` at times ``tt`` (a backend may change them)."""
        return _values(self.model, s, tt, pp)


def interior_peaks(model, segments, turns, probes: int = 33, iterations: int = 40) -> list:
    """Peaks that can lie inside a segment (a damping law's force, a chain's middle vehicle, a
    contact reloaded along its unloading line), located on the dense output to the solver's
    accuracy: in each segment, each force, acceleration and deformation is sampled at
    ``probes`` points, or :data:`PROBE_ANGLE` apart in radians of the segment's fastest
    oscillation (:meth:`~lsc.model.HybridModel.natural_frequency`) where that is closer, and
    **every** local maximum of the samples (of a force and a deformation; of an
    acceleration's magnitude) searched by golden sections, all of them at once (one
    dense-output call per iteration), to 1e-8 of the bracket in time: the value, at a smooth
    maximum, to rounding. (Refining only the largest sample took the wrong one of two near-equal
    peaks: a chain's middle car, +102.70 then -102.63 ft/s² in one segment, was given -102.63.)
    Returns one span ``(t0, t1, force (K,), acceleration (N,) signed, deformation (K,))`` per
    segment; the deformation only where ``turns`` (S, K) says it turns inside the segment (else
    -inf: its largest value is at an end, which the event rows hold).

    (For the IF-D law of two vehicles the force is affine in a deformation that is monotone
    inside every segment of a first impact, so its peaks are at events, which the event rows
    hold exactly.)"""
    if not segments:
        return []
    K, N = model.K, model.N
    golden = 0.5 * (np.sqrt(5.0) - 1.0)
    pp = _columns(model.params)
    n_q = 2 * K + N
    rows = np.arange(n_q)
    largest = (rows < K) | (rows >= K + N)   # forces and deformations: their largest value

    def stacked(q):
        """Forces, accelerations and deformations (2K + N, ·) of :func:`_values`'s ``q``."""
        return np.concatenate([q["force"], q["a"], q["deformation"]])

    spans = []
    for s, turn in zip(segments, turns):
        if not s.t1 > s.t0:
            continue
        omega = float(model.natural_frequency(s.disc))
        n = int(min(max(probes, math.ceil(omega * (s.t1 - s.t0) / PROBE_ANGLE) + 1),
                    MAX_PROBES))
        tt = np.linspace(s.t0, s.t1, n)
        probed = _values(model, s, tt, pp)
        q = stacked(probed)
        obj = np.where(largest[:, None], q, np.abs(q))
        # every local maximum of the samples (ends included): its neighbours bracket a maximum
        pad = np.full((n_q, 1), -np.inf)
        left, right = np.hstack([pad, obj[:, :-1]]), np.hstack([obj[:, 1:], pad])
        peak = (obj > left) & (obj >= right)   # (a plateau: its first sample)
        if omega > 0:   # (not one that cannot reach its quantity's largest sample: |q''| <=
            #              ω² |q|max bounds the rise between probes Δ apart by (ω Δ)² |q|max / 8;
            #              8 times that is kept)
            top = np.max(obj, axis=1, keepdims=True)
            rise = (omega * (tt[1] - tt[0])) ** 2 * np.max(np.abs(q), axis=1, keepdims=True)
            peak &= obj >= top - rise
        row, j = np.nonzero(peak)
        sgn = np.where(largest[row], 1.0, np.sign(q[row, j]) + (q[row, j] == 0))
        lo, hi = tt[np.maximum(j - 1, 0)], tt[np.minimum(j + 1, n - 1)]
        a, b = hi - golden * (hi - lo), lo + golden * (hi - lo)
        cols = np.arange(row.size)

        def value(t):
            return sgn * stacked(_values(model, s, t, pp))[row, cols]

        fa, fb = value(a), value(b)
        for _ in range(iterations):
            go_left = fa >= fb   # the maximum lies in [lo, b]
            hi, lo = np.where(go_left, b, hi), np.where(go_left, lo, a)
            a, b, fa, fb = (np.where(go_left, hi - golden * (hi - lo), b),
                            np.where(go_left, a, lo + golden * (hi - lo)),
                            np.where(go_left, np.nan, fb), np.where(go_left, fa, np.nan))
            new = value(np.where(go_left, a, b))
            fa, fb = np.where(go_left, new, fa), np.where(go_left, fb, new)
        found = np.maximum(sgn * q[row, j], np.maximum(fa, fb))   # (signed as sgn: >= 0 for a)
        best = np.full(n_q, -np.inf)
        np.maximum.at(best, row, found)
        # an acceleration: the sign of its largest-magnitude maximum
        order = np.lexsort((found, row))   # by quantity, then by value
        last = order[np.r_[np.nonzero(np.diff(row[order]))[0], order.size - 1]]
        sign = np.where(largest, 1.0, sgn[last])   # (every quantity has a local maximum)
        best, sign = _rounding_floor(model, s, probed, best, sign, K, N)
        spans.append((s.t0, s.t1, best[:K], sign[K:K + N] * best[K:K + N],
                      np.where(turn, best[K + N:], -np.inf)))
    return spans



def _rounding_floor(model, s, probed, best, sign, K: int, N: int) -> tuple:
    """``best`` (2K + N,) and ``sign`` with each force and acceleration peak found inside
    segment ``s`` that rises above the segment's ends by no more than the rounding of the dense
    output's absolute positions times the contact slopes (4 ulps of the largest position;
    ``probed``: :func:`_values` at the probes) taken back to the larger end, with its sign: such
    a rise is noise, not a peak. A near-plastic rebound line (e = 1e-6: 5.4e18 lbf/ft) 167 ft
    down the road turns one ulp of the positions, 2.8e-14 ft, into 1.5e5 lbf: diffrax reported
    3.09e5 lbf as the peak force where the contact's largest force is 3891.5 lbf."""
    ulp = float(np.spacing(np.max(np.abs(probed["y"][:N]))))
    slope = np.array([abs(float(st["s"])) if "s" in st and int(st["mode"]) else 0.0
                      for st in s.disc[:K]])
    noise = 4.0 * slope * ulp   # (K,) force
    if not np.any(noise > 0):
        return best, sign
    F, a = probed["force"], probed["a"]
    f_end = np.maximum(F[:, 0], F[:, -1])
    best, sign = best.copy(), sign.copy()
    best[:K] = np.where(best[:K] - f_end <= noise, f_end, best[:K])
    pad = np.zeros(1)
    noise_a = (np.r_[pad, noise] + np.r_[noise, pad]) / np.asarray(model.params["m"], float)
    a0, a1 = a[:, 0], a[:, -1]
    a_end = np.maximum(np.abs(a0), np.abs(a1))
    moved = (best[K:K + N] - a_end <= noise_a) & (best[K:K + N] != a_end)
    best[K:K + N] = np.where(moved, a_end, best[K:K + N])
    sign[K:K + N] = np.where(moved, np.where(np.abs(a0) >= np.abs(a1), np.sign(a0), np.sign(a1)),
                             sign[K:K + N])
    return best, sign
