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

from ...errors import SimulationError
from ..segments import Step, build_result, run_segments
from ...laws import MODE_UNLOADING
from ...locking import FEATURE as LOCK, lock_warnings, locking_model, pressed
from . import _lines, _locks
from ._brakes import Brakes
from ._locks import LockTransitions
from ._balance import check_balance
from ._carry import Carried, deformations, event_rows, frame
from ._modes import Motion, Shape, deformation_map
from ._peaks import segment_peaks
from ._roots import PER_RADIAN, Stack, earliest

__all__ = ["solve"]

#: Event functions within this fraction of their scale (length, speed) are on their surface.
START_TOL = 1e-13
#: Most samples of one event function in one segment before the search gives up (a
#: SimulationError that says so: a contact ringing on a near-plastic unloading line).
MAX_SAMPLES = 2_000_000
_EPS = float(np.finfo(float).eps)
#: The start tolerance of an event function that fires at once whatever its value (a rebound
#: line narrower than the start's resolution: :meth:`_Chain._event_functions`).
NOW = -math.inf


def solve(model, *, t_end=None, n_samples: int = 1000, max_events: int = 10_000):
    """Solve a chain ``model`` (IF-D contacts with straight or tabulated loading and a straight
    unloading line; braked vehicles that slide and stick, :mod:`._brakes`) exactly, segment by
    segment, as a :class:`~lsc.result.Result`.

    ``t_end`` [s]: simulate until then (must not cut the crash); ``n_samples``: points in the
    sampled series (every event is a sample); ``max_events``: limit on discrete events.
    """
    from . import BACKEND

    BACKEND.check(model)
    chain = _Chain(model)
    transitions = chain.parts = _transitions(model)
    start = time.perf_counter()
    segments, events, y, disc, totals = run_segments(Carried(transitions, chain), chain.advance,
                                                     t_end=t_end, max_events=max_events)
    notes = lock_warnings(events).get("warnings", []) + chain.warnings()
    stats = {"steps": totals["steps"], "rhs_evaluations": 0, "segments": len(segments),
             "wall_time": time.perf_counter() - start, **({"warnings": notes} if notes else {})}
    if isinstance(transitions, LockTransitions):   # (the locking model's forces at the
        model = transitions._locking                # events, the locked ones' included)
        rows = event_rows(chain, segments, model)
    else:
        rows = event_rows(chain, segments)
    # (a narrow rebound line's force, the line's own at the end it is at: ._lines; the peaks
    # between the events, located exactly by the chain's own search, all segments at once)
    rows = _lines.line_rows(chain.lines, rows, segments, model)
    result = build_result(model, segments, events, y, disc, method="exact-chain",
                          tolerances={}, stats=stats, n_samples=n_samples,
                          y_post=totals["y_post"], peaks=chain.spans(), interior=False, rows=rows)
    if len(chain.records) == len(segments):   # (the series from the deformations carried)
        result.sampler = _lines.Sampler(model, segments, y, n_samples, chain)
    return check_balance(result, model.brakes)


def _transitions(model):
    """The model with its laws' transitions evaluated on Python floats (those of the exact
    two-vehicle backend, about 10x cheaper than NumPy on 0-d values), keeping the laws'
    rebound resolution: this backend works in absolute deformations, to the ulps of the
    positions, as the integrators do (:data:`lsc.contact.REBOUND_RESOLUTION`)."""
    from ..exact.single import _ScalarTransitions

    # (built once per model, kept on it as its other numbers are: it holds no state of a solve)
    fast = model.__dict__.get("_chain_transitions")
    if fast is None:
        fast = model.__dict__["_chain_transitions"] = _ScalarTransitions(model)
        for pp, law in zip(fast._pp, model.laws):
            pp["wres"] = float(law.params["wres"])
    # (a chain whose pairs may lock: lsc.locking's rule, as SciPy's, on these transitions;
    # the model's features, kept on it, name it: lsc.locking.lock_features)
    return LockTransitions(fast, locking_model(model)) if LOCK in model.features() else fast


class _Chain:
    """What stays fixed over the segments of one chain: masses, maps, scales."""

    def __init__(self, model):
        self.model = model
        p = model.params
        self.N, self.K = model.N, model.K
        self.m = np.asarray(p["m"], float)
        self.gaps = np.asarray(p["gap"], float).tolist()
        self.incidence = -deformation_map(self.N).T
        # (a Python float, the same number, kept on the model: the scalar arithmetic of every
        # segment's search is several times cheaper on floats than on NumPy's scalars)
        self.t_scale = model.__dict__.get("_chain_time_scale")
        if self.t_scale is None:
            self.t_scale = model.__dict__["_chain_time_scale"] = float(model.time_scale())
        self.length = model.v_scale * self.t_scale
        self.records = []   # (t0, motion, force at the start, length, loading contacts)
        self.shapes = {}  # the modes of each set of active slopes (:class:`~._modes.Shape`)
        self.ends = []    # the state at the start and at the end of each segment
        self.parts = model   # whose events the segments search (a LockTransitions: with locks)
        self.brakes = Brakes(model) if model.brakes else None   # (._brakes)
        self.bounce = ()   # (the contacts that bounce on a narrow line this segment)
        # (each segment's narrow lines, {contact: (force at its start, at its end)}; where each
        # is at the last segment's end, 0 foot 1 top; that segment's discrete state; a
        # narrow line's contact where its place is not known: the first time)
        self.lines, self.places, self.before, self.unknown, self.t0 = [], {}, None, {}, 0.0
        # (the deformations at both ends of each segment, each start's the last end's, carried
        # from segment to segment in the modes, not re-derived from the positions: their
        # rounding, an ulp of how far the chain has gone, times a stiff contact's slope, was a
        # wrong impulse; the last end's state and deformations, what the transitions read)
        self.deformations, self.carried = [], None

    def carried_at(self, y) -> list | None:
        """The deformations (K,) [length] carried to the last segment's end where ``y`` is that
        end's state, as the segment loop passes it on (``None`` otherwise: none carried)."""
        carried = self.carried
        return carried[1] if carried is not None and carried[0] is y else None

    def advance(self, t0, y0, disc, horizon) -> Step:
        """The segment from ``(t0, y0)`` in discrete state ``disc`` to its first event (or to
        ``horizon`` [s])."""
        y0, self.t0 = np.asarray(y0, float), t0
        carried = self.carried_at(y0)
        lock = _locks.locked(self.parts, disc)
        if lock:   # (a cluster moves as one body: lsc.locking, ._locks)
            y0 = _locks.project(self, y0, lock)
        held, push = self.brakes.state(disc) if self.brakes else ((), None)
        if held:   # (a stuck vehicle is held, at rest: ._brakes)
            y0 = y0.copy()
            y0[[self.N + i for i in held]] = 0.0
        x0, v0 = y0[: self.N], y0[self.N: 2 * self.N]
        # (the deformations, carried from the last segment where it ended this one (._carry),
        # and the closing rates, as Python floats: D = C x - gap and W = C v with C's rows
        # x_k - x_(k+1), the same arithmetic as on NumPy's values, several times cheaper)
        x, v = x0.tolist(), v0.tolist()
        D0 = carried if carried is not None else [a - b - g for a, b, g in
                                                  zip(x, x[1:], self.gaps)]
        W0 = [a - b for a, b in zip(v, v[1:])]
        contacts = disc[: self.K]
        key = tuple(float(st["s"]) for st in contacts)
        tol_d = self._tol_d(x0)
        self.bounce = self._bounces(contacts, D0, W0, disc, x0, v0, tol_d)
        # (a narrow line's contact at its top or foot: the line's force there, and its
        # deformation relative to the line from there, not from the positions' rounding)
        lines = _lines.places(self, contacts, tol_d)
        lines.update((k, 0) for k in self.bounce)   # (a bounce starts from the foot)
        force = np.array([_lines.force(st, lines[k]) if k in lines
                          else float(st["fa"]) + s * (D0[k] - float(st["da"]))
                          for k, (s, st) in enumerate(zip(key, contacts))])
        if lock:
            motion = _locks.motion(self, x0, v0, np.array(key), force, lock)
        else:
            which = (key, held) if held else key
            shape = self.shapes.get(which)
            if shape is None:
                shape = self.shapes[which] = Shape(self.m, np.array(key), self.incidence, held)
            motion = Motion(self.m, x0, v0, None, force, self.incidence, shape, push)
        funcs = self._event_functions(motion, disc, D0, W0, x0, v0, force, key, lines, tol_d)
        tau, event = self._earliest(motion, funcs, horizon - t0)
        if lock and event is not None:   # (a law event at the same instant goes first)
            event = _locks.first_of_ties(self, funcs, tau, event)
        if event is None and tau is None and (horizon - t0) * PER_RADIAN * \
                motion.modes.fastest() > MAX_SAMPLES and funcs:
            tau = MAX_SAMPLES / (PER_RADIAN * motion.modes.fastest())   # (no event found)
        if event is None and tau is not None:
            raise SimulationError(
                f"exact-chain: {MAX_SAMPLES} samples in one segment by t = {t0 + tau:.6g} s and "
                f"no event: a contact rings at {motion.modes.fastest():.3g} rad/s for longer "
                "than one segment can follow (a near-plastic contact, its unloading line up to "
                "1/e² times stiffer than its loading, held shut by a neighbour: it chatters); "
                "check the scene for contacts that chatter")
        if event is None:
            tau = max(horizon - t0, 0.0)
        end = motion.state(tau)
        D1 = deformations(motion, tau, D0, W0)
        stopped = None
        if event is not None and self.brakes:
            j, w = self.parts.events[event]
            if w == 0 and j in self.brakes.parts:   # a stop: at rest, exactly
                stopped = self.N + self.brakes.vehicle(j)
                end[stopped] = 0.0
        self.records.append((t0, motion, force, tau,
                             self._unsearched(motion, funcs, disc, force.tolist(), key, lock)))
        self.ends.append((y0, end))
        self.deformations.append((D0, D1))
        self.carried = (end, D1)
        _lines.leave(self, lines, event, tau, disc)

        def dense(tt, motion=motion, t0=t0, t1=t0 + tau, stopped=stopped):
            out = motion.state(np.asarray(tt, float) - t0)
            if stopped is not None:   # (at rest from the stop on, as the state is)
                out[stopped] = np.where(np.asarray(tt) >= t1, 0.0, out[stopped])
            return out

        return Step(t0 + tau, end, event, dense, 1, 0)

    def spans(self) -> list:
        """``(t0, t1, peak force (K,), peak acceleration (N,))`` of each segment: the largest
        force of each contact and the acceleration of largest magnitude of each vehicle,
        signed, at the segment's ends or at an interior extremum, every segment searched at
        once after the loop (:func:`~._peaks.segment_peaks`)."""
        peaks = segment_peaks([rec[1:] for rec in self.records], self.K)
        return [(t0, t0 + tau, *pk) for (t0, _, _, tau, _), pk in zip(self.records, peaks)]

    def _unsearched(self, motion, funcs, disc, force, slopes, lock) -> set:
        """The contacts whose force over the segment has its extremes at the segment's ends,
        for itself and for the accelerations that follow it, which the event search proves
        (their forces are not searched, :func:`~._peaks.segment_peaks`): one whose closing rate
        is an armed event keeps closing all along (its force is monotone). One that starts the
        segment at the upper end of its piece (``hi - D = 0``: at the top of its unloading
        line, just past its largest deformation), both ends armed, stays between them until
        the segment ends: its force (slope ``>= 0``) is at most its start value ``F(0)`` and
        at least its lower end's, itself at least ``-F(0)``, so ``|F|`` too is largest at the
        start; it is left unsearched where no acceleration needs its extremes beside: each of
        its two vehicles is searched on its own (between two contacts with a slope) or is
        pushed by it alone (its other contact open, no force: ``|a| = |F|/m``). (A lock's
        closing-rate watch is not a law's: only the laws' contacts, ``k < K``; with locks held
        a contact's force is not its law's alone, and a braked vehicle's acceleration has the
        friction beside the force: the closing rate's rule only.)"""
        armed = {self.parts.events[i]: g for i, g, _ in funcs}
        out = {k for k, which in armed if which == 2 and k < self.K}
        tops = [k for (k, which), g in armed.items() if which == 1 and g.c == 0.0 and k < self.K]
        if not tops or lock or self.brakes:
            return out
        own = motion.shape.searched.tolist()
        for k in tops:
            if (k, 0) not in armed or not slopes[k] >= 0.0 or not force[k] >= 0.0 \
                    or not disc[k]["fa"] - slopes[k] * disc[k]["wl"] >= -force[k]:
                continue
            if all(self.K + i in own or all(slopes[j] == 0.0 and force[j] == 0.0
                                            for j in (i - 1, i) if j != k and 0 <= j < self.K)
                   for i in (k, k + 1)):
                out.add(k)
        return out

    # ------------------------------------------------------------------ events
    def _event_functions(self, motion, disc, D0, W0, x0, v0, force, slopes, lines, tol_d):
        """``[(event index, Series, tolerance at the start)]`` for every armed event (``lines``:
        the narrow lines' contacts at their top, 1, or foot, 0: ``D - da`` is 0 or ``-wl``;
        ``tol_d``: :meth:`_tol_d` at the start)."""
        # (a rate's rounding includes the deformation's, tol_d, through the stiffest mode
        # that an inexact force drives (._lines.rate_omega); a narrow line's own rate: all)
        fastest, tol_v = max(motion.modes.fastest(), 1.0 / self.t_scale), self._tol_v(v0)
        stiff = tol_v + fastest * tol_d
        tol_w = tol_v + _lines.rate_omega(
            self.m, slopes, disc[: self.K], D0, tol_d, fastest, 1.0 / self.t_scale) * tol_d
        out, leaves = [], {}   # (leaves: each narrow line's way out, judged once)
        for i in self.parts.active_events(disc):
            k, which = self.parts.events[i]
            st = disc[k]
            if self.brakes and k in self.brakes.parts:   # a brake's: stop, break-away
                out.append((i, *self.brakes.event_function(self, motion, disc, k, which,
                                                           np.array(slopes), force, tol_w,
                                                           START_TOL)))
                continue
            if k >= self.K:    # a lock's (._locks): its force's releases, a watched turn
                out.append((i, *_locks.event_function(self, motion, disc, k - self.K, which,
                                                      force, W0, tol_w)))
                continue
            if k in self.bounce:   # (its foot reached again: the bounce's end; not its top)
                if which == 0:
                    out.append((i, motion.deformation(k, 0.0), 0.0))
                continue
            if which == 2:     # closing rate through zero while loading
                out.append((i, motion.closing_rate(k, W0[k]), tol_w))
                continue
            if which == 0:     # the piece's lower end reached going down: (D - da) + wl
                g = motion.deformation(k, (D0[k] - st["da"] if k not in lines else
                                           0.0 if lines[k] else -st["wl"]) + st["wl"])
            else:              # its upper end reached going up: hi - D
                g = motion.deformation(k, st["hi"] - D0[k] if k not in lines else
                                       st["hi"] - st["da"] + (0.0 if lines[k] else st["wl"]),
                                       -1.0)
            if k not in leaves:
                leaves[k] = self._leaves_narrow_line(k, st, D0, W0, disc, x0, v0, tol_d,
                                                     stiff)
            tol = NOW if leaves[k] == which else tol_d
            out.append((i, g, tol))
        return out

    def _tol_d(self, x0) -> float:
        """The rounding [length] of a deformation at the start (positions ``x0``)."""
        return START_TOL * self.length + 16 * _EPS * max(map(abs, x0.tolist()))

    def _tol_v(self, v0) -> float:
        """The rounding [velocity] of a closing rate at the start (speeds ``v0``) alone."""
        return START_TOL * self.model.v_scale + 16 * _EPS * max(map(abs, v0.tolist()))

    def _bounces(self, contacts, D0, W0, disc, x0, v0, tol_d) -> tuple:
        """The contacts that close onto a narrow unloading line slower than it can stop them
        (:meth:`_leaves_narrow_line` 2): each bounces on it, elastically, from its foot
        (``tol_d``: :meth:`_tol_d` at the start)."""
        closing = [k for k, st in enumerate(contacts)
                   if st["mode"] == MODE_UNLOADING and W0[k] > 0]
        if not closing:
            return ()
        return tuple(k for k in closing if self._leaves_narrow_line(
            k, contacts[k], D0, W0, disc, x0, v0, tol_d, math.inf) == 2)

    def _leaves_narrow_line(self, k, st, D0, W0, disc, x0, v0, tol_d, tol_w):
        """Which end (0 lower, 1 upper) contact ``k`` leaves its unloading line by at once,
        where the line is narrower than the start's resolution ``tol_d`` [length] and the pair
        is not clearly closing nor opening (``|Ḋ| <= tol_w`` [velocity]); ``None`` otherwise;
        2 where it bounces on it (:meth:`_bounces`).

        Such a line (a near-plastic rebound ``e² D_max`` wide) has both ends on their surfaces
        and every derivative of its event functions within the rounding its stiffness gives
        them: it cannot be followed. The pair leaves it the way its neighbours push it: over
        its top (reloading past ``D_max``) where they press it together (the force it would
        carry held rigid, by the lock rule's own measure, :func:`lsc.locking.pressed`:
        positive, or zero and rising, a pusher that touches now) or where it closes faster
        than the line can stop it (``μ Ḋ² > s wl²``, ``μ`` the two sides' reduced mass with
        the clusters locked to them: its closing energy above the line's elastic energy);
        closing slower, it bounces on the line (2: the line followed as a spring from its foot,
        where its force is zero, back to its foot in about ``π/ω``, the closing speed
        returned); else apart (it separates, as the law's instant rule does below
        :data:`~lsc.contact.REBOUND_RESOLUTION`; the rebound's ringing is dropped)."""
        if st["mode"] != MODE_UNLOADING or st["hi"] - st["lo"] > tol_d or abs(W0[k]) > tol_w:
            return None
        model = getattr(self.parts, "_locking", self.model)   # (with the locks held)
        locked = _locks.locked(self.parts, disc)
        mask = [j == k or j in locked for j in range(self.K)]
        y, p = frame(np.concatenate([x0, v0]), model.params, D0)   # (D0's forces: frame)
        _, press = pressed(model, y, disc, p, mask)
        if press[k]:
            return 1
        # (closing faster than the line can stop: its kinetic energy of closing, the two sides
        # with the clusters locked to them, above the line's elastic energy s wl² / 2)
        rear, front = k, k + 1
        while rear > 0 and rear - 1 in locked:
            rear -= 1
        while front < self.K and front in locked:
            front += 1
        m_rear, m_front = self.m[rear: k + 1].sum(), self.m[k + 1: front + 1].sum()
        kinetic = m_rear * m_front / (m_rear + m_front) * W0[k] * abs(W0[k])
        closing = W0[k] > self._tol_v(v0)
        if kinetic > float(st["s"]) * float(st["wl"]) ** 2:
            return 1
        return 2 if closing else 0   # (a bounce where it closes beyond the speeds' rounding)

    def warnings(self) -> list[str]:
        """One warning per contact on a rebound line narrower than the start resolves at a
        point of it that the solve does not know (:func:`._lines.places`)."""
        return [f"contact {k} was at t = {t:.6g} s on its rebound line, narrower than a "
                "segment's start resolves, at a point of it the solve does not know (not its top "
                "nor its foot): the forces and accelerations recorded there are its rounding (its "
                "slope times its deformation's rounding)" for k, t in sorted(self.unknown.items())]

    def _earliest(self, motion, funcs, limit):
        """``(τ, event index)`` of the first event within ``limit`` [s] (``(None, None)``:
        none; ``(τ, None)``: the search stopped at ``τ``, see :data:`MAX_SAMPLES`)."""
        modes = motion.modes
        omega = max(modes.fastest(), 1.0 / self.t_scale)
        pending = []
        for i, g, tol in funcs:
            if tol is NOW:
                return 0.0, i
            s = _start(g, tol, omega, limit)
            if s == 0.0 and g.c <= 0:
                return 0.0, i   # (functions come in event order: the first wins a tie)
            if s is not None:
                pending.append((i, g, s))
        best, best_i = None, None
        # windows from one period of the fastest mode, doubling up to two of the slowest (an
        # event near the start, as on a stiff rebound line, costs few samples); a function that
        # leaves its surface is searched from where it provably has
        first = min(limit, 4 * math.pi / modes.slowest()) if modes.slowest() else limit
        lo = 0.0
        window = min(first, 2 * math.pi / modes.fastest()) if modes.fastest() else first
        budget = MAX_SAMPLES / (PER_RADIAN * omega)
        stack = Stack.of([g for _, g, _ in pending]) if pending else None
        while pending and lo < limit and (best is None or lo < best):
            hi = min(lo + window, limit, best if best is not None else math.inf)
            window = min(2 * window, first)
            live = [j for j, (_, _, s) in enumerate(pending) if s < hi]
            if live:
                tau, j = earliest(stack if len(live) == len(pending) else stack.take(live),
                                  lo, hi, [max(pending[j][2], lo) for j in live])
                if tau is not None and (best is None or tau < best):
                    best, best_i = tau, pending[live[j]][0]
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
    along the segment.

    ``g^(p)(0)`` is rounding where it is within :func:`start_rounding` of zero: ``tol`` [g's unit]
    the rounding of ``g(0)``, ``omega`` [1/s] the rate that turns it into that of ``g'`` and
    ``g''`` (the state's velocities and forces)."""
    if abs(g.c) > tol:
        return 0.0
    order = 2 * g.alpha.size + 1
    terms = g.each_at_zero(abs(g.c))
    next(terms)   # (g(0), within tol of zero)
    coef = g._modal()   # (kind, ω, α, γ, κ) of each mode, on floats
    _, w, alpha, gamma, _ = zip(*coef) if coef else ((),) * 5
    fastest = fastest_entering(alpha, gamma, w)
    low = []   # (the derivatives below the first clear one: rounding)
    for p in range(1, order + 1):
        dp, size = next(terms)   # (each computed only where the ones below it are not clear)
        if abs(dp) > start_rounding(tol, omega, fastest, p, size):
            break
        low.append(dp)
    else:
        return None
    if dp < 0:
        return 0.0
    # g(τ) >= d_p τ^p / p! - B τ^(p+1) / (p+1)!, B >= |g^(p+1)| (:func:`taylor_lower`):
    # positive up to (p+1) d_p / B
    lower = g
    for _ in range(p - 1):
        lower = lower.derivative()
    T = taylor_span(limit, fastest, omega)
    B = lower.curvature_bound(T)
    clear = (p + 1) * dp / B if B > 0 else T
    # the search starts where that clears what the computed g has beside it (else its sign
    # there would be theirs: a false crossing where g, proved positive, is below its rounding)
    for tau in (min(0.5 * clear, T), min(p / (p + 1) * clear, T)):
        S, C = g.modes.basis_at(tau)
        size = sum(abs(a * s) + abs(c * x) for s, x, (_, _, a, c, _) in zip(S, C, coef))
        if taylor_lower(dp, B, p, tau) > start_noise(g.c, low, tau, size):
            return tau
    return min(clear, T)


def taylor_lower(dp, B, p: int, tau):
    """A lower bound at ``tau`` [s] on a function whose first ``p - 1`` derivatives at 0 vanish,
    its ``p``-th is ``dp`` and ``B`` bounds its ``(p+1)``-th: ``dp τ^p/p! - B τ^(p+1)/(p+1)!``.
    Floats, or arrays (the batch's)."""
    return dp * tau ** p / math.factorial(p) - B * tau ** (p + 1) / math.factorial(p + 1)


def start_noise(c, low, tau, size):
    """How far rounding can put a function's computed value at ``tau`` [s] from
    :func:`taylor_lower`'s: its value and first derivatives at 0, ``c`` and ``low`` (rounding),
    carried to ``tau``, and a few ulps of the sum's terms (``size``, their magnitudes summed)."""
    carried = sum((abs(d) * tau ** q / math.factorial(q) for q, d in enumerate(low, 1)), abs(c))
    return carried + 16 * _EPS * (size + abs(c))


def fastest_entering(alpha, gamma, w):
    """The fastest mode [1/s] that enters ``g`` (coefficients ``alpha, gamma`` (..., n) on modes
    of angular frequency ``w`` (..., n), 0 where none does): a mode of a part of the chain that
    no contact of non-zero slope joins to ``g``'s is exactly absent from it, its rounding too.
    Arrays for the batch's :func:`._batch_roots.start_times` (one value per function); tuples
    of floats (one function, as :func:`_start` has them) give a float, the same number."""
    if isinstance(w, tuple):
        return max((x for a, c, x in zip(alpha, gamma, w) if a != 0 or c != 0), default=0.0)
    used = (alpha != 0) | (gamma != 0)
    return np.max(np.where(used, w, 0.0), axis=-1, initial=0.0)


def taylor_span(limit, fastest, omega):
    """The interval [s] over which :func:`_start` bounds a function leaving its surface: a
    radian of its own ``fastest`` mode (``omega`` where none enters it), at most ``limit``: past
    a stiff pair's period, beyond which a slow function leaving its surface as a high power of
    time would still be below its rounding. Floats, or arrays (the batch's)."""
    if isinstance(fastest, float):
        return min(limit, 1.0 / (fastest or omega))
    return np.minimum(limit, 1.0 / np.where(fastest > 0, fastest, omega))


def start_rounding(tol, omega, fastest, p: int, size):
    """How far from zero rounding can put ``g^(p)(0)`` (``p >= 1``): the start state's rounding,
    ``tol omega^p`` up to ``p = 2`` (position, velocity, force), each further order one more
    factor of the ``fastest`` mode [1/s] that enters ``g`` (``g^(p+2) = -A g^(p)`` in the modes,
    ``|A|`` its largest ``κ``, the modal coefficients' rounding that of the eigensolve of ``A``:
    not the model's stiffest contact, nor a stiff pair elsewhere in the chain that no closed
    contact joins to ``g``'s, which a far contact of a long chain pushed shut through soft ones,
    its deformation ``~ τ^(2j+1)``, would hide behind), and that of the sum itself, a few ulps of
    its terms' ``size``. Floats, or arrays (the batch's :func:`._batch_roots.start_times`)."""
    state = tol * omega ** min(p, 2) * fastest ** max(p - 2, 0)
    floor = 64 * _EPS * size
    return max(state, floor) if isinstance(state, float) else np.maximum(state, floor)
