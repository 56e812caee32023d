"""Inputs of the exact backend's vectorised stepper (:func:`.batch.solve_arrays`): validated
float arrays over ``B`` two-vehicle scenes, from a dict of arrays (:func:`_batch_inputs`), from
scenes (:func:`arrays_of`), or from a model and the values swept over its scene paths
(:func:`arrays_of_model`, the path of the backend contract's ``solve_batch``).
"""

from __future__ import annotations

import numpy as np

from ...scene import Restitution, UnloadingStiffness


def _as_rows(x, B, name, n_min=1):
    a = np.asarray(x, float)
    if a.ndim == 1:
        a = np.broadcast_to(a, (B, a.size))
    if a.ndim != 2 or a.shape[0] != B or a.shape[1] < n_min:
        raise ValueError(f"{name} must be an array (B, n) with n >= {n_min} (B = {B}), "
                         f"got shape {np.shape(x)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return np.ascontiguousarray(a)


def _batch_inputs(params: dict) -> dict:
    """Validated, broadcast float arrays from the :func:`solve_arrays` parameters."""
    known = {"m1", "m2", "v1", "v2", "gap", "stiffness", "load_d", "load_f", "load_end_slope",
             "e", "unload_stiffness", "unload_d", "unload_f", "g", "failure_force"}
    braking = {k for k in params if "mu" in k or "brake" in k}
    if braking:
        raise ValueError(f"braking ({', '.join(sorted(braking))}) is not batched: solve_arrays has "
                         "no friction forces; solve braked scenes one by one with exact.solve")
    unknown = set(params) - known
    if unknown:
        raise ValueError(f"unknown batch parameter(s) {sorted(unknown)}; accepted: {sorted(known)}")
    for k in ("m1", "m2", "v1", "v2"):
        if k not in params:
            raise ValueError(f"batch parameter {k!r} is required")
    base = [np.asarray(params[k], float) for k in ("m1", "m2", "v1", "v2")]
    base.append(np.asarray(params.get("gap", 0.0), float))
    m1, m2, v1, v2, gap = (np.ascontiguousarray(a, float) for a in np.broadcast_arrays(*base))
    if m1.ndim != 1:
        raise ValueError("m1, m2, v1, v2, gap must be scalars or 1-D arrays")
    B = m1.size
    if not (np.all(m1 > 0) and np.all(m2 > 0) and np.all(np.isfinite(m1 + m2))):
        raise ValueError("masses must be positive and finite")
    if not (np.all(np.isfinite(v1 - v2)) and np.all(gap >= 0) and np.all(np.isfinite(gap))):
        raise ValueError("speeds must be finite and gaps finite and >= 0")
    out = {"m1": m1, "m2": m2, "v1": v1, "v2": v2, "gap": gap, "B": B}
    # loading
    if "stiffness" in params:
        if "load_d" in params or "load_f" in params:
            raise ValueError("give either stiffness or load_d/load_f, not both")
        k = np.broadcast_to(np.asarray(params["stiffness"], float), (B,))
        if not np.all((k > 0) & np.isfinite(k)):
            raise ValueError("stiffness must be positive and finite")
        out.update(load_d=np.zeros((B, 1)), load_f=np.zeros((B, 1)), end=k.copy())
    else:
        if "load_d" not in params or "load_f" not in params:
            raise ValueError("the loading is stiffness (B,) or load_d, load_f (B, n)")
        end = params.get("load_end_slope")
        d = _as_rows(params["load_d"], B, "load_d", 1 if end is not None else 2)
        f = _as_rows(params["load_f"], B, "load_f", d.shape[1])
        if f.shape != d.shape:
            raise ValueError("load_d and load_f must have the same shape")
        if not (np.all(d[:, 0] == 0) and np.all(np.diff(d, axis=1) > 0) and np.all(f >= 0)):
            raise ValueError("each loading table starts at D = 0 with strictly increasing "
                             "deformations and forces >= 0")
        if end is not None:
            end = np.broadcast_to(np.asarray(end, float), (B,)).copy()
            if not np.all(np.isfinite(end)):
                raise ValueError("load_end_slope must be finite (give None for tables that end)")
        out.update(load_d=d, load_f=f, end=end)
    # unloading
    kinds = [k for k in ("e", "unload_stiffness", "unload_d") if k in params]
    if len(kinds) != 1:
        raise ValueError("give exactly one unloading rule: e (B,), unload_stiffness (B,) or "
                         "unload_d, unload_f (B, n) in time order")
    if kinds[0] == "e":
        e = np.broadcast_to(np.asarray(params["e"], float), (B,)).copy()
        if not np.all((e >= 0) & (e <= 1)):
            raise ValueError("restitution e must be in [0, 1]")
        out["e"] = e
    elif kinds[0] == "unload_stiffness":
        su = np.broadcast_to(np.asarray(params["unload_stiffness"], float), (B,)).copy()
        if not np.all((su > 0) & np.isfinite(su)):
            raise ValueError("unload_stiffness must be positive and finite")
        out["su"] = su
    else:
        ud = _as_rows(params["unload_d"], B, "unload_d", 2)
        uf = _as_rows(params.get("unload_f"), B, "unload_f", 2)
        if uf.shape != ud.shape:
            raise ValueError("unload_d and unload_f must have the same shape")
        if not (np.all(np.diff(ud, axis=1) < 0) and np.all(uf[:, 0] > 0) and np.all(uf[:, -1] == 0)
                and np.all(uf >= 0)):
            raise ValueError("each unloading table runs in time order from (D0, F0 > 0) to zero "
                             "force with strictly decreasing deformations")
        out.update(unload_d=ud, unload_f=uf)
    g = params.get("g")
    out["g"] = None if g is None else np.broadcast_to(np.asarray(g, float), (B,))
    ff = params.get("failure_force")
    if ff is not None:
        ff = np.broadcast_to(np.asarray(ff, float), (B,)).copy()
        if np.any(ff <= 0):
            raise ValueError("failure_force must be positive (inf or nan: none)")
        ff[np.isnan(ff)] = np.inf
    out["failure_force"] = ff
    return out


def arrays_of(scenes: list) -> dict:
    """:func:`solve_arrays` parameters from scenes the exact backend applies to (checked by
    :func:`lsc.solvers.exact.batch_params`), whose loading curves have equal numbers of points
    (all extending or none) and whose unloading rules are of one kind (tables of equal length)."""
    for i, sc in enumerate(scenes):
        if any(v.brake is not None for v in sc.vehicles):
            raise ValueError(f"scene {i}: braked scenes are not batched (the exact batch has no "
                             "friction forces): solve each with exact.solve")
        fail = sc.contacts[0].failure
        if fail is not None and fail.post_failure is not None:
            raise ValueError(f"scene {i}: scenes with a post-failure curve are not batched "
                             "(the exact batch has no failure point): solve each with exact.solve")
    laws = [sc.contacts[0].law for sc in scenes]
    curves = [law.loading for law in laws]
    if len({c.d.size for c in curves}) != 1 or len({c.extends for c in curves}) != 1:
        raise ValueError("the loading curves must have equal numbers of points, all extending "
                         "or none")
    kinds = {type(law.unloading) for law in laws}
    if len(kinds) != 1:
        raise ValueError("the unloading rules must all be of one kind")
    out = {"m1": [sc.masses[0] for sc in scenes], "m2": [sc.masses[1] for sc in scenes],
           "v1": [sc.speeds[0] for sc in scenes], "v2": [sc.speeds[1] for sc in scenes],
           "gap": [sc.contacts[0].gap for sc in scenes], "g": [sc.g for sc in scenes],
           "load_d": np.stack([c.d for c in curves]), "load_f": np.stack([c.f for c in curves])}
    if curves[0].extends:
        out["load_end_slope"] = [c.end_slope for c in curves]
    fails = [sc.contacts[0].failure for sc in scenes]
    if any(f is not None for f in fails):
        out["failure_force"] = [np.inf if f is None else f.force for f in fails]
    kind = kinds.pop()
    if kind is Restitution:
        out["e"] = [law.unloading.e for law in laws]
    elif kind is UnloadingStiffness:
        out["unload_stiffness"] = [law.unloading.stiffness for law in laws]
    else:
        if len({law.unloading.d.size for law in laws}) != 1:
            raise ValueError("the unloading tables must have equal numbers of points")
        out["unload_d"] = np.stack([np.asarray(law.unloading.d, float) for law in laws])
        out["unload_f"] = np.stack([np.asarray(law.unloading.f, float) for law in laws])
    return {k: np.asarray(v, float) for k, v in out.items()}


def arrays_of_model(model, p: dict) -> dict:
    """:func:`solve_arrays` parameters from ``model`` (two vehicles, IF-D) and its batched
    parameters ``p`` (:func:`lsc.parameters.batch_params`, leading axis ``n``): loading,
    unloading and failure force as the model's own numbers, member by member."""
    n = p["m"].shape[0]
    scene, law, c = model.scene, model.laws[0], p["contacts"][0]
    P = {"m1": p["m"][:, 0], "m2": p["m"][:, 1], "v1": p["v0"][:, 0], "v2": p["v0"][:, 1],
         "gap": p["gap"][:, 0], "g": np.full(n, scene.g)}
    if law.n_load == 1 and law.extends and scene.contacts[0].law.loading.f[0] == 0:
        P["stiffness"] = c["ls"][:, 0]
    else:
        P["load_d"], P["load_f"] = c["ld"][:, : law.n_load], c["lf"][:, : law.n_load]
        if law.extends:
            P["load_end_slope"] = c["ls"][:, law.n_load - 1]
    if law.unload_kind == "restitution":
        P["e"] = c["e"]
    elif law.unload_kind == "stiffness":
        P["unload_stiffness"] = c["su"]
    else:
        unl = scene.contacts[0].law.unloading
        P["unload_d"] = np.tile(np.asarray(unl.d, float), (n, 1))
        P["unload_f"] = np.tile(np.asarray(unl.f, float), (n, 1))
    fail = scene.contacts[0].failure
    if fail is not None:
        P["failure_force"] = np.full(n, fail.force)
    return P
