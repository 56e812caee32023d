"""The parameters of a sensitivity study: which dotted scene paths can be differentiated, their
names, values and units (:func:`default_params`, :func:`_describe`); see
:mod:`lsc.analysis.sensitivity`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..laws import law_class
from ..scene import UNITS, Damping, Hysteresis, Restitution, Scene, UnloadingStiffness
from ._common import read_path, split_path

__all__ = ["default_params"]


def _canonical(path) -> str:
    """``"vehicles[0].speed"`` → ``"vehicles.0.speed"``."""
    return ".".join(p for p in split_path(str(path)) if p != "")


@dataclass
class _Param:
    path: str
    label: str
    value: float
    unit: str
    kind: str  # a key of the scene's UNITS


def default_params(scene) -> list[str]:
    """The default parameters of :func:`sensitivity` for ``scene`` (dotted paths)."""
    sc = Scene.load(scene)
    src = sc.source
    out = []
    for i, v in enumerate(sc.vehicles):
        given = src.get("vehicles", [{}] * sc.n_vehicles)[i] if src else {}
        out.append(f"vehicles.{i}.{'mass' if 'mass' in given else 'weight'}")
        if not (v.brake is not None and v.speed == 0):  # braked at rest: stick-slip, no derivative
            out.append(f"vehicles.{i}.speed")
    for k, c in enumerate(sc.contacts):
        spec = (src.get("contacts") or [{}] * len(sc.contacts))[k] if src else {}
        law = c.law
        if isinstance(law, Hysteresis):
            lspec = spec.get("loading", {}) if isinstance(spec, dict) else {}
            linear = isinstance(lspec, dict) and "stiffness" in lspec and "scale" not in lspec
            out.append(f"contacts.{k}.loading.{'stiffness' if linear else 'scale'}")
            if isinstance(law.unloading, Restitution):
                out.append(f"contacts.{k}.unloading.restitution")
            elif isinstance(law.unloading, UnloadingStiffness):
                out.append(f"contacts.{k}.unloading.stiffness")
        elif isinstance(law, Damping):
            out += [f"contacts.{k}.{key}" for key in _damping_defaults(law)]
    for i, v in enumerate(sc.vehicles):
        if v.brake is not None:
            out.append(f"vehicles.{i}.brake.mu")
    return out


def _damping_defaults(law: Damping) -> list[str]:
    """The default keys of a spring–dashpot contact: its stiffness, its restitution or its
    damping (and Brach's c2), and any key of its own its law declares and its scene gives."""
    keys = ["stiffness"]
    if law.restitution is not None:
        keys.append("restitution")
    else:
        keys += ["damping"] + (["damping_restitution"] if law.damping_restitution is not None
                               else [])
    cls = law_class(law.name)
    declared = [p.key for p in getattr(cls, "params_declared", ())]
    own = [key for key in declared
           if key not in Damping.__dataclass_fields__ and cls.value(law, key) is not None]
    return [key for key in keys + own if key in declared]


def _closing_scale(sc: Scene) -> float:
    v = sc.speeds
    return float(max(np.max(np.abs(np.diff(v))), np.max(np.abs(v)), 1e-300))


def _describe(sc: Scene, path: str) -> _Param:
    """Value, unit and label of a parameter path (SceneError if it is not differentiable)."""
    parts = path.split(".")
    bad = SceneError(path, "not a differentiable parameter; accepted: vehicles.I.mass | weight | "
                           "speed | brake.mu | brake.mu_static, contacts.K.gap, contacts.K.loading."
                           "stiffness | scale, contacts.K.unloading.restitution | stiffness, and "
                           "for the damping laws contacts.K.stiffness | restitution | damping | "
                           "damping_restitution | exponent")
    if len(parts) < 3 or parts[0] not in ("vehicles", "contacts") or not parts[1].isdigit():
        raise bad
    i, rest = int(parts[1]), tuple(parts[2:])
    units = UNITS[sc.units]
    if parts[0] == "vehicles":
        if i >= sc.n_vehicles:
            raise SceneError(path, f"the scene has {sc.n_vehicles} vehicles (index 0..{sc.n_vehicles - 1})")
        v = sc.vehicles[i]
        name = v.name
        if rest == ("mass",):
            return _Param(path, f"{name} mass", v.mass, units["mass"], "mass")
        if rest == ("weight",):
            try:
                W = read_path(sc, path)
            except SceneError:
                W = v.mass * sc.g
            return _Param(path, f"{name} weight", W, units["force"], "force")
        if rest == ("speed",):
            if v.brake is not None and v.speed == 0:
                raise SceneError(path, f"{name} stands braked: at zero speed it sticks, at any "
                                       "other it slides, so the crash is not differentiable with "
                                       "respect to its speed there; leave it out (or give it a "
                                       "speed)")
            return _Param(path, f"{name} speed", v.speed, units["velocity"], "velocity")
        if rest in (("brake", "mu"), ("brake", "mu_static")):
            if v.brake is None:
                raise SceneError(path, f"vehicle {i} ({name}) has no brake")
            val = v.brake.mu if rest[1] == "mu" else v.brake.mu_static
            return _Param(path, f"{name} {'mu' if rest[1] == 'mu' else 'mu_static'}", val, "",
                          "dimensionless")
        raise bad
    K = len(sc.contacts)
    if i >= K:
        raise SceneError(path, f"the scene has {K} contact{'s' if K > 1 else ''} (index 0..{K - 1})")
    c = sc.contacts[i]
    law = c.law
    tag = f"contact {i}" if K > 1 else "contact"
    if rest == ("gap",):
        if c.gap <= 0:
            raise SceneError(path, f"{tag} touches at the start (gap 0): a gap cannot shrink "
                                   "below zero, so its derivative there is one-sided; give a gap > 0")
        return _Param(path, f"{tag} gap", c.gap, units["length"], "length")
    if isinstance(law, Hysteresis):
        spec = sc.source["contacts"][i] if sc.source else {}
        lspec = spec.get("loading", {})
        if rest == ("loading", "stiffness"):
            if not (isinstance(lspec, dict) and "stiffness" in lspec):
                raise SceneError(path, f"{tag}'s loading curve is not given by a stiffness: use "
                                       f"contacts.{i}.loading.scale (its force scale factor)")
            return _Param(path, f"{tag} loading stiffness", read_path(sc, path),
                          units["stiffness"], "stiffness")
        if rest == ("loading", "scale"):
            val = float(read_path(sc, path)) if isinstance(lspec, dict) and "scale" in lspec else 1.0
            return _Param(path, f"{tag} loading force scale", val, "", "dimensionless")
        if rest == ("unloading", "restitution"):
            if not isinstance(law.unloading, Restitution):
                raise SceneError(path, f"{tag} unloads by a stiffness or a table, not a restitution")
            return _Param(path, f"{tag} restitution", law.unloading.e, "", "dimensionless")
        if rest == ("unloading", "stiffness"):
            if not isinstance(law.unloading, UnloadingStiffness):
                raise SceneError(path, f"{tag} does not unload by a stiffness")
            return _Param(path, f"{tag} unloading stiffness", law.unloading.stiffness,
                          units["stiffness"], "stiffness")
        raise bad
    return _declared(sc, path, i, ".".join(rest), tag, bad)


#: Labels of the damping laws' keys that read better than the key (``{tag}``: the contact,
#: ``{name}``: its law).
_LABELS = {"restitution": "{tag} restitution", "exponent": "{tag} exponent",
           "damping_restitution": "{tag} {name} c2"}


def _declared(sc: Scene, path: str, i: int, key: str, tag: str, bad: SceneError) -> _Param:
    """A key contact ``i``'s law declares (``params_declared``), with its value, unit and label;
    ``bad`` if it declares no such key."""
    spec = sc.contacts[i].law
    cls = law_class(spec.name)
    declared = {p.key: p for p in getattr(cls, "params_declared", ())}
    if key not in declared:
        raise bad
    values = {k: cls.value(spec, k) for k in declared}
    if values[key] is None:
        given = [k for k in getattr(cls, "choice", ((), ""))[0] if values.get(k) is not None]
        raise SceneError(path, f"{tag}'s {spec.name} law is given by "
                               f"{'its ' + given[0] if given else 'other keys'}, not its {key}")
    kind = declared[key].kind_for(values)
    label = _LABELS.get(key, "{tag} {name} {key}").format(tag=tag, name=spec.name, key=key)
    return _Param(path, label, float(values[key]), UNITS[sc.units].get(kind, ""), kind)
