"""Scene parameters as numbers of the model: which dotted scene paths map straight onto the
model's numeric parameters (:attr:`lsc.model.HybridModel.params`), and batches of them.

A sweep, a Monte Carlo study or a fit changes scene values by their dotted paths
(``vehicles.0.speed``, ``contacts.0.loading.stiffness``, ...). A path maps onto the model's
numbers without re-loading the scene when it is a vehicle's speed, mass or weight, a contact's
gap, or a key its contact law declares (:attr:`~lsc.laws.HysteresisLaw.params_declared`): the law
then builds its numbers from the changed values itself (its ``numbers``). :func:`batch_params`
builds the whole batch from every swept path at once; :func:`setter` writes one path into a batch
of parameters (:func:`batched`); other paths are set through :meth:`lsc.Scene.with_values`,
member by member.
"""

from __future__ import annotations

import numpy as np

from .errors import SceneError
from .laws import law_class, make_law
from .scene import Scene

__all__ = ["read_back", "setter", "batched", "batch_params", "numbers_at", "tangent"]

_VEHICLE_KEYS = ("speed", "mass", "weight")


def _split(path: str) -> list[str]:
    return path.replace("[", ".").replace("]", "").split(".")


def _locate(scene: Scene, path: str):
    """``("vehicle", i, key)``, ``("gap", k, None)``, ``("law", k, key)`` for a path that maps
    onto model numbers of ``scene`` (``key``: the law's declared key, e.g.
    ``"unloading.restitution"``), else ``None``."""
    parts = _split(path)
    try:
        if parts[0] == "vehicles" and len(parts) == 3 and parts[2] in _VEHICLE_KEYS:
            i = int(parts[1])
            return ("vehicle", i, parts[2]) if 0 <= i < scene.n_vehicles else None
        if parts[0] == "contacts" and len(parts) >= 3:
            k = int(parts[1])
            if not 0 <= k < len(scene.contacts):
                return None
            key = ".".join(parts[2:])
            return ("gap", k, None) if key == "gap" else ("law", k, key)
    except ValueError:
        return None
    return None


def _law(scene: Scene, k: int):
    """The law object of contact ``k`` of ``scene``."""
    c = scene.contacts[k]
    m = scene.masses
    return make_law(c, float(m[k] * m[k + 1] / (m[k] + m[k + 1])))


def read_back(scene: Scene, path: str) -> float:
    """The number a fast path sets, as the loader stored it (used for unit strings)."""
    where = _locate(scene, path)
    if where is not None:
        what, i, key = where
        if what == "vehicle":
            veh = scene.vehicles[i]
            return {"speed": veh.speed, "mass": veh.mass, "weight": veh.mass * scene.g}[key]
        if what == "gap":
            return scene.contacts[i].gap
        spec = scene.contacts[i].law
        value = law_class(spec.name).value(spec, key)
        if value is not None:
            return float(value)
    raise SceneError(path, "values with units are accepted only for speeds, masses, weights, gaps "
                           "and the numbers the contact laws declare (stiffnesses, restitutions, "
                           "dampings, ...); give plain numbers in the scene's units")


def _fast(scene: Scene, where, laws) -> bool:
    """Whether a located path maps onto model numbers without re-loading the scene."""
    what, k, key = where
    return what != "law" or laws[k].sweepable(key)


def _laws(scene: Scene) -> list:
    return [_law(scene, k) for k in range(len(scene.contacts))]


def setter(scene: Scene, path: str):
    """A function ``(params_batch, values)`` that writes one swept path into the batched model
    parameters, or ``None`` if the path needs a full re-load per member.

    It writes the numbers that path moves: a vehicle's or a gap's directly; of a contact law,
    those of its numbers (:meth:`~lsc.laws.HysteresisLaw.numbers`) that the change moves, so the
    setters of several paths compose. A law whose numbers mix its keys with the vehicles' masses
    (Kelvin's ζ = c / (2√(kμ)) of a damping c) has none, and neither do the masses then:
    :func:`batch_params` builds such a law from all of its changes together."""
    where = _locate(scene, path)
    laws = _laws(scene)
    if where is None or not _fast(scene, where, laws):
        return None
    what, i, key = where
    if what == "vehicle":
        if key != "speed" and any(law.depends_on_mass for law in laws):
            return None
        return lambda p, values: _write(scene, laws, p, {path: np.asarray(values, float)})
    if what == "gap":
        return lambda p, values: p["gap"].__setitem__((slice(None), i), values)
    law = laws[i]
    if law.depends_on_mass:
        return None

    def contact(p, values):
        n = p["m"].shape[0]
        mu = _reduced(p["m"])[:, i]
        new = _member_axis(law, law.numbers({key: np.asarray(values, float)}, mu, np), n)
        c = p["contacts"][i]
        for name, arr in new.items():
            base = np.asarray(law.params[name], float)
            if not np.array_equal(arr, np.broadcast_to(base, arr.shape), equal_nan=True):
                c[name] = arr
    return contact


def _reduced(m: np.ndarray) -> np.ndarray:
    """Reduced masses of the pairs (n, K) from the masses (n, N)."""
    return m[:, :-1] * m[:, 1:] / (m[:, :-1] + m[:, 1:])


def _member_axis(law, numbers: dict, n: int) -> dict:
    """A law's numbers with a leading member axis of length ``n``: an array shaped as the law's
    own number is repeated, one with the member axis already (a changed number) is kept."""
    out = {}
    for name, v in numbers.items():
        v = np.asarray(v, float)
        base = np.shape(law.params[name])
        out[name] = np.array(v) if v.shape == (n,) + base else np.repeat(
            np.broadcast_to(v, base)[None, ...], n, axis=0)
    return out


def _write(scene: Scene, laws: list, p: dict, values: dict) -> None:
    """Write every swept path of ``values`` into the batch ``p``: vehicle and gap numbers
    directly, then each contact law whose keys changed, or whose numbers depend on the masses
    when a mass changed, rebuilt from all of its changes at once (its ``numbers``)."""
    changes = {k: {} for k in range(len(laws))}
    masses = False
    for path, vals in values.items():
        what, i, key = _locate(scene, path)
        if what == "vehicle":
            if key == "speed":
                p["v0"][:, i] = vals
            else:
                p["m"][:, i] = vals if key == "mass" else vals / scene.g
                masses = True
        elif what == "gap":
            p["gap"][:, i] = vals
        else:
            changes[i][key] = vals
    n = p["m"].shape[0]
    mu = _reduced(p["m"])
    for k, law in enumerate(laws):
        if changes[k] or (masses and law.depends_on_mass):
            p["contacts"][k] = _member_axis(law, law.numbers(changes[k], mu[:, k], np), n)


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
    the scene re-loaded per member. Each contact law is built from all of its changed values at
    once (and again from the members' masses where its numbers depend on them)."""
    scene = model.scene
    laws = model.laws
    where = {path: _locate(scene, path) for path in values}
    if any(w is None or not _fast(scene, w, laws) for w in where.values()):
        return None
    n = len(next(iter(values.values()))) if values else 1
    p = batched(model.params, n)
    _write(scene, laws, p, {path: np.asarray(vals, float) for path, vals in values.items()})
    return p


# ---------------------------------------------------------------------------- tangents
def _effect_at(model, path: str):
    """``(j, key)`` for ``vehicles.I.<table>.<key>`` naming a declared key of vehicle ``I``'s
    effect ``model.brakes[j]``, else ``None``."""
    parts = _split(path)
    if len(parts) != 4 or parts[0] != "vehicles" or not parts[1].isdigit():
        return None
    for j, eff in enumerate(model.brakes):
        if eff.i == int(parts[1]) and eff.table == parts[2] and parts[3] in eff.keys():
            return j, parts[3]
    return None


def _effect_values(model, j: int, key: str, x) -> dict:
    """Effect ``j``'s key values with ``key`` at ``x``; a key the scene left to its declared
    default that depends on other keys (a brake's ``mu_static``, ``mu`` by default) follows."""
    eff = model.brakes[j]
    src = model.scene.source or {}
    given = (src.get("vehicles") or [{}] * (eff.i + 1))[eff.i].get(eff.table, {})
    spec = eff.spec
    values = {p.key: (spec[p.key] if isinstance(spec, dict) or hasattr(spec, "keys")
                      else getattr(spec, p.key)) for p in eff.params_declared}
    values[key] = x
    for p in eff.params_declared:
        if p.key != key and callable(p.default) and p.key not in given:
            values[p.key] = p.default(values)
    return values


def _put(xp, arr, i: int, x):
    """``arr`` with entry ``i`` set to ``x`` (array code)."""
    arr = xp.asarray(arr, float)
    return xp.where(xp.arange(arr.shape[0]) == i, x, arr)


def numbers_at(model, path: str, x, xp=np) -> dict:
    """The model's numbers (:attr:`lsc.model.HybridModel.params`' structure) with the scene
    value at ``path`` set to ``x`` (a scalar, scene units), built by the declared construction:
    a vehicle's or a gap's number directly (with every law whose numbers depend on the masses
    rebuilt), a contact law's by its :meth:`~lsc.laws.HysteresisLaw.numbers`, a vehicle effect's
    by its ``build``. Array code: traceable by JAX (``xp = jax.numpy``); raises
    :class:`~lsc.SceneError` for a path that does not map onto the model's numbers."""
    scene, laws, p0 = model.scene, model.laws, model.params
    p = {**p0, "contacts": list(p0["contacts"]), "brakes": list(p0["brakes"])}
    where = _locate(scene, path)
    effect = _effect_at(model, path) if where is None else None
    if where is None and effect is None:
        raise SceneError(path, "does not map onto the model's numbers: accepted are a vehicle's "
                               "speed, mass or weight, a declared key of its effects, a "
                               "contact's gap, and the keys its contact law declares")
    if effect is not None:
        j, key = effect
        eff = model.brakes[j]
        p["brakes"][j] = eff.build(_effect_values(model, j, key, x), scene.g, xp)
        return p
    what, i, key = where
    if what == "gap":
        p["gap"] = _put(xp, p0["gap"], i, x)
    elif what == "vehicle" and key == "speed":
        p["v0"] = _put(xp, p0["v0"], i, x)
    elif what == "vehicle":
        p["m"] = _put(xp, p0["m"], i, x if key == "mass" else x / scene.g)
        m = p["m"]
        for k, law in enumerate(laws):
            if law.depends_on_mass and i in (k, k + 1):
                p["contacts"][k] = law.numbers({}, m[k] * m[k + 1] / (m[k] + m[k + 1]), xp)
    else:
        law = laws[i]
        if not law.sweepable(key):
            raise SceneError(path, f"contact {i}'s {law.name} law builds its numbers for this "
                                   "key only by re-loading the scene (a loading curve spliced at "
                                   "a bumper failure moves the failure point with it), so it has "
                                   "no tangent: use method=\"finite-difference\"")
        m = np.asarray(p0["m"], float)
        p["contacts"][i] = law.numbers({key: x}, m[i] * m[i + 1] / (m[i] + m[i + 1]), xp)
    return p


def tangent(model, path: str, value: float) -> dict:
    """``∂ model.params / ∂ path`` at ``value`` (the scene's value at ``path``, scene units): a
    pytree of NumPy arrays of :attr:`lsc.model.HybridModel.params`' structure.

    The derivative of :func:`numbers_at` by forward-mode autodiff (``jax.jvp``); a number a law
    builds by a root find on NumPy (a target restitution) carries the derivative the law
    declares with it (:func:`lsc.laws.damping.traced_root`). Needs JAX."""
    import jax
    import jax.numpy as jnp

    def numbers(x):
        return numbers_at(model, path, x, jnp)

    with jax.enable_x64(True):
        _, t = jax.jvp(numbers, (jnp.asarray(float(value)),), (jnp.asarray(1.0),))
        return jax.tree_util.tree_map(lambda a: np.array(a, float), t)
