"""The paper's fixed-step integrator (Eqs. 1–8), kept as the reference it is.

Two vehicles that touch at ``t = 0``; time positions ``t_j = (j - 1) Δt``. Accelerations are zero
at ``j = 1``; then, for ``j >= 2``,

- ``D_j = UD - (X_2,j - X_1,j)`` (Eq. 4), ``F_j = Function(D_j)`` (Eq. 5), ``A_i,j = ±F_j / M_i``
  (Eq. 6);
- ``V_i,j+1 = V_i,j + A_i,j Δt`` (Eq. 7); once the vehicles reach a common velocity
  (``V_1 <= V_2``) ``Function`` becomes the rebound branch for good;
- ``X_i,j+1 = X_i,j + V_i,j Δt + ½ A_i,j Δt²`` (Eq. 8),

until ``F_j`` reaches zero: the pulse duration is that ``t_j``. The post-crash velocities are
read as the paper's Table 1 reads them: the velocities at the last time position at which the force
still acted (``V_i,j-1``; the impulse ``F_j-1 Δt`` of that last step is not added). Only this
reading reproduces every printed digit of Table 1 (e.g. ``V1* = -0.082`` at ``Δt = 0.001``, where
``V_i,j`` would give -0.083); it is one more first-order error term, and it vanishes with ``Δt``. ``Function`` is the shared IF-D law of :mod:`lsc.contact` (its segment transitions
included); the rebound branch starts from the last loading point ``(D, F)`` before the switch.
The method is first order: its error shrinks in proportion to ``Δt``.

Accuracy and memory. A run whose ``Δt`` is coarser than 1/100 of the contact time (``π/(2ω)``
of the stiffest loading piece the run reached, or its own compression time if shorter) is
returned with a warning in ``stats["warnings"]`` (its ΔV is then off by about ``Δt/T`` of the
closing speed). Every step of a run is kept (for the series and the exact peaks); a ``Δt`` that
would need more than :data:`MAX_STEPS` steps for the pulse (its length taken from the exact
piecewise solution) is refused up front with a :class:`~lsc.errors.SceneError` on
``solver.dt``.
"""

from __future__ import annotations

import math
import time
from array import array

import numpy as np

from ..contact import MODE_LOADING, MODE_OPEN, MODE_UNLOADING, HysteresisLaw
from ..errors import SceneError, SimulationError
from ..result import Event, Result
from .base import Backend

__all__ = ["BACKEND", "why_not", "solve", "MAX_STEPS", "STEPS_PER_CONTACT_TIME"]

#: Most steps one run may take: every step is kept (9 float64 values, about 130 bytes with the
#: arrays built from them at the end), so this bounds a run's memory to about 2 GiB.
MAX_STEPS = 2 ** 24

#: A run with fewer steps than this per contact time gets a warning in ``stats["warnings"]``.
STEPS_PER_CONTACT_TIME = 100


#: The paper's algorithm: two vehicles in contact at the start (no gap), the IF-D law, a
#: failure force reported; no braking, no post-failure branch.
BACKEND = Backend(
    name="reference", module=__name__, options=("dt", "t_end", "n_samples", "max_steps"),
    vehicles=(2, 2), solves=frozenset({"law:ifd", "loading:linear", "loading:table", "unloading:restitution",
                   "unloading:stiffness", "unloading:table", "effect:failure"}),
    summary="the paper's fixed-step algorithm")


def why_not(scene) -> str | None:
    """Why the paper's algorithm cannot run ``scene`` (``None`` if it can)."""
    from ..model import HybridModel

    return BACKEND.why_not(HybridModel(scene))


def solve(model, *, dt: float = 1e-5, t_end=None, max_steps: int = MAX_STEPS,
          n_samples: int = 1000) -> Result:
    """Run the paper's algorithm with time step ``dt`` [s], at most ``max_steps`` steps (at most
    :data:`MAX_STEPS`, the most whose run fits in memory)."""
    scene = model.scene
    BACKEND.check(model)
    dt = float(dt)
    if not (np.isfinite(dt) and dt > 0):
        raise SceneError("solver.dt", f"dt must be a positive time step, got {dt!r}")
    law: HysteresisLaw = model.laws[0]
    p = model.params["contacts"][0]
    M1, M2 = (float(m) for m in model.params["m"])
    V1, V2 = (float(v) for v in model.params["v0"])
    if not V1 > V2:
        raise SceneError("vehicles[0].speed", "the paper's algorithm needs the rear vehicle "
                         "(vehicle 1) faster than the front one at t = 0")
    if int(max_steps) > MAX_STEPS:
        raise SceneError("solver.max_steps", f"max_steps must be at most {MAX_STEPS} for the "
                         f"reference method (its run is held in memory), got {max_steps}")
    _check_steps(model, dt)
    max_steps = int(max_steps)
    start = time.perf_counter()

    def settle(D, st):
        """Move the law to the segment holding D (table breakpoints, separation)."""
        while True:
            mode = int(st["mode"])
            if mode == MODE_LOADING and D > st["hi"]:
                st = _py(law.on_event(1, D, 0.0, st, p, np))
                if st["status"]:
                    raise SimulationError(f"reference, t = {t:.6g} s: " + _status(st))
                events.append(Event(t, "breakpoint", 0))
            elif mode == MODE_UNLOADING and D < st["lo"]:
                st = _py(law.on_event(0, D, 0.0, st, p, np))
                events.append(Event(t, "separation" if int(st["mode"]) == MODE_OPEN
                                     else "breakpoint", 0))
            else:
                return st

    events = [Event(0.0, "contact", 0)]
    st = _py(law.init(0.0, V1 - V2, p, np))
    # j = 1
    t = 0.0
    X1, X2, A1, A2 = 0.0, 0.0, 0.0, 0.0
    ts, x1s, x2s, v1s, v2s, a1s, a2s, Ds, Fs = (array("d", [v]) for v in
                                                (0.0, 0.0, 0.0, V1, V2, 0.0, 0.0, 0.0, 0.0))
    # j = 2: the vehicles move through the first step at their initial velocities
    X1, X2 = X1 + V1 * dt, X2 + V2 * dt
    j = 2
    rebound = False
    while True:
        t = (j - 1) * dt
        D = X1 - X2
        st = settle(D, st)
        F = law.force(D, 0.0, st) if int(st["mode"]) != MODE_OPEN else 0.0
        over = F <= 0.0 and (rebound or int(st["mode"]) == MODE_OPEN)
        if over:
            F = 0.0
        else:
            V1_last, V2_last = V1, V2
        A1, A2 = -F / M1, F / M2
        ts.append(t); x1s.append(X1); x2s.append(X2); v1s.append(V1); v2s.append(V2)
        a1s.append(A1); a2s.append(A2); Ds.append(D); Fs.append(F)
        if over:
            if not events or "separation" not in events[-1].kind:
                events.append(Event(t, "separation", 0))
            break
        if t_end is not None and t > t_end:
            raise SimulationError(f"the requested end time t_end = {t_end:g} s comes before the "
                                  "crash is over: raise solver.t_end or leave it unset")
        if j >= max_steps:
            raise SimulationError(f"reference: no separation after {max_steps} steps of dt = "
                                  f"{dt:g} s; use a larger dt or another method")
        # next time position
        j += 1
        V1n, V2n = V1 + A1 * dt, V2 + A2 * dt
        if not rebound and V1n <= V2n:
            # common velocity: the IF-D function becomes the rebound branch from (D, F)
            rebound = True
            st = _py(law.on_event(2, D, 0.0, st, p, np))
            if st["status"]:
                raise SimulationError(f"reference, t = {t:.6g} s: " + _status(st))
            events.append(Event(t + dt, "max_deformation", 0))
        X1, X2 = X1 + V1 * dt + 0.5 * A1 * dt * dt, X2 + V2 * dt + 0.5 * A2 * dt * dt
        V1, V2 = V1n, V2n
    wall = time.perf_counter() - start
    t_arr = np.frombuffer(ts)
    keep = _thin(t_arr.size, n_samples)
    x = np.stack([np.frombuffer(x1s), np.frombuffer(x2s)], axis=1)
    v = np.stack([np.frombuffer(v1s), np.frombuffer(v2s)], axis=1)
    a = np.stack([np.frombuffer(a1s), np.frombuffer(a2s)], axis=1)
    Darr, Farr = np.frombuffer(Ds), np.frombuffer(Fs)
    if t_end is not None and t_end > t:
        # after separation nothing acts: the vehicles coast
        te = np.array([t_end])
        t_arr = np.append(t_arr, te)
        x = np.vstack([x, x[-1] + v[-1] * (t_end - t)])
        v = np.vstack([v, v[-1]])
        a = np.vstack([a, np.zeros(2)])
        Darr = np.append(Darr, x[-1, 0] - x[-1, 1])
        Farr = np.append(Farr, 0.0)
        keep = np.append(keep, t_arr.size - 1)
    rec = [{"dmax": st["dmax"], "fmax": st["fmax"], "dperm": st["dperm"], "ec": st["ec"],
            "er": st["er"]}]
    stats = {"steps": j - 1, "rhs_evaluations": j - 1, "segments": 1, "wall_time": wall}
    warning = _coarse_step_warning(law, p, M1, M2, st, events, dt)
    if warning:
        stats["warnings"] = [warning]
    # the peaks over every step up to the separation, not only over the kept samples
    ia = np.argmax(np.abs(a), axis=0)
    peaks = [(0.0, t, [Farr.max()], a[ia, [0, 1]])]
    return Result.build(scene, t=t_arr[keep], x=x[keep], v=v[keep], a=a[keep],
                        deformation=Darr[keep, None], force=Farr[keep, None], events=events,
                        contacts=rec, v_final=np.array([V1_last, V2_last]), peaks=peaks,
                        method="reference", tolerances={"dt": dt}, stats=stats)


def _check_steps(model, dt: float) -> None:
    """Refuse (``SceneError`` on ``solver.dt``) a ``dt`` whose run would need more than
    :data:`MAX_STEPS` steps for the pulse, the length of the exact piecewise solution (a
    scene whose exact solve fails is left to the run itself to report)."""
    from .exact import solve as exact_solve

    try:
        pulse = float(exact_solve(model, n_samples=2).duration)
    except (SimulationError, SceneError):
        return
    if not pulse / dt > MAX_STEPS:
        return
    raise SceneError("solver.dt", f"dt = {dt:g} s would take about {pulse / dt:.3g} steps for "
                     f"this pulse ({pulse:.6g} s), more than the {MAX_STEPS} steps a reference "
                     "run may keep in memory; use dt >= "
                     f"{_two_digits(pulse / MAX_STEPS, up=True)} s, or an exact method ('auto')")


def _two_digits(x: float, up: bool) -> str:
    """``x`` > 0 rounded up (or down) to 2 significant digits, as text."""
    e = math.floor(math.log10(x)) - 1
    return f"{(math.ceil if up else math.floor)(x / 10 ** e) * 10 ** e:.2g}"


def contact_time(law, p, M1: float, M2: float, st: dict, events) -> float:
    """The contact time [s] a reference run's step is measured against: ``π/(2ω)``,
    ``ω = √(k/μ)`` for the stiffest loading piece up to the run's maximum deformation, or the
    run's own compression time (contact to the common velocity) where that is shorter."""
    mu = M1 * M2 / (M1 + M2)
    n = law.n_load
    ld, ls = np.asarray(p["ld"], float)[:n], np.asarray(p["ls"], float)[:n]
    reached = ls[(ld < st["dmax"]) | (np.arange(n) == 0)]
    k = float(np.max(reached, initial=0.0))
    t_c = 0.5 * math.pi * math.sqrt(mu / k) if k > 0 else math.inf
    for ev in events:
        if ev.kind == "max_deformation":
            t_c = min(t_c, ev.time)
            break
    return t_c


def _coarse_step_warning(law, p, M1, M2, st, events, dt: float) -> str | None:
    """The warning for a step coarser than 1/:data:`STEPS_PER_CONTACT_TIME` of the contact
    time (``None`` if it is not)."""
    t_c = contact_time(law, p, M1, M2, st, events)
    if not dt * STEPS_PER_CONTACT_TIME > t_c:
        return None
    return (f"reference: dt = {dt:g} s is coarser than 1/{STEPS_PER_CONTACT_TIME} of the "
            f"contact time ({t_c:.4g} s, {t_c / dt:.3g} steps): the paper's first-order algorithm "
            f"is then off by about dt/T of the closing speed; use dt <= "
            f"{_two_digits(t_c / STEPS_PER_CONTACT_TIME, up=False)} s, or an exact method ('auto')")


def _py(st: dict) -> dict:
    return {k: (int(v) if k in ("mode", "seg", "status") else float(v)) for k, v in st.items()}


def _status(st) -> str:
    from ..contact import STATUS
    return STATUS[int(st["status"])]


def _thin(n: int, n_samples: int) -> np.ndarray:
    """Indices of at most about ``n_samples`` evenly spaced rows (first and last kept)."""
    if n <= n_samples + 1:
        return np.arange(n)
    return np.unique(np.append(np.linspace(0, n - 1, n_samples + 1).astype(int), n - 1))
