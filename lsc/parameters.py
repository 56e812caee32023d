"""Scene parameters as numbers of the model: which dotted scene paths map straight onto the
model's numeric parameters (:attr:`lsc.model.HybridModel.params`), and batches of them.

A sweep, a Monte Carlo study or a fit changes scene values by their dotted paths
(``vehicles.0.speed``, ``contacts.0.loading.stiffness``, ...). Where a path maps onto the model's
numbers without re-loading the scene, :func:`setter` writes it into a batch of parameters
(:func:`batched`), and :func:`batch_params` builds the whole batch; other paths are set through
:meth:`lsc.Scene.with_values`, member by member.
"""

from __future__ import annotations

import numpy as np

from .errors import SceneError
from .scene import Restitution, Scene, UnloadingStiffness

__all__ = ["read_back", "setter", "batched", "batch_params"]


def read_back(scene: Scene, path: str) -> float:
    """The number a fast path sets, as the loader stored it (used for unit strings)."""
    parts = path.replace("[", ".").replace("]", "").split(".")
    if parts[0] == "vehicles" and len(parts) == 3:
        veh = scene.vehicles[int(parts[1])]
        return {"speed": veh.speed, "mass": veh.mass, "weight": veh.mass * scene.g}[parts[2]]
    if parts[0] == "contacts" and len(parts) >= 3:
        c = scene.contacts[int(parts[1])]
        if parts[2] == "gap":
            return c.gap
        if parts[2:] == ["unloading", "restitution"]:
            return c.law.unloading.e
        if parts[2:] == ["unloading", "stiffness"]:
            return c.law.unloading.stiffness
        if parts[2:] == ["loading", "stiffness"]:
            return c.law.loading.stiffness
        if parts[2:] == ["loading", "scale"]:
            return float(scene.source["contacts"][int(parts[1])]["loading"].get("scale", 1.0))
    raise SceneError(path, "values with units are accepted only for speeds, masses, weights, gaps "
                           "and stiffnesses; give plain numbers in the scene's units")


def setter(scene: Scene, path: str):
    """A function ``(params_batch, values)`` that writes a swept path into the batched model
    parameters, or ``None`` if the path needs a full re-load per member."""
    parts = path.replace("[", ".").replace("]", "").split(".")
    try:
        if parts[0] == "vehicles" and len(parts) == 3:
            i = int(parts[1])
            if not 0 <= i < scene.n_vehicles:
                return None
            if parts[2] == "speed":
                return lambda p, v: p["v0"].__setitem__((slice(None), i), v)
            if parts[2] == "mass":
                return lambda p, v: p["m"].__setitem__((slice(None), i), v)
            if parts[2] == "weight":
                return lambda p, v: p["m"].__setitem__((slice(None), i), v / scene.g)
        if parts[0] == "contacts" and len(parts) >= 3:
            k = int(parts[1])
            if not 0 <= k < len(scene.contacts):
                return None
            law = scene.contacts[k].law
            tail = parts[2:]
            fail = scene.contacts[k].failure
            if tail[0] == "loading" and fail is not None and fail.post_failure is not None:
                return None  # the failure point moves with the loading curve: re-load
            if tail == ["gap"]:
                return lambda p, v: p["gap"].__setitem__((slice(None), k), v)
            if tail == ["unloading", "restitution"] and isinstance(law.unloading, Restitution):
                return lambda p, v: p["contacts"][k].__setitem__("e", v)
            if tail == ["unloading", "stiffness"] and isinstance(law.unloading, UnloadingStiffness):
                return lambda p, v: p["contacts"][k].__setitem__("su", v)
            if tail == ["loading", "stiffness"] and law.loading.is_linear:
                return lambda p, v: p["contacts"][k]["ls"].__setitem__((slice(None), 0), v)
            if tail == ["loading", "scale"] and hasattr(law, "loading"):
                base = float(scene.source["contacts"][k]["loading"].get("scale", 1.0))

                def scale(p, v, k=k, base=base):
                    c = p["contacts"][k]
                    f = (np.asarray(v, float) / base)[:, None]
                    for key in ("lf", "ls", "le"):
                        c[key] = c[key] * f
                return scale
    except (ValueError, AttributeError, KeyError, TypeError):
        return None
    return None


def batched(params, n: int):
    """The model's parameter pytree (dicts and lists of arrays) with a leading member axis of
    length ``n`` on every array."""
    if isinstance(params, dict):
        return {k: batched(v, n) for k, v in params.items()}
    if isinstance(params, (list, tuple)):
        return [batched(v, n) for v in params]
    x = np.asarray(params, float)
    return np.repeat(x[None, ...], n, axis=0)


def batch_params(model, values: dict):
    """The model's parameters (a pytree) with a leading member axis, every swept path of
    ``values`` (dotted path → (n,) array in scene units) written in; ``None`` if some path needs
    the scene re-loaded per member (no :func:`setter`)."""
    setters = {path: setter(model.scene, path) for path in values}
    if any(s is None for s in setters.values()):
        return None
    n = len(next(iter(values.values()))) if values else 1
    p = batched(model.params, n)
    for path, vals in values.items():
        setters[path](p, np.asarray(vals, float))
    return p
