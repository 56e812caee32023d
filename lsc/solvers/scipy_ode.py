"""SciPy backend: the hybrid ODE on SciPy's integrators (``scipy.integrate.RK45``, ``DOP853``,
``LSODA``, ...), stepped here with the armed events of each segment.

Each segment (frozen discrete state) is one run of a SciPy ``OdeSolver``, stepped by this module
as ``solve_ivp`` would step it, with the armed events of that state, all terminal and all
crossing zero downward. On every accepted step each armed event function is searched for its
earliest crossing *inside* the step (:class:`_StepWatch`, :mod:`.step_roots`: linear in the
state, it is a polynomial of the dense output's degree along the step, and all its roots are
found), not only a sign change between the step's ends: a contact that reloads past its max
deformation and comes back inside one step is seen. The crossing's time is located on the
step's dense output by Brent's method (to a few ulps in time), bracketed at the step's end by
the solver's own state rather than by the interpolant's: ``solve_ivp`` brackets with the interpolant, which for
LSODA can differ from the step's own state in the last bits, and then fails ("f(a) and f(b) must
have different signs") on an event that is within rounding of zero at a step end. Because every
event function is zero on its surface and only a *downward* crossing counts, a new segment that
starts on the surface it just crossed moves away from it and does not fire again (the restart
trap).

No step is longer than ``MAX_ANGLE / ω`` for the highest natural frequency ``ω`` of the frozen
contacts (:meth:`HybridModel.max_step`): over longer steps of an oscillation the embedded
error estimates stop being reliable (DOP853 accepted a one-radian step of a near-plastic rebound
with an error of 5e-6, and Radau's damping of a stiff unloading oscillation lost the rebound and
the separation), and no segment takes more than ``max_steps`` steps (a bounded loop: a problem too
stiff for an explicit integrator ends with a SimulationError instead of running for hours).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.integrate
from numpy.polynomial import chebyshev as cheb
from scipy.integrate import OdeSolution
from scipy.optimize import brentq

from ..contact import HysteresisLaw
from ..effects import BrakeEffect
from ..errors import SimulationError
from .. import locking
from ..locking import locking_model
from ..metrics import RESTART_SHIFT
from ..model import MAX_ANGLE  # noqa: F401  (the longest step, in radians; see _max_step)
from . import step_roots, stiffness
from .base import Backend
from ..effects import integrable_features
from .integrable import BUILTIN
from .segments import Step, build_result, run_segments

__all__ = ["BACKEND", "FEATURES", "solve", "INTEGRATORS", "RTOL"]

INTEGRATORS = ("RK45", "DOP853", "LSODA", "Radau", "BDF", "RK23")
#: The relative tolerance of a solve that names none.
RTOL = 1e-10


def _max_step(model, disc) -> float:
    """The longest step in discrete state ``disc`` [s] (:meth:`HybridModel.max_step`)."""
    return float(model.max_step(disc))


def _absolute(frame, sol):
    """A segment's dense output ``sol`` (in its ``frame``) as absolute states (n,) or (n, k)."""
    return lambda tt: frame.to_abs(tt, sol(tt))


def _other(integrator: str) -> str:
    """Integrators to suggest instead of ``integrator`` when it cannot finish a segment."""
    others = [i for i in ("LSODA", "Radau", "DOP853") if i != integrator][:2]
    return " or ".join(f"integrator {i!r}" for i in others)


#: Start-on-surface threshold, relative to each event's scale (as the diffrax backend's; the
#: metrics' tie rule allows for the delay it gives a simultaneous event).
EVENT_TOL = RESTART_SHIFT


def _event_scales(model) -> np.ndarray:
    """The scale of each event function that :func:`_restart` shifts
    (:meth:`HybridModel.event_scales`): the IF-D law's events (deformation bounds: a length;
    closing rate: the speed scale) and a brake's stop (a sliding vehicle's speed through zero);
    0 for the other events (no restart shift).

    (A held vehicle keeps a speed of a rounding error, -3e-17 m/s: when it broke away under a net
    force equal to its friction limit, with mu = mu_static, its stop fired at once, then its
    break-away, to the event limit. With a scale its stop starts a rounding error past its surface
    and is shifted like an IF-D event.)"""
    shifted = [isinstance(model.parts[j], HysteresisLaw)
               or (isinstance(model.parts[j], BrakeEffect) and w == 0) for j, w in model.events]
    return np.where(shifted, model.event_scales(), 0.0)


def _restart(model, disc, p, t0, y0, active, scale, fired):
    """The restart trap, both ways, at the start of a segment at ``t0``, the time at which the
    parts in ``fired`` had their events (empty at t = 0). Returns ``(shift, now)``: the event
    functions are ``g + shift``, and ``now`` is an event to fire at once (or None).

    - An armed event of a part that has not fired at this instant, on its surface or a rounding
      error past it (``g <= 0``) and going further in, fires at once (the lowest index first, as
      in the exact backend): SciPy sees a sign change only from ``>= 0`` to ``<= 0`` over a
      step, so one already past would never fire. After a simultaneous event, the second
      contact's closing rate a few ulps below zero (its common velocity was missed and its
      loading curve run backwards as if elastic), a braked vehicle's speed a few ulps past zero
      (it slid on with its friction pushing it backwards), or a deformation on a permanent set
      only ``e² D_max`` below the max deformation (a step past it pulls).
      So does one of a part that has just fired, if the new state put it past its surface by
      more than a rounding error (``EVENT_TOL * scale``).
    - An IF-D event (``scale > 0``) that starts on its surface or past it and does not go further
      in (one an event at this instant placed there, a rounding error either way, or a part
      moving back out) is shifted to start at ``+EVENT_TOL * scale``, so that it fires only once
      the motion comes back and goes that much further into it. Exactly on it, a contact that
      separated at its permanent set while a neighbour still pushes would close again at once,
      again and again (a plastic chain chattering to the event limit); a rounding error past it,
      the sign test never sees the crossing when the motion comes back: a contact separated a
      few 1e-18 ft below its permanent set, came back and was never closed again, its vehicles
      passing through each other until the next event put the contact on the extension of a
      near-vertical unloading line (e = 1e-6 in a chain: 2e12 lbf, energy out of nothing).
    """
    shift = np.zeros(len(model.events))
    if not active:
        return shift, None
    y0 = np.asarray(y0, float)
    g0 = np.asarray(model.event_values(t0, y0, disc, p), float)
    tol = EVENT_TOL * scale
    past = [i for i in active if g0[i] <= 0]
    if past:
        # the motion over a tiny time, to second order in the segment's frame: a deformation
        # at zero closing rate (a lock's release) moves by its acceleration, not by rounding
        h = 1e-6 * model.time_scale()
        frame = model.frame(t0, y0, p)
        u0, pf = frame.to_frame(t0, y0), frame.params(p)
        f0 = np.asarray(model.rhs(t0, u0, disc, pf), float)
        g0f = np.asarray(model.event_values(t0, u0, disc, pf), float)
        u1 = u0 + h * f0
        u1[:model.N] += 0.5 * h * h * f0[model.N:2 * model.N]
        g1 = np.asarray(model.event_values(t0 + h, u1, disc, pf), float)
        going = [i for i in past if g1[i] < g0f[i]
                 and (model.events[i][0] not in fired or g0[i] < -tol[i])]
        if going:
            return shift, min(going)
    for i in active:
        if scale[i] > 0 and g0[i] <= 0:
            shift[i] = tol[i] - g0[i]
    return shift, None


def _missed(gval, sol, active, best, tb, yb, tol):
    """An armed event that crossed zero and back inside one step is invisible to the sign test
    at step ends (e.g. a table breakpoint just below the max deformation, crossed on the way up
    and down within the step that holds the common velocity). Every armed event is checked at
    the end of the segment: one that is negative there crossed earlier, and its first crossing
    is located on the dense output (Brent) and taken if it comes first.

    Not one that is past its surface by less than ``tol`` (the global error, on each event's
    scale): a max deformation exactly at a breakpoint only touches it, and the interpolant, a
    tolerance's worth above the breakpoint over a stretch of time around the max, would report
    a crossing there (a breakpoint 1e-7 s before the max deformation). One that goes on past
    its surface fires at the start of the next segment (:func:`_restart`)."""
    g_end = gval(tb, yb)
    ts = sol.ts
    for i in active:
        if i == best or not g_end[i] < -tol[i]:
            continue

        def g(t, i=i):
            return gval(t, sol(t))[i]

        # the last step start where the event was still on its positive side
        k = int(np.searchsorted(ts, tb, side="left")) - 1
        while k > 0 and g(ts[k]) < 0:
            k -= 1
        a = float(ts[max(k, 0)])
        if a >= tb or not g(a) >= 0 or not g(tb) < 0:
            continue
        root = brentq(g, a, tb, xtol=1e-15, rtol=1e-15, maxiter=200)
        if root < tb:
            best, tb, yb = i, float(root), sol(root)
    return best, tb, yb


def _degree(dense) -> int:
    """The degree in time of a SciPy step's dense output (a polynomial on the step)."""
    for attr, axis in (("Q", 1), ("F", 0)):   # RK45, RK23, Radau: y_old + Q x^k; DOP853
        if hasattr(dense, attr):
            return int(np.shape(getattr(dense, attr))[axis])
    if hasattr(dense, "yh"):                 # LSODA: its Nordsieck array
        return int(np.shape(dense.yh)[1]) - 1
    return int(getattr(dense, "order", 12))  # BDF


class _StepWatch:
    """The armed events of one segment, watched on each accepted step's dense output: every
    crossing inside the step is found (:mod:`.step_roots`), not only a sign change between its
    ends. Each event is the minimum of its pieces (:meth:`HybridModel.event_pieces`); a piece
    linear in the state is a polynomial of the dense output's degree along the step and is
    fitted exactly; one that is not is interpolated at :data:`~.step_roots.NONLINEAR_POINTS`
    points, its values lowered by the interpolant's error bound."""

    def __init__(self, model, disc, pf, active, shift, touch):
        self.model, self.disc, self.pf = model, disc, pf
        self.pf_columns = dict(pf, gap=np.asarray(pf["gap"], float)[:, None])
        events = np.asarray(active, dtype=int)
        self.pieces = np.flatnonzero(np.isin(model.piece_event, events))
        self.owner = model.piece_event[self.pieces]          # the event of each watched piece
        self.linear = model.event_linear[self.owner]
        self.shift, self.depth = shift[self.owner], touch[self.owner]

    def values(self, t, u):
        """The watched pieces (n_pieces, ...) at frame state(s) ``u``."""
        if np.ndim(u) == 1:
            vals = self.model.event_pieces(t, u, self.disc, self.pf)
            return vals[self.pieces] + self.shift
        vals = self.model.event_pieces(t, u, self.disc, self.pf_columns)
        return vals[self.pieces] + self.shift[:, None]

    def _series(self, dense, t_old, h, n):
        """Chebyshev coefficients of the pieces on the step, from ``n + 1`` points."""
        tt = t_old + 0.5 * (step_roots.lobatto(n) + 1.0) * h
        return step_roots.fit(np.asarray(self.values(tt, dense(tt)), float))

    def crossings(self, dense, t_old, t_new, y_new):
        """``[(t, event)]``: each armed event's earliest crossing inside the step
        ``[t_old, t_new]`` (``y_new``: the solver's own state at its end)."""
        if not self.pieces.size:
            return []
        h = t_new - t_old
        at_end = np.asarray(self.values(t_new, y_new), float)
        coef = {True: self._series(dense, t_old, h, _degree(dense))}
        if not self.linear.all():
            coef[False] = self._series(dense, t_old, h, step_roots.NONLINEAR_POINTS - 1)
        first = {}
        # (a cheap bound first, for all at once: |T_k| <= 1, so a series is at least
        # c_0 - sum |c_k|; where that is positive and the step ends positive, no root)
        lin = coef[True]
        clear = (lin[:, 0] - np.sum(np.abs(lin[:, 1:]), axis=1) > 0) & (at_end > 0) & self.linear
        for j in np.flatnonzero(~clear):
            event = self.owner[j]
            c = coef[bool(self.linear[j])][j]
            slack = 0.0 if self.linear[j] else step_roots.tail_bound(c)
            floor = 64 * np.finfo(float).eps * np.max(np.abs(c))
            span = step_roots.first_crossing(c, max(self.depth[j], floor), at_end[j] <= 0,
                                             slack)
            if span is None:
                continue
            t = self._root(dense, t_old, t_new, j, c, span, at_end[j])
            if t < first.get(int(event), np.inf):
                first[int(event)] = t
        return [(t, i) for i, t in first.items()]

    def _root(self, dense, t_old, t_new, j, c, span, g_end):
        """The crossing of piece ``j`` in ``span`` (in the step's ``[-1, 1]``), located on the
        dense output (Brent), bracketed by its values there (at the step's end, the solver's
        own ``g_end``: Brent between the step's ends as before); on the series ``c`` itself
        where rounding leaves no bracket on the dense output."""
        h = t_new - t_old
        ta, tb = (t_old + 0.5 * (x + 1.0) * h for x in span)

        def g(t):
            return float(self.values(t, dense(t))[j])

        ga = g(ta) if span[0] > -1.0 else g(t_old)
        tb, gb = (t_new, g_end) if span[1] == 1.0 and g_end <= 0 else (tb, g(tb))
        if ga >= 0 >= gb:
            return _locate(g, ta, tb, ga, gb)

        def series(t):
            return float(cheb.chebval(2.0 * (t - t_old) / h - 1.0, c))
        return _locate(series, ta, tb, max(series(ta), 0.0), min(series(tb), 0.0))


def _locate(g, t_old, t_new, g_old, g_new):
    """The zero of ``g`` (an event function on a step's dense output) between the step ends
    ``t_old`` and ``t_new``, where it went from ``g_old >= 0`` to ``g_new <= 0`` (values on the
    solver's own states): Brent's method on ``g`` inside, bracketed by those end values."""
    if g_new == 0 or g_old == g_new:
        return t_new
    if g_old == 0:
        return t_old

    def h(t):
        if t <= t_old:
            return g_old
        if t >= t_new:
            return g_new
        return g(t)

    # to the ulps of the time itself: an event a few ulps of t after the step start is not at it
    # (SciPy's absolute xtol of 4 eps s returned the step start for a closing rate of 1e-11 that
    # a stiff contact stops in 1e-16 s: the state there still closing, a plastic contact
    # separated and closed again and again to the event limit)
    xtol = 2 * np.spacing(max(abs(t_old), abs(t_new)))
    return float(brentq(h, t_old, t_new, xtol=xtol, rtol=4 * np.finfo(float).eps,
                        maxiter=500))


#: One-step integrators whose interpolant is less accurate than their steps: an event located on
#: it is polished by re-taking the step to it (:func:`_polish`).
ONE_STEP = ("RK45", "RK23", "DOP853", "Radau")


def _polish(restep, g, slope, t_old, t_new, tr, yr, iters: int = 3):
    """An event at ``tr`` located on a step's interpolant (state ``yr`` there), moved onto the
    integrator's own solution: ``restep(t)`` re-takes the step from its start to ``t`` (None if
    the integrator would not take it in one step), and Newton's method on ``g`` (``slope``: its
    rate along the motion) moves ``t`` until ``g`` is zero on that solution. RK45's quartic
    interpolant, for one, is off by ~rtol from its own steps: a plastic contact separated at a
    common velocity that was still closing at that level, closed again and repeated it."""
    best = (abs(g(tr, yr)), tr, yr)
    t = tr
    # a correction, not a search: within 1e-6 of the step of the interpolant's root (where the
    # function only touches zero, a max deformation exactly at a breakpoint, Newton's steps on
    # its flat bottom would walk off to where the event has not happened)
    cap = 1e-6 * (t_new - t_old)
    lo, hi = max(tr - cap, t_old), min(tr + cap, t_new)
    for _ in range(iters):
        y = restep(t)
        if y is None:
            break
        gv = g(t, y)
        if abs(gv) < best[0] or (abs(gv) == best[0] and t == best[1]):
            best = (abs(gv), t, y)
        if gv == 0:
            break
        d = slope(t, y)
        if not d < 0:   # (events cross downward)
            break
        t_next = min(max(t - gv / d, lo), hi)
        if abs(t_next - t) <= 2 * np.spacing(t):
            break
        t = t_next
    return best[1], best[2]


#: What SciPy solves: every integrable feature, and locked pairs (:mod:`lsc.locking`); a live
#: set, so laws and effects registered later are in it.
FEATURES = integrable_features(BUILTIN | {locking.FEATURE})

#: The SciPy backend's declaration: any number of vehicles, every law and effect.
BACKEND = Backend(
    name="scipy", module=__name__,
    options=("rtol", "atol", "integrator", "t_end", "max_events", "n_samples", "first_step",
             "max_steps"),
    vehicles=(2, None), solves=FEATURES,
    summary="event-driven SciPy solve_ivp (DOP853 by default; Radau for a stiff damping law)")


def solve(model, *, integrator: str | None = None, rtol: float = RTOL, atol=None, t_end=None,
          max_events: int = 10_000, n_samples: int = 1000, first_step=None,
          max_steps: int = 20_000):
    """Solve ``model`` with a SciPy integrator (``integrator``: RK45, DOP853, LSODA, Radau, BDF,
    RK23; ``None``: DOP853, or Radau where a damping law's rebound is too stiff for it at this
    ``rtol``, :func:`.stiffness.integrator_for`); ``max_steps``: most steps in a segment."""
    if integrator is None:
        integrator = stiffness.integrator_for(model, rtol, atol)
    if integrator not in INTEGRATORS:
        from ..errors import SceneError
        raise SceneError("solver.integrator", f"unknown SciPy integrator {integrator!r}; "
                         f"accepted: {', '.join(INTEGRATORS)}")
    if rtol < 100 * np.finfo(float).eps:
        from ..errors import SceneError
        raise SceneError("solver.rtol", f"SciPy's integrators accept rtol >= 100 machine epsilons "
                         f"(2.2e-14), got {rtol:g}; for more digits use method 'exact' or "
                         "'closed-form' where they apply")
    # a chain's contacts pushed shut lock instead of chattering (lsc.locking)
    model = locking_model(model)
    p = model.params
    method = getattr(scipy.integrate, integrator)
    max_steps = int(max_steps)
    scale = _event_scales(model)
    # an event past its surface by less only touched it (100 rtol: the global error of a
    # deformation, here 2.7e-12 of D_max at rtol 1e-12)
    touch = max(EVENT_TOL, 100 * rtol) * scale
    last = [0.0, set()]  # the latest event time, and the parts that had events then

    N = model.N
    project = getattr(model, "project", lambda y, disc, p: y)

    def advance(t0, y0_abs, disc, horizon):
        y0_abs = project(np.asarray(y0_abs, float), disc, p)  # (locks: lsc.lock_law.project)
        active = model.active_events(disc)
        if t0 != last[0]:
            last[:] = [t0, set()]
        shift, now = _restart(model, disc, p, t0, y0_abs, active, scale, last[1])
        if now is not None:
            last[1].add(model.events[now][0])
            return Step(t0, y0_abs, now,
                        lambda tt: np.repeat(y0_abs[:, None], np.size(tt), axis=1))

        # The segment's frame (HybridModel.frame): positions from where the segment starts,
        # moving with its centre of mass; the model is evaluated on the frame's own state.
        frame = model.frame(t0, y0_abs)
        at = float(atol) if atol is not None else model.default_atol(rtol, disc)
        pf = frame.params(p)

        def fun(t, u):
            f = np.asarray(model.rhs(t, u, disc, pf), float)
            f[:N] = u[N:2 * N]   # (dx/dt = v: the frame's own velocities, unrounded)
            return f

        def gval(t, u):
            return model.event_values(t, u, disc, pf) + shift

        y0 = frame.to_frame(t0, y0_abs)

        extra_nfev = [0]   # right-hand sides evaluated polishing events

        def restepper(t_a, y_a):
            """Re-take a step from ``(t_a, y_a)`` to ``t`` (None if not in one step)."""
            def restep(t):
                if not t > t_a:
                    return y_a
                try:
                    one = method(fun, t_a, y_a, t, rtol=rtol, atol=at, first_step=t - t_a)
                    one.step()
                except ValueError:
                    return None
                extra_nfev[0] += one.nfev
                return one.y if one.status == "finished" and one.t == t else None
            return restep

        def slope(i, h):
            """The rate of event function ``i`` along the motion (a forward difference)."""
            def rate(t, y):
                return (gval(t + h, y + h * fun(t, y))[i] - gval(t, y)[i]) / h
            return rate

        # (first_step is only the trial size of the first step: never beyond the interval)
        extra = {"first_step": min(first_step, horizon - t0)} if first_step else {}
        y0 = np.asarray(y0, float)
        try:
            # (SciPy's first-step estimate overflows on a derivative near the float range, a
            # Hunt-Crossley pulse at e = 1e-200: its norm inf, its step 0, which SciPy raises to
            # its least step; the numbers it returns are checked as any step's)
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                solver = method(fun, t0, y0, horizon, rtol=rtol, atol=at,
                                max_step=_max_step(model, disc), **extra)
        except ValueError as exc:  # SciPy's own check of its options
            raise SimulationError(f"SciPy {integrator} could not start at t = {t0:.6g} s: "
                                  f"{exc}") from exc
        watch = _StepWatch(model, disc, pf, active, shift, touch)
        ts, interpolants = [t0], []
        best, tb, yb = None, t0, y0
        while solver.status == "running":
            if len(interpolants) >= max_steps:
                raise SimulationError(
                    f"SciPy {integrator}: {max_steps} steps in one segment by t = {solver.t:.6g} "
                    "s and no event: the motion is too stiff (or too long) for this integrator "
                    f"at this tolerance; try {_other(integrator)}, a larger rtol, or raise "
                    "solver.max_steps")
            # (a trial step that overflows, the force of a near-plastic Hunt-Crossley pulse at
            # a step too long, has an error norm inf or NaN: SciPy rejects it and shortens the
            # step; the steps it accepts are finite, as before)
            with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                message = solver.step()
            if solver.status == "failed":
                raise SimulationError(f"SciPy {integrator} failed at t = {solver.t:.6g} s: "
                                      f"{message}")
            t_old, t_new, y_new = float(solver.t_old), float(solver.t), solver.y
            dense = solver.dense_output()
            ts.append(t_new)
            interpolants.append(dense)
            tb, yb = t_new, y_new
            if not active:
                continue
            roots = watch.crossings(dense, t_old, t_new, y_new)
            if roots:
                # the earliest; on a tie (within 4 ulps) the lowest index
                first = min(r for r, _ in roots)
                best, tb = min((i, r) for r, i in roots if r <= first + 4 * np.spacing(first))
                yb = y_new if tb == t_new else dense(tb)
                if tb < t_new and integrator in ONE_STEP:
                    tb, yb = _polish(restepper(t_old, np.array(solver.y_old)),
                                     lambda t, y, i=best: gval(t, y)[i],
                                     slope(best, 1e-6 * (t_new - t_old)),
                                     t_old, t_new, tb, yb)
                tb = float(tb)
                break
        steps, nfev = len(interpolants), solver.nfev + extra_nfev[0]
        if not interpolants:   # nothing to integrate (t0 at the horizon)
            return Step(t0, y0_abs, None,
                        lambda tt: np.repeat(y0_abs[:, None], np.size(tt), axis=1))
        sol = OdeSolution(np.asarray(ts), interpolants,
                          alt_segment=integrator in ("BDF", "LSODA"))
        best, tb, yb = _missed(gval, sol, active, best, tb, yb, touch)
        if best is not None:
            if tb != last[0]:
                last[:] = [tb, set()]
            last[1].add(model.events[best][0])
        return Step(tb, frame.to_abs(tb, yb), best, _absolute(frame, sol), steps, nfev)

    start = time.perf_counter()
    segments, events, y, disc, totals = run_segments(model, advance, t_end=t_end,
                                                     max_events=max_events)
    wall = time.perf_counter() - start
    stats = {"steps": totals["steps"], "rhs_evaluations": totals["nfev"],
             "segments": len(segments), "wall_time": wall,
             **locking.lock_warnings(events)}   # (a lock left the plain IF-D law: say so)
    return build_result(model, segments, events, y, disc, method=f"scipy-{integrator}",
                        tolerances={"rtol": rtol, "atol": atol}, stats=stats,
                        n_samples=n_samples, y_post=totals["y_post"])
