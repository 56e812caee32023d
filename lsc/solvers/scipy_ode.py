"""SciPy backend: the hybrid ODE on ``scipy.integrate.solve_ivp`` with terminal events.

Each segment (frozen discrete state) is one ``solve_ivp`` call with the armed events of that
state, all terminal and all crossing zero downward; SciPy locates the earliest on its dense output
(Brent's method to a few ulps in time). Because every event function is zero on its surface and
only a *downward* crossing counts, a new segment that starts on the surface it just crossed moves
away from it and does not fire again (the restart trap).
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from ..errors import SimulationError
from .segments import Step, build_result, run_segments

__all__ = ["solve", "INTEGRATORS"]

INTEGRATORS = ("RK45", "DOP853", "LSODA", "Radau", "BDF", "RK23")


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


def _missed(model, disc, p, sol, active, best, tb, yb):
    """An armed event that crossed zero and back inside one step is invisible to SciPy's sign
    test at step ends (e.g. a table breakpoint just below the max deformation, crossed on the
    way up and down within the step that holds the common velocity). Every armed event is
    checked at the end of the segment: one that is negative there crossed earlier, and its first
    crossing is located on the dense output (Brent) and taken if it comes first."""
    g_end = model.event_values(tb, yb, disc, p)
    ts = sol.t
    for i in active:
        if i == best or not g_end[i] < 0:
            continue

        def g(t, i=i):
            return model.event_values(t, sol.sol(t), disc, p)[i]

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
          max_events: int = 10_000, n_samples: int = 1000, first_step=None):
    """Solve ``model`` with ``solve_ivp`` (``integrator``: RK45, DOP853, LSODA, Radau, BDF, RK23)."""
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

    def advance(t0, y0, disc, horizon):
        def fun(t, y):
            return model.rhs(t, y, disc, p)

        active = model.active_events(disc)
        evs = []
        for i in active:
            def ev(t, y, i=i):
                return model.event_values(t, y, disc, p)[i]
            ev.terminal = True
            ev.direction = -1
            evs.append(ev)
        sol = solve_ivp(fun, (t0, horizon), y0, method=integrator, rtol=rtol, atol=at,
                        events=evs or None, dense_output=True,
                        **({"first_step": first_step} if first_step else {}))
        if sol.status == -1:
            raise SimulationError(f"SciPy {integrator} failed at t = {sol.t[-1]:.6g} s: {sol.message}")
        steps, nfev = len(sol.t) - 1, sol.nfev
        best, tb, yb = None, float(sol.t[-1]), sol.y[:, -1]
        if sol.status == 1:
            tb = np.inf
            for j, i in enumerate(active):
                if len(sol.t_events[j]) and sol.t_events[j][0] < tb:
                    best, tb, yb = i, float(sol.t_events[j][0]), sol.y_events[j][0]
        best, tb, yb = _missed(model, disc, p, sol, active, best, tb, yb)
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
