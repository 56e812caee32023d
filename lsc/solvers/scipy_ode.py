"""SciPy backend: the hybrid ODE on ``scipy.integrate.solve_ivp`` with terminal events.

Each segment (frozen discrete state) is one ``solve_ivp`` call with the armed events of that
state, all terminal and all crossing zero downward; SciPy locates the earliest on its dense output
(Brent's method to a few ulps in time). Because every event function is zero on its surface and
only a *downward* crossing counts, a new segment that starts on the surface it just crossed moves
away from it and does not fire again (the restart trap).

No step is longer than ``MAX_ANGLE / ω`` for the highest natural frequency ``ω`` of the frozen
contacts (:meth:`HybridModel.natural_frequency`): over longer steps of an oscillation the embedded
error estimates stop being reliable (DOP853 accepted a one-radian step of a near-plastic rebound
with an error of 5e-6, and Radau's damping of a stiff unloading oscillation lost the rebound and
the separation), and no segment takes more than ``max_steps`` steps (a bounded loop: a problem too
stiff for an explicit integrator ends with a SimulationError instead of running for hours).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.integrate
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from ..contact import HysteresisLaw
from ..errors import SimulationError
from .segments import Step, build_result, run_segments

__all__ = ["solve", "INTEGRATORS"]

INTEGRATORS = ("RK45", "DOP853", "LSODA", "Radau", "BDF", "RK23")

#: Longest step, in radians of the fastest natural oscillation of the frozen contacts.
MAX_ANGLE = 0.5


class _StepLimit(Exception):
    """Raised inside ``solve_ivp`` when a segment has taken ``max_steps`` steps."""


def _counted(integrator: str, max_steps: int):
    """The SciPy solver class of ``integrator``, stopping with :class:`_StepLimit` at its
    ``max_steps``-th step."""
    base = getattr(scipy.integrate, integrator)

    class Counted(base):
        def step(self):
            self.lsc_steps = getattr(self, "lsc_steps", 0) + 1
            if self.lsc_steps > max_steps:
                raise _StepLimit(self.t)
            return super().step()

    Counted.__name__ = integrator
    return Counted


def _atol(model, rtol: float, atol):
    """Absolute tolerances (2N,): given, or ``rtol`` times the speed scale (and times the
    contact time scale for positions)."""
    if atol is not None:
        return float(atol)
    v = rtol * model.v_scale
    T = model.time_scale()
    m = np.asarray(model.params["m"], float)
    e = v * model.v_scale * float(np.min(m))  # work integrals: an energy scale
    return np.concatenate([np.full(model.N, v * T), np.full(model.N, v),
                           np.full(len(model.work), e)])


#: Start-on-surface threshold, relative to each event's scale (as the diffrax backend's).
EVENT_TOL = 1e-12


def _event_scales(model) -> np.ndarray:
    """The scale of each event function of the IF-D law: a length (``v_scale`` times the contact
    time scale) for its deformation bounds, ``v_scale`` for its closing rate; 0 for the events of
    other parts (no restart shift: :func:`_restart`)."""
    L, V = model.v_scale * model.time_scale(), model.v_scale
    out = np.zeros(len(model.events))
    for i, (j, w) in enumerate(model.events):
        part = model.parts[j]
        if isinstance(part, HysteresisLaw):
            out[i] = V if part.event_kinds[w] == "vmax" else L
    return out


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
    - An IF-D event (``scale > 0``) that starts exactly *on* its surface (``g == 0``: one an event
      at this instant placed there) is shifted up by ``EVENT_TOL * scale``, so that it fires only
      once the motion goes that much further into it (a contact that separated at its permanent
      set while a neighbour still pushes would otherwise close again at once, again and again: a
      plastic chain chattering to the event limit).
    """
    shift = np.zeros(len(model.events))
    if not active:
        return shift, None
    y0 = np.asarray(y0, float)
    g0 = np.asarray(model.event_values(t0, y0, disc, p), float)
    past = [i for i in active if g0[i] <= 0 and model.events[i][0] not in fired]
    if past:
        # the rate of each event function along the motion, over a tiny time
        h = 1e-6 * model.time_scale()
        f0 = np.asarray(model.rhs(t0, y0, disc, p), float)
        g1 = np.asarray(model.event_values(t0 + h, y0 + h * f0, disc, p), float)
        going = [i for i in past if g1[i] < g0[i]]
        if going:
            return shift, min(going)
    for i in active:
        if scale[i] > 0 and g0[i] == 0:
            shift[i] = EVENT_TOL * scale[i]
    return shift, None


def _missed(gval, sol, active, best, tb, yb):
    """An armed event that crossed zero and back inside one step is invisible to SciPy's sign
    test at step ends (e.g. a table breakpoint just below the max deformation, crossed on the
    way up and down within the step that holds the common velocity). Every armed event is
    checked at the end of the segment: one that is negative there crossed earlier, and its first
    crossing is located on the dense output (Brent) and taken if it comes first."""
    g_end = gval(tb, yb)
    ts = sol.t
    for i in active:
        if i == best or not g_end[i] < 0:
            continue

        def g(t, i=i):
            return gval(t, sol.sol(t))[i]

        # the last step start where the event was still on its positive side
        k = int(np.searchsorted(ts, tb, side="left")) - 1
        while k > 0 and g(ts[k]) < 0:
            k -= 1
        a = float(ts[max(k, 0)])
        if a >= tb or not g(a) >= 0 or not g(tb) < 0:
            continue
        root = brentq(g, a, tb, xtol=1e-15, rtol=1e-15, maxiter=200)
        if root < tb:
            best, tb, yb = i, float(root), sol.sol(root)
    return best, tb, yb


def solve(model, *, integrator: str = "DOP853", rtol: float = 1e-10, atol=None, t_end=None,
          max_events: int = 10_000, n_samples: int = 1000, first_step=None,
          max_steps: int = 20_000):
    """Solve ``model`` with ``solve_ivp`` (``integrator``: RK45, DOP853, LSODA, Radau, BDF, RK23);
    ``max_steps``: most steps in one segment (then a SimulationError)."""
    if integrator not in INTEGRATORS:
        from ..errors import SceneError
        raise SceneError("solver.integrator", f"unknown SciPy integrator {integrator!r}; "
                         f"accepted: {', '.join(INTEGRATORS)}")
    if rtol < 100 * np.finfo(float).eps:
        from ..errors import SceneError
        raise SceneError("solver.rtol", f"SciPy's integrators accept rtol >= 100 machine epsilons "
                         f"(2.2e-14), got {rtol:g}; for more digits use method 'exact' or "
                         "'closed-form' where they apply")
    p = model.params
    at = _atol(model, rtol, atol)
    method = _counted(integrator, int(max_steps))
    scale = _event_scales(model)
    last = [0.0, set()]  # the latest event time, and the parts that had events then

    def advance(t0, y0, disc, horizon):
        def fun(t, y):
            return model.rhs(t, y, disc, p)

        active = model.active_events(disc)
        if t0 != last[0]:
            last[:] = [t0, set()]
        shift, now = _restart(model, disc, p, t0, y0, active, scale, last[1])
        if now is not None:
            last[1].add(model.events[now][0])
            y0 = np.asarray(y0, float)
            return Step(t0, y0, now, lambda tt: np.repeat(y0[:, None], np.size(tt), axis=1))

        def gval(t, y):
            return model.event_values(t, y, disc, p) + shift

        evs = []
        for i in active:
            def ev(t, y, i=i):
                return gval(t, y)[i]
            ev.terminal = True
            ev.direction = -1
            evs.append(ev)
        w = model.natural_frequency(disc)
        # (first_step is only the trial size of the first step: never beyond the interval)
        extra = {"first_step": min(first_step, horizon - t0)} if first_step else {}
        try:
            sol = solve_ivp(fun, (t0, horizon), y0, method=method, rtol=rtol, atol=at,
                            events=evs or None, dense_output=True,
                            max_step=MAX_ANGLE / w if w > 0 else np.inf, **extra)
        except _StepLimit as exc:
            raise SimulationError(
                f"SciPy {integrator}: {max_steps} steps in one segment by t = {exc.args[0]:.6g} s "
                "and no event: the motion is too stiff (or too long) for this integrator at this "
                "tolerance; try integrator 'Radau' or 'LSODA', a larger rtol, or raise "
                "solver.max_steps") from None
        except ValueError as exc:  # raised inside SciPy (e.g. its event root finder)
            raise SimulationError(f"SciPy {integrator} failed after t = {t0:.6g} s: {exc}") from exc
        if sol.status == -1:
            raise SimulationError(f"SciPy {integrator} failed at t = {sol.t[-1]:.6g} s: {sol.message}")
        steps, nfev = len(sol.t) - 1, sol.nfev
        best, tb, yb = None, float(sol.t[-1]), sol.y[:, -1]
        if sol.status == 1:
            tb = np.inf
            for j, i in enumerate(active):  # the earliest; on a tie the lowest index
                if len(sol.t_events[j]) and (best is None or
                                             sol.t_events[j][0] < tb - 4 * np.spacing(tb)):
                    best, tb, yb = i, float(sol.t_events[j][0]), sol.y_events[j][0]
        best, tb, yb = _missed(gval, sol, active, best, tb, yb)
        if best is not None:
            if tb != last[0]:
                last[:] = [tb, set()]
            last[1].add(model.events[best][0])
        return Step(tb, yb, best, sol.sol, steps, nfev)

    start = time.perf_counter()
    segments, events, y, disc, totals = run_segments(model, advance, t_end=t_end,
                                                     max_events=max_events)
    wall = time.perf_counter() - start
    stats = {"steps": totals["steps"], "rhs_evaluations": totals["nfev"],
             "segments": len(segments), "wall_time": wall}
    return build_result(model, segments, events, y, disc, method=f"scipy-{integrator}",
                        tolerances={"rtol": rtol, "atol": atol}, stats=stats,
                        n_samples=n_samples, y_post=totals["y_post"])
