"""The autodiff path of :func:`lsc.analysis.sensitivity`: each parameter's tangent, the derivative
of the model's numbers with respect to it (:func:`_tangent`), and the derivatives of the metrics
through the diffrax solve (:func:`_by_diffrax`, with
:func:`lsc.solvers.diffrax_ode.metrics_jacobian`)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError
from ..scene import Damping, Scene
from ._sensitivity_params import _Param

__all__: list[str] = []


# ---------------------------------------------------------------------------- tangents
def _kelvin_dlne_dzeta(z: float) -> float:
    """``d ln e / dζ`` of the Kelvin restitution ``ln e = -2ζ arccos ζ / √(1-ζ²)``."""
    if abs(z - 1.0) < 1e-6:  # the two branches meet smoothly at ζ = 1: difference across it
        from ..contact import kelvin_restitution
        h = 1e-4
        return float((np.log(kelvin_restitution(z + h)) - np.log(kelvin_restitution(z - h))) / (2 * h))
    if z < 1:
        s2 = 1.0 - z * z
        return -2.0 * (math.acos(z) / s2 ** 1.5 - z / s2)
    s2 = z * z - 1.0
    return -2.0 * (z / s2 - math.acosh(z) / s2 ** 1.5)


def _tangent(model, sc: Scene, prm: _Param):
    """``∂ model.params / ∂ prm`` as a pytree of NumPy arrays (model.params' structure)."""
    p = model.params
    T = _zeros(p)
    parts = prm.path.split(".")
    i, rest = int(parts[1]), tuple(parts[2:])
    if parts[0] == "vehicles":
        if rest in (("mass",), ("weight",)):
            dm = 1.0 if rest[0] == "mass" else 1.0 / sc.g
            T["m"][i] = dm
            _kelvin_mass(model, T, i, dm)
        elif rest == ("speed",):
            T["v0"][i] = 1.0
        else:  # brake
            j = [b.i for b in model.brakes].index(i)
            src = sc.source["vehicles"][i].get("brake", {}) if sc.source else {}
            if rest[1] == "mu":
                T["brakes"][j]["mu"] = np.asarray(1.0)
                if "mu_static" not in src:  # mu_static defaults to mu: it moves with it
                    T["brakes"][j]["mus"] = np.asarray(1.0)
            else:
                T["brakes"][j]["mus"] = np.asarray(1.0)
        return T
    cp, ct = p["contacts"][i], T["contacts"][i]
    law = sc.contacts[i].law
    if rest == ("gap",):
        T["gap"][i] = 1.0
    elif rest in (("loading", "stiffness"), ("loading", "scale")):
        fail = sc.contacts[i].failure
        if fail is not None and fail.post_failure is not None:
            raise SceneError(prm.path, "this contact goes on along a post-failure curve from the "
                             "point where its loading reaches the failure force, and that point "
                             "moves with the loading curve (the post-failure curve does not "
                             "scale): use method=\"finite-difference\"")
        # every force of the curve is proportional to the stiffness (or the scale), and so are
        # the slopes and the cumulative energies derived from them
        for key in ("lf", "ls", "le"):
            ct[key] = np.asarray(cp[key], float) / prm.value
    elif rest == ("unloading", "restitution"):
        ct["e"] = np.asarray(1.0)
    elif rest == ("unloading", "stiffness"):
        ct["su"] = np.asarray(1.0)
    elif rest == ("stiffness",):
        ct["k"] = np.asarray(1.0)
        if law.law == "kelvin" and law.restitution is None:  # ζ = c / (2√(kμ)), c held
            ct["zeta"] = np.asarray(-0.5 * float(cp["zeta"]) / law.stiffness)
    elif rest == ("restitution",):
        e = law.restitution
        if law.law == "kelvin":
            z = float(cp["zeta"])
            ct["zeta"] = np.asarray(1.0 / (e * _kelvin_dlne_dzeta(z)))  # e = 1: -1/π
        elif law.law == "hunt-crossley":  # a (1+e) = ln[(1+a)/(1-a e)]
            a = float(cp["a"])
            R_a = (1 + e) - 1 / (1 + a) - e / (1 - a * e)
            R_e = a - a / (1 - a * e)
            # at e = 1 (a = 0) the limit of a ≈ 3(1 - e²) / (2(1 + e³)): da/de = -3/2
            ct["a"] = np.asarray(-R_e / R_a if a > 1e-6 else -1.5)
        else:
            raise SceneError(prm.path, "Brach's law with a target restitution finds its c2 by "
                             "bisection inside the solve, which forward-mode autodiff cannot see "
                             "through: use method=\"finite-difference\"")
    elif rest == ("damping",):
        if law.law == "kelvin":  # ζ = c / (2√(kμ))
            ct["zeta"] = np.asarray(float(cp["zeta"]) / law.damping if law.damping > 0 else
                                    1.0 / (2.0 * math.sqrt(law.stiffness * _mu(model)[i])))
        elif law.law == "hunt-crossley":
            ct["alpha"] = np.asarray(1.0)
        else:
            ct["c1"] = np.asarray(1.0)
    elif rest == ("damping_restitution",):
        ct["c2"] = np.asarray(1.0)
    elif rest == ("exponent",):
        ct["n"] = np.asarray(1.0)
    return T


def _mu(model) -> np.ndarray:
    m = np.asarray(model.params["m"], float)
    return m[:-1] * m[1:] / (m[:-1] + m[1:])


def _kelvin_mass(model, T, i: int, dm: float) -> None:
    """A Kelvin damping given by its coefficient keeps ``c``: its ``ζ = c/(2√(kμ))`` moves with
    the pair's reduced mass ``μ``."""
    m = np.asarray(model.params["m"], float)
    mu = _mu(model)
    for k, law in enumerate(model.laws):
        if getattr(law, "name", "") != "kelvin" or law.spec.restitution is not None:
            continue
        if i not in (k, k + 1):
            continue
        other = m[k + 1] if i == k else m[k]
        dmu = (other / (m[k] + m[k + 1])) ** 2 * dm
        z = float(model.params["contacts"][k]["zeta"])
        T["contacts"][k]["zeta"] = np.asarray(float(T["contacts"][k]["zeta"]) - 0.5 * z / mu[k] * dmu)


def _zeros(tree):
    if isinstance(tree, dict):
        return {k: _zeros(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_zeros(v) for v in tree]
    return np.zeros(np.shape(tree))


# ---------------------------------------------------------------------------- diffrax (autodiff)
#: Below this restitution the IF-D unloading line is too narrow (``e² D_max``) for its derivative
#: in ``e`` to be accurate, and at ``e = 0`` there is none (the contact separates at once): the
#: derivative with respect to ``e`` is taken at this ``e`` (ΔV and the pulse of a two-vehicle
#: crash are linear in ``e``; the peaks do not depend on it).
_E_MIN = 1e-3


def _by_diffrax(sc, model, prms, *, integrator, rtol, atol, max_steps, max_events):
    """Values and derivatives of the metrics (and stats, and how they were computed) by
    forward-mode autodiff through the diffrax solve of ``model`` (the scene ``sc``), along the
    parameters ``prms``."""
    from ..solvers import diffrax_ode as dx

    dx.check_settings(integrator, rtol, atol, max_steps, max_events)
    for c in sc.contacts:
        if isinstance(c.law, Damping) and c.law.law == "brach" and c.law.restitution is not None:
            raise SceneError("method", "Brach's law with a target restitution finds its c2 by "
                             "bisection inside the solve, which forward-mode autodiff cannot see "
                             "through: use method=\"finite-difference\"")
    tangents = [_tangent(model, sc, prm) for prm in prms]
    opts = dict(integrator=integrator, rtol=rtol, atol=atol, max_steps=max_steps,
                max_events=max_events)
    values, derivs, stats = dx.metrics_jacobian(model, tangents, **opts)
    stats.update({"integrator": integrator, "rtol": rtol})
    # e near 0: see _E_MIN (the other derivatives stay those of the scene as given)
    low = [j for j, q in enumerate(prms)
           if q.path.endswith(".unloading.restitution") and q.value < _E_MIN]
    if low:
        p2 = _copy(model.params)
        for j in low:
            p2["contacts"][int(prms[j].path.split(".")[1])]["e"] = np.asarray(_E_MIN, float)
        _, derivs2, stats2 = dx.metrics_jacobian(model, tangents, params=p2, **opts)
        for k in derivs:
            derivs[k][..., low] = derivs2[k][..., low]
        stats["wall_time"] += stats2["wall_time"]
        stats["one_sided"] = [prms[j].path for j in low]
    how = f"forward-mode autodiff through the diffrax solve ({integrator}, rtol {rtol:g})"
    return values, derivs, stats, how


def _copy(tree):
    """A copy of a parameter pytree (dicts and lists copied, arrays shared)."""
    if isinstance(tree, dict):
        return {k: _copy(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_copy(v) for v in tree]
    return tree
