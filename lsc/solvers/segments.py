"""The segment loop shared by the event-driven NumPy backends, and sampling into a Result.

A backend supplies ``advance(t0, y0, disc, horizon)``: integrate the frozen-mode system from
``(t0, y0)`` until the earliest armed event or ``horizon``, returning a :class:`Step`. This module
applies the event's transition (the model's, never the backend's), checks the physics status,
stops when no contact can close any more, and samples the piecewise solution for the result.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import SimulationError
from ..result import Event, Result

__all__ = ["Step", "Segment", "run_segments", "build_result"]


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
                "over: raise solver.max_events, or check the scene for contacts that chatter")
        step = advance(t, y, disc, horizon)
        totals["steps"] += step.steps
        totals["nfev"] += step.nfev
        if not np.all(np.isfinite(step.y)):
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
        new = model.to_python(model.apply_event(step.event, t, y, disc, model.params))
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


def contact_records(model, disc) -> list[dict]:
    """Each contact's record (max and permanent deformation, absorbed and returned energy)."""
    return [{k: float(st[k]) for k in ("dmax", "fmax", "dperm", "ec", "er")}
            for st in disc[: model.K]]


def build_result(model, segments, events, y_final, disc_final, *, method, tolerances, stats,
                 n_samples=1000, y_post=None) -> Result:
    """Sample every segment (both ends included) and assemble the :class:`Result`."""
    p = model.params
    total = max(sum(s.t1 - s.t0 for s in segments), 1e-300)
    ts, ys, As, Ds, Fs = [], [], [], [], []
    for s in segments:
        n = max(2, int(round(n_samples * (s.t1 - s.t0) / total)) + 1)
        tt = np.linspace(s.t0, s.t1, n)
        yy = np.asarray(s.dense(tt), float).reshape(model.n_state, n)
        pp = dict(p, gap=p["gap"][:, None])
        Fk, _, acc = model.accelerations(yy, s.disc, pp)
        Fk = np.broadcast_to(np.asarray(Fk, float), (model.K, n))
        acc = np.broadcast_to(np.asarray(acc, float), (model.N, n)).T
        F = Fk.T
        D, _ = model.deformation(yy, pp)
        ts.append(tt)
        ys.append(yy.T)
        As.append(acc)
        Ds.append(np.asarray(D).T)
        Fs.append(F)
    if not segments:  # nothing happened (cannot occur for a validated scene, kept for safety)
        ts, ys = [np.zeros(1)], [np.asarray(y_final)[None, :]]
        As, Ds, Fs = [np.zeros((1, model.N))], [np.zeros((1, model.K))], [np.zeros((1, model.K))]
    Y = np.concatenate(ys)
    N = model.N
    post = np.asarray(y_final if y_post is None else y_post)
    r = Result.build(model.scene, t=np.concatenate(ts), x=Y[:, :N], v=Y[:, N:2 * N],
                     a=np.concatenate(As), deformation=np.concatenate(Ds),
                     force=np.concatenate(Fs), events=events,
                     contacts=contact_records(model, disc_final), v_final=post[N:2 * N],
                     method=method, tolerances=tolerances, stats=stats)
    if segments and (model.work or model.N > 2):
        _refine_peaks(model, segments, r)
    return r


def _refine_peaks(model, segments, r, probes: int = 33, iterations: int = 40) -> None:
    """Peaks that can lie inside a segment (a damping law's force, a chain's middle vehicle),
    located on the dense output to the solver's accuracy rather than read off the samples:
    in each segment, each force and acceleration is sampled at ``probes`` points and its largest
    sample's neighbourhood searched by golden sections, all of them at once (one dense-output
    call per iteration for every quantity), to 1e-8 of the bracket in time: the value, at a
    smooth maximum, to rounding.

    (For the IF-D law of two vehicles the force is affine in a deformation that is monotone
    inside every segment, so its peaks are at events, which the samples hold exactly.)"""
    p = model.params
    pp = dict(p, gap=p["gap"][:, None])
    K, N = model.K, model.N
    golden = 0.5 * (np.sqrt(5.0) - 1.0)

    def quantities(s, t):
        """Forces and accelerations (K + N, len(t)) at times ``t``."""
        yy = np.asarray(s.dense(np.atleast_1d(t)), float).reshape(model.n_state, -1)
        F, _, a = model.accelerations(yy, s.disc, pp)
        return np.concatenate([np.broadcast_to(np.asarray(F, float), (K, yy.shape[1])),
                               np.broadcast_to(np.asarray(a, float), (N, yy.shape[1]))])

    spans = []
    rows = np.arange(K + N)
    for s in segments:
        if not s.t1 > s.t0:
            continue
        tt = np.linspace(s.t0, s.t1, probes)
        q = quantities(s, tt)
        # forces: their largest value; accelerations: their largest magnitude, with its sign
        j = np.where(rows < K, np.argmax(q, axis=1), np.argmax(np.abs(q), axis=1))
        sgn = np.where(rows < K, 1.0, np.sign(q[rows, j]) + (q[rows, j] == 0))
        best = sgn * q[rows, j]
        lo, hi = tt[np.maximum(j - 1, 0)], tt[np.minimum(j + 1, probes - 1)]
        a, b = hi - golden * (hi - lo), lo + golden * (hi - lo)

        def value(t):
            return sgn * quantities(s, t)[rows, rows]

        fa, fb = value(a), value(b)
        for _ in range(iterations):
            left = fa >= fb   # the maximum lies in [lo, b]
            hi, lo = np.where(left, b, hi), np.where(left, lo, a)
            a, b, fa, fb = (np.where(left, hi - golden * (hi - lo), b),
                            np.where(left, a, lo + golden * (hi - lo)),
                            np.where(left, np.nan, fb), np.where(left, fa, np.nan))
            new = value(np.where(left, a, b))
            fa, fb = np.where(left, new, fa), np.where(left, fb, new)
        best = np.maximum(best, np.maximum(fa, fb))
        spans.append((s.t0, s.t1, best[:K], sgn[K:] * best[K:]))
    r._raise_peaks(spans)  # each impact's peaks over the segments it holds
