"""One chain, segment by segment: the closed-form motion (:mod:`._modes`), its events located
with a guarantee (:mod:`._roots`), the model's transitions (:func:`~lsc.solvers.segments.run_segments`).

A segment starts on the surface of the event that ended the last one (the restart trap). An
event function within rounding of zero at the start is judged by its first derivative that is
not: going down, it fires at once (a contact touching at rest that a neighbour pushes shut,
however far down the chain: its deformation grows as a high power of time); going up, it is
left alone over the interval where its Taylor polynomial with that derivative and a bound on
the next one is provably positive, and searched from there on. A function whose derivatives
all vanish (up to the order that decides it) stays on its surface all along the segment.
"""

from __future__ import annotations

import math
import time

import numpy as np

from ..segments import Step, build_result, run_segments
from ._modes import Motion, Series, deformation_map
from ._roots import PER_RADIAN, earliest, extrema, first_crossing

__all__ = ["solve"]

#: Event functions within this fraction of their scale (length, speed) are on their surface.
START_TOL = 1e-13
#: Most samples of one event function in one segment before the search gives up (the segment
#: then ends at the last time searched with no event, and the run says the crash never ends).
MAX_SAMPLES = 2_000_000
_EPS = float(np.finfo(float).eps)


def solve(model, *, t_end=None, n_samples: int = 1000, max_events: int = 10_000):
    """Solve a chain ``model`` (IF-D contacts with straight or tabulated loading and a straight
    unloading line) exactly, segment by segment, as a :class:`~lsc.result.Result`.

    ``t_end`` [s]: simulate until then (must not cut the crash); ``n_samples``: points in the
    sampled series (every event is a sample); ``max_events``: limit on discrete events.
    """
    from . import BACKEND

    BACKEND.check(model)
    chain = _Chain(model)
    start = time.perf_counter()
    segments, events, y, disc, totals = run_segments(_transitions(model), chain.advance,
                                                     t_end=t_end, max_events=max_events)
    stats = {"steps": totals["steps"], "rhs_evaluations": 0, "segments": len(segments),
             "wall_time": time.perf_counter() - start}
    # the peaks between the events, located exactly by the chain's own search
    return build_result(model, segments, events, y, disc, method="exact-chain", tolerances={},
                        stats=stats, n_samples=n_samples, y_post=totals["y_post"],
                        peaks=chain.spans, interior=False)


def _transitions(model):
    """The model with its laws' transitions evaluated on Python floats (those of the exact
    two-vehicle backend, about 10x cheaper than NumPy on 0-d values), keeping the laws'
    rebound resolution: this backend works in absolute deformations, to the ulps of the
    positions, as the integrators do (:data:`lsc.contact.REBOUND_RESOLUTION`)."""
    from ..exact.single import _ScalarTransitions

    fast = _ScalarTransitions(model)
    for pp, law in zip(fast._pp, model.laws):
        pp["wres"] = float(law.params["wres"])
    return fast


class _Chain:
    """What stays fixed over the segments of one chain: masses, maps, scales."""

    def __init__(self, model):
        self.model = model
        p = model.params
        self.N, self.K = model.N, model.K
        self.m = np.asarray(p["m"], float)
        self.gap = np.asarray(p["gap"], float)
        self.C = deformation_map(self.N)
        self.incidence = -self.C.T
        self.t_scale = model.time_scale()
        self.length = model.v_scale * self.t_scale
        self.spans = []   # (t0, t1, peak force (K,), peak acceleration (N,)) of each segment

    def advance(self, t0, y0, disc, horizon) -> Step:
        """The segment from ``(t0, y0)`` in discrete state ``disc`` to its first event (or to
        ``horizon`` [s])."""
        y0 = np.asarray(y0, float)
        x0, v0 = y0[: self.N], y0[self.N: 2 * self.N]
        D0, W0 = self.C @ x0 - self.gap, self.C @ v0
        contacts = disc[: self.K]
        slope = np.array([float(st["s"]) for st in contacts])
        force = np.array([float(st["fa"]) + float(st["s"]) * (D0[k] - float(st["da"]))
                          for k, st in enumerate(contacts)])
        motion = Motion(self.m, x0, v0, slope, force, self.incidence)
        funcs = self._event_functions(motion, disc, D0, W0, x0, v0)
        tau, event = self._earliest(motion, funcs, horizon - t0)
        if event is None:
            tau = max(horizon - t0, 0.0) if tau is None else tau
        end = motion.state(tau)
        self.spans.append((t0, t0 + tau, *self._peaks(motion, slope, force, tau)))

        def dense(tt, motion=motion, t0=t0):
            return motion.state(np.asarray(tt, float) - t0)

        return Step(t0 + tau, end, event, dense, 1, 0)

    def _peaks(self, motion, slope, force, tau):
        """The largest force of each contact (K,) and the acceleration of largest magnitude of
        each vehicle (N,), signed, over ``[0, τ]``: at the ends or at an interior extremum
        (:func:`~._roots.extrema`), each a series in closed form."""
        rows = slope[:, None] * motion.P
        fa, fg = rows * motion.a, rows * motion.b
        inc, m = self.incidence, self.m[:, None]
        c = np.concatenate([force, (inc @ force) / self.m])
        alpha = np.concatenate([fa, (inc @ fa) / m])
        gamma = np.concatenate([fg, (inc @ fg) / m])
        series = [Series(float(c[j]), alpha[j], gamma[j], motion.modes) for j in range(c.size)]
        inner = extrema(series, tau)
        peaks = []
        for g, times in zip(series, inner):
            vals = g(np.array([0.0, tau, *times]))
            peaks.append(vals[np.argmax(np.abs(vals))] if len(peaks) >= self.K else np.max(vals))
        return np.array(peaks[: self.K]), np.array(peaks[self.K:])

    # ------------------------------------------------------------------ events
    def _event_functions(self, motion, disc, D0, W0, x0, v0):
        """``[(event index, Series, tolerance at the start)]`` for every armed event."""
        tol_d = START_TOL * self.length + 16 * _EPS * float(np.max(np.abs(x0)))
        tol_w = START_TOL * self.model.v_scale + 16 * _EPS * float(np.max(np.abs(v0)))
        out = []
        for i in self.model.active_events(disc):
            k, which = self.model.events[i]
            st = disc[k]
            if which == 0:     # the piece's lower end reached going down: (D - da) + wl
                g, tol = motion.deformation(k, (D0[k] - st["da"]) + st["wl"]), tol_d
            elif which == 1:   # its upper end reached going up: hi - D
                g, tol = motion.deformation(k, st["hi"] - D0[k], -1.0), tol_d
            else:              # closing rate through zero while loading
                g, tol = motion.closing_rate(k, W0[k]), tol_w
            out.append((i, g, tol))
        return out

    def _earliest(self, motion, funcs, limit):
        """``(τ, event index)`` of the first event within ``limit`` [s] (``(None, None)``:
        none; ``(τ, None)``: the search stopped at ``τ``, see :data:`MAX_SAMPLES`)."""
        modes = motion.modes
        omega = max(modes.fastest(), 1.0 / self.t_scale)
        pending = []
        for i, g, tol in funcs:
            s = _start(g, tol, omega, limit)
            if s == 0.0 and g.c <= 0:
                return 0.0, i   # (functions come in event order: the first wins a tie)
            if s is not None:
                pending.append((i, g, s))
        best, best_i = None, None
        # each function that leaves its surface, over the interval before the shared windows
        first = min(limit, 4 * math.pi / modes.slowest()) if modes.slowest() else limit
        for i, g, s in pending:
            if 0.0 < s < first:
                tau = first_crossing(g, s, first)
                if tau is not None and (best is None or tau < best):
                    best, best_i = tau, i
        # windows from one period of the fastest mode, doubling up to two of the slowest (an
        # event near the start, as on a stiff rebound line, costs few samples)
        lo = 0.0
        window = min(first, 2 * math.pi / modes.fastest()) if modes.fastest() else first
        budget = MAX_SAMPLES / (PER_RADIAN * omega)
        while pending and lo < limit and (best is None or lo < best):
            hi = min(lo + window, limit, best if best is not None else math.inf)
            window = min(2 * window, first)
            live = [(i, g) for i, g, s in pending if s <= lo or (lo > 0 and s < hi)]
            if live:
                tau, j = earliest([g for _, g in live], lo, hi)
                if tau is not None and (best is None or tau < best):
                    best, best_i = tau, live[j][0]
            lo = hi
            if lo >= budget and best is None:
                return lo, None
        return (best, best_i) if best_i is not None else (None, None)


def _start(g, tol: float, omega: float, limit: float) -> float | None:
    """Where to start searching ``g`` [s into the segment]: 0 normally (0 with ``g(0) <= 0``:
    it fires now), later where it starts on its surface and leaves it (see the module
    docstring), ``None`` where it stays on it: ``g`` lies in the span of ``1, S_j, C_j``
    (``2n + 1`` functions for ``n`` modes), which differentiation maps into itself, so where its
    first ``2n + 1`` derivatives vanish every one does (Cayley-Hamilton), and ``g`` is zero all
    along the segment."""
    order = 2 * g.alpha.size + 1
    if abs(g.c) > tol:
        return 0.0
    d = g.derivatives_at_zero(order)
    for p in range(1, order + 1):
        if abs(d[p]) > tol * omega ** p:
            break
    else:
        return None
    if d[p] < 0:
        return 0.0
    # g(τ) >= d_p τ^p / p! - B τ^(p+1) / (p+1)!, B >= |g^(p+1)|: positive up to (p+1) d_p / B
    lower = g
    for _ in range(p - 1):
        lower = lower.derivative()
    T = min(limit, 1.0 / omega) if math.isfinite(limit) else 1.0 / omega
    B = lower.curvature_bound(T)
    clear = (p + 1) * d[p] / B if B > 0 else T
    return min(0.5 * clear, T)
