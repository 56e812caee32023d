"""Closed-form backend: two vehicles, linear loading ``k``, linear unloading (DESIGN.md §1).

With ``μ = m1 m2/(m1+m2)``, ``ω = √(k/μ)`` and closing speed ``v0``, the deformation is harmonic
while loading, ``D = (v0/ω) sin ωτ`` for ``τ ≤ π/(2ω)``, and harmonic again on the unloading line
of slope ``k/e²`` (``ω_u = ω/e``) from ``D_max = v0/ω`` down to ``D_perm = D_max (1 - e²)``, which
it reaches after another ``e π/(2ω)`` at closing speed ``-e v0``. The centre of mass moves at
constant speed throughout. Everything here is exact and vectorised over arrays of scenes.
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import SceneError
from .. import metrics as _metrics
from ..model import HybridModel
from ..result import Event, Result
from ..scene import Restitution
from . import kelvin
from .base import Backend

__all__ = ["BACKEND", "applies", "why_not", "parameters", "metrics", "solve", "solve_batch"]


#: What the IF-D closed form solves: linear loading from the origin, a straight unloading line.
IFD_FEATURES = frozenset({"law:ifd", "loading:linear", "unloading:restitution",
                          "unloading:stiffness", "effect:failure", "gap:open"})

#: The closed form's declaration: two vehicles, one contact, either the IF-D law with linear
#: loading from the origin and a straight unloading line, or the Kelvin law
#: (:mod:`lsc.solvers.kelvin`); a gap; a failure force reported; no braking, no post-failure
#: branch.
BACKEND = Backend(
    name="closed-form", module=__name__, options=("t_end", "n_samples"), exact=True, cost=0.0,
    vehicles=(2, 2), solves=IFD_FEATURES | kelvin.FEATURES, batch=IFD_FEATURES | kelvin.FEATURES,
    summary="closed forms: the linear spring with a straight unloading line, and the Kelvin law")


def why_not(scene) -> str | None:
    """Why the closed form does not apply to ``scene`` (``None`` if it does)."""
    return BACKEND.why_not(HybridModel(scene))


def applies(scene) -> bool:
    """True when the closed form solves ``scene`` exactly."""
    return why_not(scene) is None


def parameters(scene) -> dict:
    """The closed form's inputs: ``m1, m2, v1, v2, k, e, gap`` (floats, scene units)."""
    reason = why_not(scene)
    if reason:
        raise SceneError("solver.method", f"the closed form does not apply: {reason}; "
                         "use method 'scipy' (or 'auto')")
    c = scene.contacts[0]
    k = c.law.loading.stiffness
    u = c.law.unloading
    e = u.e if isinstance(u, Restitution) else np.sqrt(k / u.stiffness)
    (m1, m2), (v1, v2) = scene.masses, scene.speeds
    return {"m1": m1, "m2": m2, "v1": v1, "v2": v2, "k": k, "e": float(e), "gap": c.gap}


def first_impact(m1, m2, v1, v2, k, e, gap=0.0) -> dict:
    """The exact first-impact record (:data:`lsc.metrics.FIRST_KEYS`, K = 1) and the contact
    record (``dmax, dperm, ec, er``), vectorised: every argument may be an array (broadcast
    together). Also returns ``v_final`` (..., 2), ``omega`` (...) [1/time] and ``v0`` (...)."""
    m1, m2, v1, v2, k, e, gap = np.broadcast_arrays(*(np.asarray(a, float)
                                                      for a in (m1, m2, v1, v2, k, e, gap)))
    M = m1 + m2
    w = np.sqrt(k / (m1 * m2 / M))
    v0 = v1 - v2
    dmax = v0 / w
    fmax = k * dmax
    ec = 0.5 * k * dmax**2
    t_c = gap / v0
    v_touch = np.stack([v1, v2], axis=-1)
    v_final = v_touch + np.stack([-(1 + e) * m2 * v0 / M, (1 + e) * m1 * v0 / M], axis=-1)
    first = {"contact_time": t_c[..., None], "v_touch": v_touch[..., None, :],
             "first_end": (t_c + np.pi / (2 * w) * (1 + e))[..., None],
             "v_sep": v_final[..., None, :], "peak_force": fmax[..., None],
             "peak_acc": np.stack([-fmax / m1, fmax / m2], axis=-1)[..., None, :],
             "v_max": np.maximum(np.max(np.abs(v_touch), axis=-1),
                                 np.max(np.abs(v_final), axis=-1))}
    records = {"dmax": dmax[..., None], "dperm": (dmax * (1 - e**2))[..., None],
               "ec": ec[..., None], "er": (e**2 * ec)[..., None]}
    return {"first": first, "records": records, "v_final": v_final, "omega": w, "v0": v0}


def metrics(m1, m2, v1, v2, k, e, gap=0.0, g=1.0, failure_force=np.nan) -> dict:
    """Exact metrics, vectorised: every argument may be an array (broadcast together), through
    :func:`lsc.metrics.metrics` from the closed-form first impact (:func:`first_impact`).

    Returns ``delta_v, v_final, peak_acceleration, peak_acceleration_g`` (..., 2) and
    ``duration, max_deformation, permanent_deformation, peak_force, restitution,
    restitution_energy, energy_absorbed, energy_returned, contact_time, separation_time,
    failure_time`` (...): the force first exceeds ``failure_force`` at
    ``t_c + arcsin(F_fail / F_max) / ω`` (NaN if it never does).
    """
    cf = first_impact(m1, m2, v1, v2, k, e, gap)
    first, w = cf["first"], cf["omega"]
    t_c, fmax = first["contact_time"][..., 0], first["peak_force"][..., 0]
    ff = np.asarray(failure_force, float)
    with np.errstate(invalid="ignore"):
        t_fail = np.where(fmax > ff, t_c + np.arcsin(np.minimum(ff / fmax, 1.0)) / w, np.nan)
    out = _metrics.metrics(first, cf["records"], cf["v_final"], g, t_fail[..., None],
                           first["first_end"][..., 0], cf["v_final"],
                           separation_time=first["first_end"])
    # one contact: its values (...) rather than (..., 1)
    return _metrics.one_contact(out)


def relative_motion(t, v0, w, e, gap, k=None):
    """Deformation ``D`` and closing rate ``Ddot`` at times ``t`` (exact, piecewise), and with
    the loading stiffness ``k`` the contact force ``F`` as well.

    The rebound is written from ``(D_max, F_max)``, in its phase ``θ = (π/2) τ/T_2`` (``T_2 = e
    T_1`` its duration): ``D = D_max - e² D_max (1 - cos θ)``, ``Ddot = -e v0 sin θ``,
    ``F = F_max cos θ``, with no ``D_perm`` rounded to the ulps of ``D_max`` and no ``ω/e``
    (which overflows for a subnormal ``e``)."""
    t = np.asarray(t, float)
    dmax = v0 / w
    t_c = gap / v0
    T1 = np.pi / (2 * w)
    T2 = e * T1
    tau = t - t_c
    D = np.where(tau < 0, -gap + v0 * t, 0.0)
    Dd = np.where(tau < 0, v0, 0.0)
    comp = (tau >= 0) & (tau <= T1)
    D = np.where(comp, dmax * np.sin(w * np.clip(tau, 0, T1)), D)
    Dd = np.where(comp, v0 * np.cos(w * np.clip(tau, 0, T1)), Dd)
    F = np.where(comp, 0.0 if k is None else k * np.maximum(D, 0), 0.0)
    unl = (tau > T1) & (tau <= T1 + T2)
    if T2 > 0:
        th = 0.5 * np.pi * np.clip(tau - T1, 0, T2) / T2
        half = np.sin(0.5 * th)
        D = np.where(unl, dmax - (e * e * dmax) * (2.0 * half * half), D)
        Dd = np.where(unl, -e * v0 * np.sin(th), Dd)
        if k is not None:
            F = np.where(unl, k * dmax * np.cos(th), F)
    post = tau > T1 + T2
    D = np.where(post, dmax * (1 - e**2) - e * v0 * (tau - T1 - T2), D)
    Dd = np.where(post, -e * v0, Dd)
    return (D, Dd) if k is None else (D, Dd, F)


class _Motion:
    """The exact motion of a closed-form scene: its rows at given times, and its sampler."""

    def __init__(self, P: dict, t_stop: float, knots, n_samples: int):
        self.P, self.t_stop, self.knots, self.n_samples = P, t_stop, knots, n_samples

    def rows(self, t) -> dict:
        """``t, x, v, a`` and ``deformation, force`` (one contact) at times ``t``."""
        m1, m2, v1, v2, k, e, gap = (self.P[n] for n in ("m1", "m2", "v1", "v2", "k", "e", "gap"))
        M = m1 + m2
        v0, vcm = v1 - v2, (m1 * v1 + m2 * v2) / M
        w = np.sqrt(k * M / (m1 * m2))
        D, Dd, F = relative_motion(t, v0, w, e, gap, k)
        x = np.stack([vcm * t + m2 / M * (D + gap), vcm * t - m1 / M * (D + gap)], axis=1)
        v = np.stack([vcm + m2 / M * Dd, vcm - m1 / M * Dd], axis=1)
        a = np.stack([-F / m1, F / m2], axis=1)
        return {"t": t, "x": x, "v": v, "a": a, "deformation": D[:, None], "force": F[:, None]}

    def __call__(self) -> dict:
        """The series: ``n_samples`` steps over the run, every event time included."""
        return self.rows(np.union1d(np.linspace(0.0, self.t_stop, self.n_samples + 1),
                                    self.knots))


def solve(model, *, t_end=None, n_samples: int = 1000) -> Result:
    """Exact solution of a closed-form scene as a :class:`Result`: its metrics from the
    closed-form first impact, its series (on a grid that includes every event time) computed
    when first read. A Kelvin scene is solved by :func:`lsc.solvers.kelvin.solve`."""
    if "law:kelvin" in model.features():
        return kelvin.solve(model, t_end=t_end, n_samples=n_samples)
    start = time.perf_counter()
    scene = model.scene
    P = parameters(scene)
    fail = scene.contacts[0].failure
    met = metrics(*(P[n] for n in ("m1", "m2", "v1", "v2", "k", "e", "gap")), scene.g,
                  fail.force if fail else np.nan)
    e = P["e"]
    t_c, t_s = float(met["contact_time"]), float(met["separation_time"])
    M = P["m1"] + P["m2"]
    t_m = P["gap"] / (P["v1"] - P["v2"]) + np.pi / (2 * np.sqrt(P["k"] * M / (P["m1"] * P["m2"])))
    t_stop = t_s
    if t_end is not None:
        if t_end < t_s:
            from ..errors import SimulationError
            raise SimulationError(
                f"the requested end time t_end = {t_end:g} s comes before the crash is over "
                f"(separation at {t_s:.6g} s): raise solver.t_end or leave it unset")
        t_stop = float(t_end)
    knots = np.array(sorted({0.0, t_c, t_m, t_s, t_stop}))
    motion = _Motion(P, t_stop, knots, n_samples)
    events = [Event(t_c, "contact", 0)]
    events.append(Event(t_m, "max_deformation" if e > 0 else "max_deformation+separation", 0))
    if e > 0:
        events.append(Event(t_s, "separation", 0))
    records = [{"dmax": float(met["max_deformation"]), "fmax": float(met["peak_force"]),
                "dperm": float(met["permanent_deformation"]),
                "ec": float(met["energy_absorbed"]), "er": float(met["energy_returned"])}]
    stats = {"steps": 0, "rhs_evaluations": 0, "segments": 3 if e > 0 else 2,
             "wall_time": time.perf_counter() - start}
    # the exact peaks, at max deformation
    peak = (t_m, t_m, [float(met["peak_force"])], met["peak_acceleration"])
    return Result.build(scene, rows=motion.rows(knots), sampler=motion, peaks=[peak],
                        events=events, contacts=records, v_final=met["v_final"],
                        method="closed-form", tolerances={}, stats=stats,
                        failure_time=np.array([float(met["failure_time"])]))


def solve_batch(model, values: dict, *, progress=None) -> dict:
    """Exact metrics of every member of ``values`` (dotted scene path → (n,) array in scene
    units, every member valid) of ``model``'s closed-form scene, in one vectorised evaluation of
    :func:`metrics`: ``{"metrics": {name: (n, ...) array for every name of lsc.result.METRICS},
    "status": (n,) object array of "ok"}`` (a closed-form member always completes).
    ``progress(k)``: called as ``k`` members finish. Kelvin scenes:
    :func:`lsc.solvers.kelvin.solve_batch`."""
    if "law:kelvin" in model.features():
        return kelvin.solve_batch(model, values, progress=progress)
    from ..parameters import batch_params
    from ..result import METRICS

    p = batch_params(model, values)
    if p is None:
        path = next(q for q in values if batch_params(model, {q: values[q][:1]}) is None)
        raise SceneError(path, "the closed-form batch sets only paths that map onto the model's "
                               "numbers (speeds, masses, weights, gaps, stiffnesses, "
                               "restitution); solve the members one by one (lsc.sweep does)")
    n = p["m"].shape[0]
    c = p["contacts"][0]
    k = c["ls"][:, 0]
    fail = model.scene.contacts[0].failure
    with np.errstate(invalid="ignore", divide="ignore"):
        e = c["e"] if "e" in c else np.sqrt(k / c["su"])
        out = metrics(p["m"][:, 0], p["m"][:, 1], p["v0"][:, 0], p["v0"][:, 1], k, e,
                      p["gap"][:, 0], model.scene.g, fail.force if fail else np.nan)
    shape = {"scene": (n,), "vehicle": (n, model.N), "contact": (n, model.K)}
    res = {name: np.asarray(out[name], float).reshape(shape[per])
           for name, (_, per) in METRICS.items()}
    if progress is not None:
        progress(n)
    return {"metrics": res, "status": np.full(n, "ok", dtype=object)}
