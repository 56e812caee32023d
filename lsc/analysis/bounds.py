"""The paper's severity bound: the closing speed at which the peak contact force reaches a failure
force (section "Technique to estimate peak acceleration", Table 3), found by root finding.

If neither bumper's weakest part (the impact bar that failed at the lowest force in the
quasi-static tests) was damaged in the crash, the peak contact force stayed below that failure
force, so the closing speed stayed below the speed at which the simulated peak force reaches it.
The paper finds that speed by trial speeds (4, 5, 6 ft/s → 4007, 5009, 6011 lb) and reports 6 ft/s
as the conservative upper limit; :func:`max_closing_speed` finds the speed itself by Brent's method
and reports the same whole-unit rows and bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..api import solve
from ..display import unit_of
from ..errors import SceneError, SimulationError
from ..scene import Scene
from ._common import (SummaryHTML, check_brent, check_contact, check_keywords, quantity, read_path,
                      split_path)

#: Most whole steps above the root ``max_closing_speed`` reports (each is one more solve).
MAX_MARGIN_STEPS = 1000

__all__ = ["max_closing_speed", "Bound", "peak_force"]


@dataclass(eq=False)
class Bound(SummaryHTML):
    """The result of :func:`max_closing_speed`; every value in the scene's unit system.

    ``speed`` [velocity]: the value of ``speed_path`` at which the peak force of ``contact`` equals
    ``failure_force`` [force]; ``closing_speed`` [velocity]: the contact's initial closing speed
    (rear minus front vehicle) there; ``result``: the crash at that speed (ΔVs, peak accelerations
    in g, pulse duration, ...). ``step`` [velocity]: the whole unit of speed; ``step_speed``: the
    first whole step at or above ``speed`` (the paper's 5 ft/s, 5009 lb: just above the failure
    force); ``bound_speed = step_speed + margin_steps * step``, the conservative bound (the paper's
    6 ft/s, 6011 lb) and ``bound_result`` its crash. ``rows``: ``(speed, Result)`` at each whole step
    from one step below ``step_speed`` to ``bound_speed`` (the paper's Table 3); the Result is
    ``None`` where the simulation cannot be completed (a loading table that ends too soon). ``evaluations``:
    simulations run by the search. ``step_unit``: the unit the step was given in (``"mph"``
    for ``step="1 mph"``; ``None``: the scene's), the unit :meth:`summary` prints speeds in.
    """

    scene: Scene
    failure_force: float
    contact: int
    speed_path: str
    speed: float
    closing_speed: float
    result: object
    step: float
    step_speed: float
    bound_speed: float
    bound_result: object
    rows: list = field(default_factory=list)
    evaluations: int = 0
    step_unit: str | None = None

    def summary(self, speed_unit: str | None = None) -> str:
        """Plain text: the root, the crash there, and the whole-step table (what ``lsc bound``
        prints). Speeds and ΔVs are printed in ``speed_unit`` (``"mph"``, ``"km/h"``, ``"ft/s"``,
        ``"m/s"``), by default in the unit the step was given in (``step="1 mph"``: mph), else
        the scene's; peak accelerations are signed, in g, as in :meth:`lsc.Result.summary`."""
        from ..display import speed_display, velocity_display
        s = self.scene
        if speed_unit is None and self.step_unit is not None:
            fv, vel = velocity_display(self.step_unit, s.units, "step")
        else:
            fv, vel = speed_display(speed_unit, s.units)
        u = {k: s.unit(k) for k in ("force", "time")}
        k = self.contact
        names = [v.name for v in s.vehicles]
        r = self.result
        lines = [
            f"{s.name}: bound on the closing speed from the failure force "
            f"{self.failure_force:g} {u['force']} (contact {k}, {names[k]}-{names[k + 1]})",
            f"peak force reaches {self.failure_force:g} {u['force']} at {self.speed_path} = "
            f"{self.speed * fv:.6f} {vel} (closing speed {self.closing_speed * fv:.6f} {vel}):",
            "  delta_v " + ", ".join(f"{n} {dv * fv:+.4f}" for n, dv in zip(names, r.delta_v))
            + f" {vel}; peak acceleration "
            + ", ".join(f"{n} {a:+.3f} g" for n, a in zip(names, r.peak_acceleration_g))
            + f"; pulse {r.duration:.5f} {u['time']}",
            "",
            f"{'speed':>8} {'peak force':>11} " + " ".join(f"{'dV ' + n:>12}" for n in names)
            + " " + " ".join(f"{'a ' + n:>10}" for n in names) + f" {'pulse':>8}",
            f"{vel:>8} {u['force']:>11} " + " ".join(f"{vel:>12}" for _ in names)
            + " " + " ".join(f"{'g':>10}" for _ in names) + f" {u['time']:>8}",
        ]
        for v, rr in self.rows:
            if rr is None:
                lines.append(f"{v * fv:>8.4g}  could not be completed (the loading table ends "
                             "before the vehicles reach a common velocity)")
                continue
            note = ""
            if v == self.step_speed:
                note = "  first whole step at or above the failure force"
            if v == self.bound_speed:
                note = "  conservative bound"
            lines.append(f"{v * fv:>8.4g} {rr.peak_force[k]:>11.1f} "
                         + " ".join(f"{dv * fv:>12.3f}" for dv in rr.delta_v) + " "
                         + " ".join(f"{a:>+10.3f}" for a in rr.peak_acceleration_g)
                         + f" {rr.duration:>8.5f}" + note)
        lines.append("")
        lines.append(f"conservative upper limit: {self.speed_path} <= {self.bound_speed * fv:g} "
                     f"{vel} (the first whole step of {self.step * fv:g} {vel} at or "
                     f"above {self.speed * fv:.4f}, plus "
                     f"{round((self.bound_speed - self.step_speed) / self.step)})")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """A JSON-ready summary (numbers in the scene's units)."""
        k = self.contact

        def row(v, r):
            if r is None:
                return {"speed": v, "completed": False}
            return {"speed": v, "peak_force": float(r.peak_force[k]), "delta_v": r.delta_v.tolist(),
                    "peak_acceleration_g": r.peak_acceleration_g.tolist(), "duration": r.duration}

        return {"scene": self.scene.name, "unit_system": self.scene.units,
                "units": {q: self.scene.unit(q) for q in ("velocity", "force", "time")},
                "failure_force": self.failure_force, "contact": k, "speed_path": self.speed_path,
                "speed": self.speed, "closing_speed": self.closing_speed,
                "at_speed": row(self.speed, self.result), "step": self.step,
                "step_speed": self.step_speed, "bound_speed": self.bound_speed,
                "rows": [row(v, r) for v, r in self.rows], "evaluations": self.evaluations}


def peak_force(scene, speed: float, *, contact: int = 0, speed_path: str = "vehicles.0.speed",
               method: str = "auto", **options) -> float:
    """Peak force of ``contact`` [force] with ``speed_path`` set to ``speed`` [velocity]."""
    check_keywords("peak_force", options, ("contact", "speed_path", "method"))
    sc = Scene.load(scene).with_values({speed_path: float(speed)})
    return float(solve(sc, method=method, **{"n_samples": 2, **options}).peak_force[contact])


def max_closing_speed(scene, failure_force=None, *, contact: int = 0,
                      speed_path: str = "vehicles.0.speed", method: str = "auto", step=1.0,
                      margin_steps: int = 1, bracket=None, xtol: float = 1e-12,
                      rtol: float = 4 * np.finfo(float).eps, maxiter: int = 200,
                      **options) -> Bound:
    """The speed at which the peak contact force reaches ``failure_force`` (the paper's bound).

    Parameters
    ----------
    scene : dict, path or Scene
        The crash with the measured (or approximated) system IF-D curve and the vehicles' masses.
    failure_force : float or str, optional
        The lowest failure force of the bumpers involved [force] (``"5000 lbf"`` or a number in
        the scene's units); default: the contact's ``failure.force``.
    contact : int
        The contact whose peak force is bounded.
    speed_path : str
        The dotted path of the speed that is searched (default the rear vehicle's speed).
    method : str
        Backend for every simulation (``"auto"``: the cheapest exact one).
    step : float or str
        The whole unit of speed for the rows and the bound [velocity] (``"1 mph"``; default 1).
    margin_steps : int
        Steps added above the first whole step at or above the root for the bound (default 1:
        the paper's 6 ft/s from a root of 4.99 ft/s); at most :data:`MAX_MARGIN_STEPS`.
    bracket : (lo, hi), optional
        Speeds [velocity] with peak force below / above the failure force; by default the search
        starts at closing speed zero (speed of the vehicle in front) and doubles until above.
    xtol, rtol, maxiter
        Brent's method tolerances on the speed [velocity] and iteration limit.
    **options
        Solver options (``rtol``, ``dt``, ...), as for :func:`lsc.solve`.

    Returns
    -------
    Bound
    """
    from scipy.optimize import brentq

    check_keywords("max_closing_speed", options,
                   ("failure_force", "contact", "speed_path", "method", "step", "margin_steps",
                    "bracket", "xtol", "rtol", "maxiter"))
    check_brent(xtol, rtol, maxiter)
    base = Scene.load(scene)
    k = check_contact(base, contact)
    if failure_force is None:
        fail = base.contacts[k].failure
        if fail is None:
            raise SceneError("failure_force", f"give the failure force (e.g. \"5000 lbf\"), or set "
                                              f"contacts[{k}].failure.force in the scene")
        F = float(fail.force)
    else:
        F = quantity(failure_force, "force", base, "failure_force")
    if not (math.isfinite(F) and F > 0):
        raise SceneError("failure_force", f"must be a positive force, got {F:g}")
    dv = quantity(step, "velocity", base, "step")
    if not dv > 0:
        raise SceneError("step", f"must be a positive speed, got {dv:g}")
    if isinstance(margin_steps, bool) or not isinstance(margin_steps, (int, np.integer)) \
            or not 0 <= margin_steps <= MAX_MARGIN_STEPS:
        raise SceneError("margin_steps", f"must be a whole number from 0 to {MAX_MARGIN_STEPS} "
                                         f"(one solve per step), got {margin_steps!r}")
    x0 = read_path(base, speed_path)
    ref, direct = _zero_force_speed(base, speed_path, k)
    evals = [0]
    cache: dict[float, float] = {}

    def g(x: float) -> float:
        """Peak force minus the failure force at speed ``x``; SimulationError propagates."""
        x = float(x)
        if direct and x <= ref:
            return -F  # the searched vehicle does not close on the one ahead: no contact force
        if x not in cache:
            evals[0] += 1
            try:
                sc = base.with_values({speed_path: x})
            except SceneError:
                if ref is not None and x <= ref:
                    return -F  # no pair closes at all
                raise
            cache[x] = float(solve(sc, method=method, **{"n_samples": 2, **options}).peak_force[k]) - F
        return cache[x]

    lo, hi = (_given_bracket(bracket, g, base) if bracket is not None
              else _expand(g, x0, ref, base, speed_path))
    root = brentq(g, lo, hi, xtol=xtol, rtol=rtol, maxiter=maxiter) if g(hi) != 0 else hi

    def at(x):
        return solve(base.with_values({speed_path: float(x)}), method=method, **options)

    result = at(root)
    first = math.ceil(root / dv - 1e-12) * dv
    bound_v = first + margin_steps * dv
    speeds = [first - dv] if (ref is None or first - dv > ref) else []
    speeds += [first + i * dv for i in range(margin_steps + 1)]
    rows = []
    for v in speeds:
        try:
            rows.append((float(v), at(v)))
        except SimulationError:  # e.g. the loading table ends before a common velocity
            rows.append((float(v), None))
    bound_result = rows[-1][1]
    sc_root = base.with_values({speed_path: float(root)})
    closing = float(sc_root.speeds[k] - sc_root.speeds[k + 1])
    return Bound(base, F, k, speed_path, float(root), closing, result, dv, float(first),
                 float(bound_v), bound_result, rows, evals[0], unit_of(step))


def _zero_force_speed(scene: Scene, path: str, k: int) -> tuple[float | None, bool]:
    """The speed of the vehicle ahead of the searched one (``None`` if ``path`` is not the speed
    of a vehicle with one ahead), and whether the peak force of contact ``k`` is known to be zero
    at or below it without simulating (``k`` joins the searched vehicle to the one ahead, no
    brakes, so nothing else can make them close)."""
    parts = split_path(path)
    if len(parts) == 3 and parts[0] == "vehicles" and parts[2] == "speed" and parts[1].isdigit():
        i = int(parts[1])
        if i + 1 < scene.n_vehicles:
            direct = (i == k and scene.n_vehicles == 2
                      and all(v.brake is None for v in scene.vehicles))
            return float(scene.speeds[i + 1]), direct
    return None, False


def _given_bracket(bracket, g, base):
    try:
        lo, hi = (quantity(b, "velocity", base, "bracket") for b in bracket)
    except (TypeError, ValueError):
        raise SceneError("bracket", f"a bracket is two speeds (lo, hi), got {bracket!r}") from None
    glo, ghi = g(lo), g(hi)
    if not (glo < 0 <= ghi):
        raise SceneError("bracket", f"the peak force must be below the failure force at lo and "
                                    f"reach it at hi; got {glo:+g} and {ghi:+g} relative to it")
    return lo, hi


def _expand(g, x0: float, ref: float | None, base: Scene, path: str, limit: int = 60):
    """A bracket ``(lo, hi)`` with ``g(lo) < 0 <= g(hi)`` found by doubling the closing speed
    from the scene's own (or one unit), then halving towards zero closing speed to tighten it.

    A speed whose simulation fails (the loading table ends before the vehicles reach a common
    velocity) is replaced by bisection towards the last speed that worked; if the force never
    reaches the failure force before the table ends, that is said.
    """
    if ref is None:
        raise SceneError("bracket", f"give bracket=(lo, hi): {path!r} is not the speed of a vehicle "
                                    "with one ahead of it, so there is no closing speed to start from")
    unit = base.unit("velocity")
    width = x0 - ref if x0 > ref else 1.0
    lo = ref
    if g(lo) >= 0:
        raise SimulationError(f"the peak force already reaches the failure force at zero closing "
                              f"speed ({path} = {ref:g} {unit}); give bracket=(lo, hi)")
    for _ in range(limit):
        hi = ref + width
        try:
            val = g(hi)
        except SimulationError as err:
            return lo, _last_working(g, lo, hi, err, unit)
        if val >= 0:
            break
        lo, width = hi, 2.0 * width
    else:
        raise SimulationError(f"the peak force does not reach the failure force even at "
                              f"{path} = {ref + width / 2:g} {unit}")
    if lo == ref:  # tighten towards zero closing speed (a few halvings)
        for _ in range(4):
            mid = ref + 0.5 * (hi - ref)
            try:
                val = g(mid)
            except SimulationError:
                break
            if val < 0:
                lo = mid
                break
            hi = mid
    return lo, hi


def _last_working(g, lo: float, hi: float, err, unit: str, limit: int = 80) -> float:
    """Bisect between ``lo`` (works, below the failure force) and ``hi`` (fails) for a speed that
    works and is at or above the failure force."""
    for _ in range(limit):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        try:
            val = g(mid)
        except SimulationError:
            hi = mid
            continue
        if val >= 0:
            return mid
        lo = mid
    raise SimulationError(f"the peak force does not reach the failure force before the "
                          f"simulation fails (at {hi:g} {unit}): {err}")
