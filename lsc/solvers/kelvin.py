"""The Kelvin contact of two vehicles in closed form: ``F = max(0, k D + c Ḋ)`` (DESIGN.md §1).

With ``μ = m1 m2/(m1+m2)``, ``ω = √(k/μ)``, ``ζ = c/(2√(kμ))`` and the closing speed ``v0``
(the gap closes at constant speeds, at ``t_c = gap/v0``), the deformation obeys
``D'' + 2ζω D' + ω² D = 0`` from ``D = 0, D' = v0``; in the phase ``τ = ω (t - t_c)``

    D = (v0/ω) e^{-ζτ} S(τ),        Ḋ = v0 e^{-ζτ} (C(τ) - ζ S(τ)),

with ``S = sin(βτ)/β, C = cos βτ, β = √(1-ζ²)`` (under-damped), ``S = τ, C = 1`` (critical)
and ``S = sinh(βτ)/β, C = cosh βτ, β = √(ζ²-1)`` (over-damped; evaluated as
``e^{-ζτ} S = -e^{-τ/(ζ+β)} expm1(-2βτ)/(2β)``, which neither overflows nor cancels). The force
is ``F = k D + c Ḋ = -μ D''``, so it is zero at the inflection of ``D``, which comes in every
regime *before* ``D`` returns to zero (over-damped, ``D`` never does): the contact is tension-free
and separates there. With ``h(ζ) = arccos ζ/√(1-ζ²)``, ``1``, ``arccosh ζ/√(ζ²-1)``:

- max crush (``Ḋ = 0``) at ``τ_m = h``: ``D_max = (v0/ω) e^{-ζh}``;
- separation (``F = 0``) at ``τ_s = 2h`` (``2 arccos ζ/ω_d`` under-damped), closing rate
  ``-e v0`` with ``e = e^{-2ζh}`` (:func:`lsc.contact.kelvin_restitution`), at the permanent
  deformation ``D_s = 2ζ e v0/ω`` (from ``k D_s = -c Ḋ_s``); then both move at constant speed;
- the peak force ``F = √(kμ) v0 f(τ)``, ``f = ωD/v0 + 2ζ Ḋ/v0``: ``f`` jumps to ``2ζ`` at
  touch (the law's known flaw) and for ``ζ < 1/2`` rises to ``e^{-ζτ_p}`` at
  ``τ_p = (3 arccos ζ - π)/β`` (``D''' = 0``); for ``ζ >= 1/2`` it only falls, the peak is at touch;
- the energy absorbed to max crush is the relative kinetic energy ``½ μ v0²`` (``Ḋ = 0`` there),
  the energy returned ``e²`` times it; ``ΔV_1 = -(1+e) μ v0/m1``, ``ΔV_2 = (1+e) μ v0/m2``.

A declared failure force ``F_f`` is exceeded at touch when ``2ζ√(kμ)v0 > F_f``, else, when the
peak exceeds it, at the root of ``f(τ) = F_f/(√(kμ)v0)`` on ``(0, τ_p)``, where ``f`` rises
(bisected to the last bit). Everything is vectorised over arrays of scenes.
"""

from __future__ import annotations

import time

import numpy as np

from .. import metrics as _metrics
from ..errors import SceneError, SimulationError
from ..result import Event, Result
from .base import describe, solve_alone

__all__ = ["FEATURES", "why_not", "applies", "parameters", "crush_phase", "unit_motion",
           "metrics", "solve", "batch_parameters", "solve_batch"]

#: What this closed form solves (:meth:`lsc.model.HybridModel.features`), two vehicles only:
#: one Kelvin contact, an initial gap, a failure force reported (no braking).
FEATURES = frozenset({"law:kelvin", "effect:failure", "gap:open"})


def why_not(model) -> str | None:
    """Why the Kelvin closed form does not solve ``model`` (a
    :class:`~lsc.model.HybridModel`; ``None`` if it does)."""
    if model.N != 2:
        return f"it solves exactly 2 vehicles, the scene has {model.N}"
    extra = sorted(model.features() - FEATURES)
    if extra:
        return "; ".join(f"it does not solve {describe(f)}" for f in extra)
    if "law:kelvin" not in model.features():
        return "its contact law is not Kelvin's"
    if not model.params["v0"][0] > model.params["v0"][1]:
        return "the vehicles are not closing"
    return None


def applies(model) -> bool:
    """True when the Kelvin closed form solves ``model`` exactly."""
    return why_not(model) is None


def parameters(model) -> dict:
    """The closed form's inputs (floats, scene units): ``m1, m2, v1, v2, k, zeta, gap, g,
    failure_force`` (NaN when the contact has none); a :class:`SceneError` if it does not apply."""
    reason = why_not(model)
    if reason:
        raise SceneError("solver.method", f"the Kelvin closed form does not apply: {reason}; "
                         "use method 'scipy' (or 'auto')")
    p = model.params
    (m1, m2), (v1, v2) = (float(x) for x in p["m"]), (float(x) for x in p["v0"])
    law = p["contacts"][0]
    fail = p["failures"][0]["force"] if p["failures"] else np.nan
    return {"m1": m1, "m2": m2, "v1": v1, "v2": v2, "k": float(law["k"]),
            "zeta": float(law["zeta"]), "gap": float(p["gap"][0]), "g": float(model.scene.g),
            "failure_force": float(fail)}


# ------------------------------------------------------------------ dimensionless motion
def _beta(zeta):
    """``√|1 - ζ²|`` without cancellation near ζ = 1."""
    return np.sqrt(np.abs((1.0 - zeta) * (1.0 + zeta)))


def crush_phase(zeta):
    """``h(ζ) = ω t_max`` [-], the phase of max crush: ``arccos ζ/√(1-ζ²)`` (ζ < 1), ``1``
    (ζ = 1), ``arccosh ζ/√(ζ²-1)`` (ζ > 1); separation comes at ``2h``."""
    z = np.asarray(zeta, float)
    b = _beta(z)
    safe = np.where(b > 0, b, 1.0)
    with np.errstate(invalid="ignore"):
        under = np.arccos(np.minimum(z, 1.0)) / safe
        over = np.arccosh(np.maximum(z, 1.0)) / safe
    return np.where(z < 1, under, np.where(z > 1, over, 1.0))


def unit_motion(tau, zeta):
    """Deformation ``ωD/v0`` and closing rate ``Ḋ/v0`` [-] at phase ``τ = ω (t - t_c) >= 0``
    of the free damped motion from ``D = 0, Ḋ = v0`` (the contact phase, before separation)."""
    tau, z = np.broadcast_arrays(np.asarray(tau, float), np.asarray(zeta, float))
    b = _beta(z)
    safe = np.where(b > 0, b, 1.0)
    # under-damped and critical (b = 0: S = τ, C = 1)
    S = np.where(b > 0, np.sin(b * tau) / safe, tau)
    decay = np.exp(-z * tau)
    d_under, dd_under = decay * S, decay * (np.cos(b * tau) - z * S)
    # over-damped: e^{-ζτ} sinh(βτ)/β = -e^{-r τ} expm1(-2βτ)/(2β), r = ζ - β = 1/(ζ + β)
    r = 1.0 / (z + b)
    slow = np.exp(-r * tau)
    E = np.expm1(-2.0 * b * tau) / (2.0 * safe)
    d_over, dd_over = -slow * E, slow * (np.exp(-2.0 * b * tau) + r * E)
    over = z > 1
    return np.where(over, d_over, d_under), np.where(over, dd_over, dd_under)


def _unit_force(tau, zeta):
    """``F/(√(kμ) v0) = ωD/v0 + 2ζ Ḋ/v0`` [-] in the contact phase."""
    d, dd = unit_motion(tau, zeta)
    return d + 2.0 * np.asarray(zeta, float) * dd


def _unit_peak(zeta):
    """Phase ``τ_p`` and value ``f_p`` of the peak of ``F/(√(kμ) v0)`` over the contact."""
    z = np.asarray(zeta, float)
    b = np.where(z < 0.5, _beta(z), 1.0)
    tau = np.where(z < 0.5, (3.0 * np.arccos(np.minimum(z, 1.0)) - np.pi) / b, 0.0)
    return tau, np.where(z < 0.5, np.exp(-z * tau), 2.0 * z)


def _unit_failure(zeta, level):
    """Phase [-] at which ``F/(√(kμ) v0)`` first exceeds ``level`` (NaN if it never does):
    at touch if the jump ``2ζ`` does, else by bisection on the rise ``(0, τ_p)``."""
    z, level = np.broadcast_arrays(np.asarray(zeta, float), np.asarray(level, float))
    tau_p, f_p = _unit_peak(z)
    lo, hi = np.zeros_like(tau_p), tau_p.copy()
    for _ in range(1100):   # halves the bracket down to one ulp (or to a subnormal width)
        mid = 0.5 * (lo + hi)
        if not np.any((mid > lo) & (mid < hi)):
            break
        up = _unit_force(mid, z) > level
        lo, hi = np.where(up, lo, mid), np.where(up, mid, hi)
    out = np.where(2.0 * z > level, 0.0, hi)
    return np.where(f_p > level, out, np.nan)


# ------------------------------------------------------------------ metrics
def metrics(m1, m2, v1, v2, k, zeta, gap=0.0, g=1.0, failure_force=np.nan) -> dict:
    """Exact metrics of the Kelvin impact, vectorised: every argument may be an array
    (broadcast together). Masses [mass], speeds [velocity], ``k`` [force/length], ``zeta`` the
    damping ratio [-], ``gap`` [length], ``g`` [acceleration], ``failure_force`` [force].

    Returns ``delta_v, v_final, peak_acceleration, peak_acceleration_g`` (..., 2) and
    ``duration`` (touch to ``F = 0``), ``max_deformation``, ``permanent_deformation`` (at
    separation), ``peak_force``, ``restitution``, ``restitution_energy``, ``energy_absorbed``,
    ``energy_returned``, and the absolute times [time] ``contact_time, max_deformation_time,
    peak_force_time, separation_time, failure_time`` (NaN if the failure force is never
    exceeded) (...).
    """
    m1, m2, v1, v2, k, z, gap, g, ff = np.broadcast_arrays(
        *(np.asarray(a, float) for a in (m1, m2, v1, v2, k, zeta, gap, g, failure_force)))
    mu = m1 * m2 / (m1 + m2)
    w = np.sqrt(k / mu)
    v0 = v1 - v2
    scale = np.sqrt(k * mu) * v0          # F / f [force]
    h = crush_phase(z)
    e = np.exp(-2.0 * z * h)
    tau_p, f_p = _unit_peak(z)
    t_c = gap / v0
    impulse = (1.0 + e) * mu * v0
    dv = np.stack([-impulse / m1, impulse / m2], axis=-1)
    F_p = scale * f_p
    peak_a = np.stack([-F_p / m1, F_p / m2], axis=-1)
    ec = 0.5 * mu * v0 * v0
    t_sep = t_c + 2.0 * h / w
    v_touch = np.stack([v1, v2], axis=-1)
    v_final = v_touch + dv
    # the first-impact record, and every definition from the one metrics function
    first = {"contact_time": t_c[..., None], "v_touch": v_touch[..., None, :],
             "first_end": t_sep[..., None], "v_sep": v_final[..., None, :],
             "peak_force": F_p[..., None], "peak_acc": peak_a[..., None, :],
             "v_max": np.maximum(np.max(np.abs(v_touch), axis=-1),
                                 np.max(np.abs(v_final), axis=-1))}
    records = {"dmax": (v0 / w * np.exp(-z * h))[..., None],
               "dperm": (2.0 * z * e * v0 / w)[..., None], "ec": ec[..., None],
               "er": (e * e * ec)[..., None]}
    t_fail = t_c + _unit_failure(z, ff / scale) / w
    out = _metrics.metrics(first, records, v_final, g, t_fail[..., None], t_sep, v_final,
                           separation_time=first["first_end"])
    out = _metrics.one_contact(out)
    out.update(max_deformation_time=t_c + h / w, peak_force_time=t_c + tau_p / w,
               separation_time=t_sep)
    return out


# ------------------------------------------------------------------ the Result
def _end_time(t_end, t_sep: float) -> float:
    """Where the series stop: at separation, or at ``t_end`` [s] if it does not cut the crash."""
    if t_end is None:
        return t_sep
    if t_end < t_sep:
        raise SimulationError(
            f"the requested end time t_end = {t_end:g} s comes before the crash is over "
            f"(separation at {t_sep:.6g} s): raise solver.t_end or leave it unset")
    return float(t_end)


def _relative_series(t, P: dict, met: dict):
    """``D, Ḋ, F`` at times ``t`` (sorted; the contact time once): before touch, in contact
    (``F = max(0, k D + c Ḋ)``), and after separation at constant speeds."""
    z, k = P["zeta"], P["k"]
    mu = P["m1"] * P["m2"] / (P["m1"] + P["m2"])
    w, v0 = np.sqrt(k / mu), P["v1"] - P["v2"]
    t_c, t_s = float(met["contact_time"]), float(met["separation_time"])
    e, d_s = float(met["restitution"]), float(met["permanent_deformation"])
    d, dd = unit_motion(np.clip(w * (t - t_c), 0.0, None), z)
    D, Dd = v0 / w * d, v0 * dd
    F = np.maximum(k * D + 2.0 * z * np.sqrt(k * mu) * Dd, 0.0)
    before, after = t < t_c, t >= t_s
    D = np.where(before, v0 * (t - t_c), np.where(after, d_s - e * v0 * (t - t_s), D))
    Dd = np.where(before, v0, np.where(after, -e * v0, Dd))
    F = np.where(before | after, 0.0, F)
    return D, Dd, F


def _events(met: dict) -> list:
    """Contact, failure (if any), max crush and separation, in time order."""
    t = {name: float(met[f"{name}_time"]) for name in ("contact", "max_deformation",
                                                        "separation", "failure")}
    events = [Event(t["contact"], "contact", 0)]
    if np.isfinite(t["failure"]):
        events.append(Event(t["failure"], "failure", 0))
    events += [Event(t["max_deformation"], "max_deformation", 0),
               Event(t["separation"], "separation", 0)]
    return sorted(events, key=lambda ev: ev.time)


def solve(model, *, t_end=None, n_samples: int = 1000) -> Result:
    """Exact solution of a two-vehicle Kelvin scene as a :class:`Result`: series sampled on a
    grid that holds every event time and the peak of the force (the contact time twice, before
    and after the force's jump, when the gap is open), events ``contact``, ``failure``,
    ``max_deformation``, ``separation``."""
    start = time.perf_counter()
    P = parameters(model)
    met = metrics(**P)
    t_c, t_s = float(met["contact_time"]), float(met["separation_time"])
    t_stop = _end_time(t_end, t_s)
    knots = [0.0, t_c, float(met["max_deformation_time"]), float(met["peak_force_time"]), t_s,
             t_stop]
    fail = float(met["failure_time"])
    t = np.union1d(np.linspace(0.0, t_stop, n_samples + 1),
                   knots + ([fail] if np.isfinite(fail) else []))
    D, Dd, F = _relative_series(t, P, met)
    if t_c > 0:   # the row just before touch (no force yet) beside the one after it
        i = int(np.searchsorted(t, t_c))
        t, D, Dd, F = (np.insert(t, i, t_c), np.insert(D, i, 0.0),
                       np.insert(Dd, i, P["v1"] - P["v2"]), np.insert(F, i, 0.0))
    m1, m2, gap = P["m1"], P["m2"], P["gap"]
    M = m1 + m2
    vcm = (m1 * P["v1"] + m2 * P["v2"]) / M
    x = np.stack([vcm * t + m2 / M * (D + gap), vcm * t - m1 / M * (D + gap)], axis=1)
    v = np.stack([vcm + m2 / M * Dd, vcm - m1 / M * Dd], axis=1)
    a = np.stack([-F / m1, F / m2], axis=1)
    dmax = float(met["max_deformation"])
    records = [{"dmax": dmax, "fmax": P["k"] * dmax, "dperm": float(met["permanent_deformation"]),
                "ec": float(met["energy_absorbed"]), "er": float(met["energy_returned"])}]
    stats = {"steps": 0, "rhs_evaluations": 0, "segments": 3,
             "wall_time": time.perf_counter() - start}
    # the exact peak (the sample at its time holds it to rounding)
    peak = (t_c, t_s, [float(met["peak_force"])], met["peak_acceleration"])
    return Result.build(model.scene, t=t, x=x, v=v, a=a, deformation=D[:, None],
                        force=F[:, None], events=_events(met), contacts=records,
                        v_final=met["v_final"], method="closed-form", tolerances={}, stats=stats,
                        peaks=[peak], failure_time=np.array([fail]))


# ------------------------------------------------------------------ batches
def batch_parameters(model, values: dict) -> dict:
    """:func:`metrics`' inputs for every member of ``values`` (dotted scene path → (n,) array in
    scene units): each an (n,) array, from the model's numbers of each member
    (:func:`lsc.parameters.batch_params`: a damping ``c`` given in the scene keeps ``c``, its
    damping ratio follows each member's masses and stiffness); a path with no parameter setter
    (the failure force) re-loads the scene member by member."""
    from ..model import HybridModel
    from ..parameters import batch_params

    n = len(next(iter(values.values())))
    p = batch_params(model, values)
    if p is None:
        rows = [parameters(HybridModel(model.scene.with_values(
            {path: float(v[j]) for path, v in values.items()}))) for j in range(n)]
        return {name: np.array([row[name] for row in rows]) for name in rows[0]}
    base = parameters(model)
    m, v = np.asarray(p["m"], float), np.asarray(p["v0"], float)
    law = p["contacts"][0]
    return {"m1": m[:, 0], "m2": m[:, 1], "v1": v[:, 0], "v2": v[:, 1],
            "k": np.broadcast_to(np.asarray(law["k"], float), (n,)).copy(),
            "zeta": np.broadcast_to(np.asarray(law["zeta"], float), (n,)).copy(),
            "gap": np.asarray(p["gap"], float)[:, 0], "g": np.full(n, base["g"]),
            "failure_force": np.full(n, base["failure_force"])}


def solve_batch(model, values: dict, *, progress=None) -> dict:
    """Every member of ``values`` (dotted scene path → (n,) array in scene units, each member
    validated by the loader) at once: ``{"metrics": {name: array with leading axis n, for every
    name of lsc.result.METRICS}, "status": (n,) object array}``, ``"ok"`` or, for a member whose
    numbers the closed form cannot represent, ``"SimulationError: <message>"`` of its single
    solve. ``progress(k)`` (optional) is advanced by ``n`` at the end."""
    from ..result import METRICS

    P = batch_parameters(model, values)
    met = metrics(**P)
    n = P["m1"].size
    out = {name: np.asarray(met[name], float).reshape(n, -1) if where != "scene"
           else np.asarray(met[name], float) for name, (_, where) in METRICS.items()}
    status = np.full(n, "ok", dtype=object)
    bad = np.zeros(n, bool)
    for name, value in out.items():
        if name != "failure_time":   # (NaN there: never failed)
            bad |= ~np.all(np.isfinite(value.reshape(n, -1)), axis=1)
    solve_alone(solve, model, values, np.flatnonzero(bad), out, status)
    if progress is not None:
        progress(n)
    return {"metrics": out, "status": status}
