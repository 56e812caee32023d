"""Sensitivities: how much ΔV, peak acceleration and pulse duration change per unit change of each
input (mass or weight, speed, bumper stiffness, restitution, ...), at the scene as given.

``method="diffrax"`` (the default) differentiates the simulation itself: forward-mode automatic
differentiation (``jax.jacfwd``) through the compiled diffrax solve of :mod:`lsc.solvers.diffrax_ode`
— every integrator step, and every event. An event time depends on the parameters; the backend
locates each event by Newton's method on the step's interpolant and polishes it with one Newton
step on the integrator's own solution, so the tangent that comes out of the polish is the implicit
function theorem's ``dt*/dp = -(∂g/∂p) / ġ`` (``g`` the event function): the derivative of where
the event *is*, not of where the search happened to stop. Peaks are maxima: a peak reached at an
event (the IF-D peak at the common velocity, or at a table breakpoint) is differentiated through
that event; a peak inside a segment (damping laws) is the value at the located extremum, whose
derivative is the partial derivative there (the envelope theorem: ``dq/dt = 0`` at the argmax).
The derivatives are those of the numerical solution, accurate to about the solver tolerance
(``rtol``, default ``1e-12``); they are checked against finite differences of the exact backends
in the tests.

``method="finite-difference"`` computes the same derivatives by a fourth-order central difference
of :func:`lsc.solve` (any backend, default ``auto``: the closed form or the exact piecewise solve
where they apply) with each parameter set through :meth:`lsc.Scene.with_values`: no JAX needed,
and every law is supported (Brach's law with a target restitution only this way).

Parameters are dotted scene paths (``"vehicles.0.speed"``, as :func:`lsc.sweep` takes them).
The default set: each vehicle's ``weight`` (or ``mass``, as the scene gives it), each vehicle's
``speed``, each contact's loading ``stiffness`` (a linear curve) or force ``scale`` (a table,
CSV or series curve: every force of the curve times the factor), its unloading ``restitution``
(or unloading ``stiffness``); for the damping laws ``stiffness`` and ``restitution`` (or
``damping``); and each braked vehicle's ``brake.mu``. A weight derivative is per unit of weight
(``m = W/g``, at the scene's ``g``), a mass derivative per unit of mass. Derived quantities follow
the parameter as the scene loader would rebuild them: a table's slopes and cumulative energies
scale with its forces, a Kelvin damping ratio given by its coefficient ``c`` changes with ``k`` and
the masses, a ``brake.mu`` without ``mu_static`` moves the static coefficient with it.

Where the crash is not differentiable the parameter is refused, with the reason: the speed of a
braked vehicle at rest (it sticks at zero speed and slides at any other), a gap of zero (it cannot
shrink), Brach's law given a target restitution (autodiff only). At ``e = 0`` (no rebound at all)
the derivative with respect to an IF-D restitution is one-sided; below ``e = 1e-3`` it is taken
at ``e = 1e-3`` (a two-vehicle crash's ΔV and pulse are linear in ``e``).

The normalised sensitivity (elasticity) ``(∂M/∂p) p / M`` is the percent change of a metric per
percent change of a parameter: what :func:`lsc.plots.tornado` ranks. Where a parameter is zero (a
target at rest, ``e = 0``) its value is replaced by a reference: the scene's largest initial
closing speed for a speed, 1 for a dimensionless parameter (``Sensitivity.reference``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, SimulationError
from ..result import METRICS as RESULT_METRICS
from ..scene import UNITS, Damping, Hysteresis, Restitution, Scene, UnloadingStiffness
from ._common import SummaryHTML, read_path, split_path

__all__ = ["sensitivity", "Sensitivity", "default_params", "DEFAULT_METRICS", "METHODS"]

#: Metrics differentiated by default.
DEFAULT_METRICS = ("delta_v", "peak_acceleration", "duration")
#: Accepted ``method`` values.
METHODS = ("diffrax", "finite-difference")
#: Metrics that can be differentiated (those of :data:`lsc.result.METRICS`, failure time aside).
_METRICS = tuple(m for m in RESULT_METRICS if m != "failure_time")


# ---------------------------------------------------------------------------- result
@dataclass(eq=False)
class Sensitivity(SummaryHTML):
    """The result of :func:`sensitivity`; every value in the scene's unit system.

    ``params``: the dotted paths differentiated (P); ``labels``: readable names;
    ``values`` (P,): their values in the scene; ``param_units``: their units; ``reference`` (P,):
    the value each elasticity is normalised by (the value, or a reference where it is zero).
    ``metrics``: metric → its value at the scene (an array per vehicle (N,) or contact (K,), or a
    float); ``derivatives``: metric → ``∂metric/∂param``, shape ``metric.shape + (P,)``;
    ``units``: metric → unit; ``method`` (how the derivatives were computed) and ``stats``.
    """

    scene: Scene
    params: tuple
    labels: tuple
    values: np.ndarray
    param_units: tuple
    reference: np.ndarray
    metrics: dict
    derivatives: dict
    units: dict
    method: str
    stats: dict = field(default_factory=dict)

    @property
    def elasticities(self) -> dict:
        """metric → ``(∂M/∂p) p_ref / M`` (same shapes as :attr:`derivatives`; NaN where the
        metric is zero): the percent change of the metric per percent change of the parameter."""
        out = {}
        for name, d in self.derivatives.items():
            m = np.asarray(self.metrics[name], float)[..., None]
            with np.errstate(divide="ignore", invalid="ignore"):
                out[name] = np.where(m != 0, d * self.reference / np.where(m != 0, m, 1.0), np.nan)
        return out

    def _index(self, metric: str, index):
        if metric not in self.derivatives:
            raise SceneError("metric", f"no sensitivity of {metric!r}; computed: "
                             + ", ".join(self.derivatives))
        d = self.derivatives[metric]
        if d.ndim == 1:
            return ()
        per = RESULT_METRICS[metric][1]
        n = d.shape[0]
        if index is None:
            index = self.scene.n_vehicles - 1 if per == "vehicle" else 0
        if isinstance(index, str) and per == "vehicle":
            names = [v.name for v in self.scene.vehicles]
            if index not in names:
                raise SceneError("index", f"no vehicle named {index!r}; vehicles: {', '.join(names)}")
            index = names.index(index)
        if not isinstance(index, (int, np.integer)) or not -n <= index < n:
            raise SceneError("index", f"{metric} has {n} values (one per {per}); got {index!r}")
        return (int(index) % n,)

    def _param(self, param) -> int:
        if isinstance(param, (int, np.integer)):
            return int(param)
        key = _canonical(param)
        if key not in self.params:
            raise SceneError(str(param), "not among the parameters differentiated: "
                             + ", ".join(self.params))
        return self.params.index(key)

    def derivative(self, metric: str, param, index=None) -> float:
        """``∂metric/∂param`` [metric unit / parameter unit] (``index``: the vehicle or contact
        of a per-vehicle or per-contact metric, default the front vehicle / contact 0)."""
        idx = self._index(metric, index) + (self._param(param),)
        return float(self.derivatives[metric][idx])

    def elasticity(self, metric: str, param, index=None) -> float:
        """``(∂M/∂p) p / M`` for one metric and parameter (see :attr:`elasticities`)."""
        idx = self._index(metric, index) + (self._param(param),)
        return float(self.elasticities[metric][idx])

    def value(self, metric: str, index=None) -> float:
        """The metric's value at the scene (of vehicle / contact ``index``)."""
        return float(np.asarray(self.metrics[metric])[self._index(metric, index)])

    def label(self, metric: str, index=None) -> str:
        """``"delta_v, target"``: the metric and, for a per-vehicle / per-contact one, whose."""
        idx = self._index(metric, index)
        if not idx:
            return metric
        per = RESULT_METRICS[metric][1]
        return f"{metric}, {self.scene.vehicles[idx[0]].name}" if per == "vehicle" \
            else f"{metric}, contact {idx[0]}"

    def ranked(self, metric: str, index=None) -> list[tuple[str, float, float]]:
        """``(param, derivative, elasticity)`` sorted by the elasticity's magnitude, largest
        first (parameters whose elasticity is NaN last)."""
        idx = self._index(metric, index)
        d = self.derivatives[metric][idx]
        el = self.elasticities[metric][idx]
        order = sorted(range(len(self.params)),
                       key=lambda j: (not np.isfinite(el[j]), -abs(el[j]) if np.isfinite(el[j]) else 0))
        return [(self.params[j], float(d[j]), float(el[j])) for j in order]

    def summary(self) -> str:
        """Plain text: per metric (and vehicle / contact), each parameter's value, derivative and
        elasticity, largest effect first (what ``lsc sensitivity`` prints)."""
        s = self.scene
        lines = [f"{s.name}: sensitivities by {self.method}", ""]
        width = max(len(lab) for lab in self.labels)
        for name in self.derivatives:
            d = self.derivatives[name]
            idxs = [None] if d.ndim == 1 else list(range(d.shape[0]))
            for i in idxs:
                unit = self.units[name]
                v = self.value(name, i)
                lines.append(f"{self.label(name, i)} = {v:.6g} {unit}".rstrip())
                lines.append(f"  {'parameter':<{width}} {'value':>11} {'unit':<8} "
                             f"{'derivative':>13} {'unit':<14} {'elasticity':>10}")
                for param, der, el in self.ranked(name, i):
                    j = self.params.index(param)
                    pu = self.param_units[j]
                    du = _ratio_unit(unit, pu)
                    lines.append(f"  {self.labels[j]:<{width}} {self.values[j]:>11.6g} {pu:<8} "
                                 f"{der:>+13.6g} {du:<14} {el:>+10.4f}")
                lines.append("")
        for path in self.stats.get("one_sided", ()):
            lines.append(f"{path}: below {_E_MIN:g} the derivative is taken at e = {_E_MIN:g} "
                         "(one-sided at e = 0)")
        lines.append("elasticity: percent change of the metric per percent change of the parameter"
                     + (" (a zero parameter is normalised by a reference: "
                        + ", ".join(f"{self.params[j]} by {self.reference[j]:g}"
                                    for j in range(len(self.params))
                                    if self.values[j] == 0) + ")"
                        if np.any(self.values == 0) else ""))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """A JSON-ready summary (numbers in the scene's units)."""
        def plain(x):
            return np.asarray(x, float).tolist()
        el = self.elasticities
        return {"scene": self.scene.name, "unit_system": self.scene.units, "method": self.method,
                "vehicles": [v.name for v in self.scene.vehicles],
                "params": list(self.params), "values": plain(self.values),
                "param_units": list(self.param_units), "reference": plain(self.reference),
                "metrics": {k: plain(v) for k, v in self.metrics.items()},
                "units": dict(self.units),
                "derivatives": {k: plain(v) for k, v in self.derivatives.items()},
                "elasticities": {k: plain(v) for k, v in el.items()},
                "stats": {k: (v if isinstance(v, (int, float, str)) else str(v))
                          for k, v in self.stats.items()}}


def _ratio_unit(num: str, den: str) -> str:
    if num == den:
        return ""
    if not den:
        return num
    if not num:
        return f"1/{den}"
    return f"{num}/({den})" if any(c in den for c in "*/^") else f"{num}/{den}"


# ---------------------------------------------------------------------------- parameters
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
            out.append(f"contacts.{k}.stiffness")
            if law.restitution is not None:
                out.append(f"contacts.{k}.restitution")
            else:
                out.append(f"contacts.{k}.damping")
                if law.law == "brach":
                    out.append(f"contacts.{k}.damping_restitution")
    for i, v in enumerate(sc.vehicles):
        if v.brake is not None:
            out.append(f"vehicles.{i}.brake.mu")
    return out


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
    if isinstance(law, Damping):
        name = law.law
        if rest == ("stiffness",):
            kind = "stiffness" if law.exponent == 1.0 else f"stiffness^{law.exponent:g}"
            return _Param(path, f"{tag} {name} stiffness", law.stiffness, units.get(kind, ""), kind)
        if rest == ("restitution",):
            if law.restitution is None:
                raise SceneError(path, f"{tag}'s {name} law is given by its damping, not a restitution")
            return _Param(path, f"{tag} restitution", law.restitution, "", "dimensionless")
        if rest == ("damping",):
            if law.damping is None:
                raise SceneError(path, f"{tag}'s {name} law is given by a restitution, not its damping")
            kind = {"kelvin": "damping", "hunt-crossley": "slowness",
                    "brach": "damping_per_length"}[name]
            return _Param(path, f"{tag} {name} damping", law.damping, units[kind], kind)
        if rest == ("damping_restitution",) and name == "brach":
            if law.damping_restitution is None:
                raise SceneError(path, f"{tag}'s Brach law is given by a restitution, not c2")
            return _Param(path, f"{tag} brach c2", law.damping_restitution,
                          units["damping_per_length"], "damping_per_length")
        if rest == ("exponent",) and name == "hunt-crossley":
            return _Param(path, f"{tag} exponent", law.exponent, "", "dimensionless")
    raise bad


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
_CORES: dict = {}
def _jvp_core(model, integrator: str, max_steps: int, max_events: int):
    """The diffrax segment loop of this scene structure (a solver whose stage loop JAX can
    differentiate forward) and its compiled Jacobian function, built once per structure."""
    from ..solvers import diffrax_ode as dx
    key = (dx._structure(model), integrator, int(max_steps), int(max_events))
    entry = _CORES.get(key)
    if entry is None:
        core = dx._Core(model, integrator, max_steps, max_events)
        # diffrax's ForwardMode switches a Runge-Kutta solver's stage loop to a plain lax loop
        # (its default checkpointed loop is a custom_vjp, which jvp refuses); the backend wraps
        # the solver, so do it here, on this private copy of the core
        core.solver = dx._SOLVERS[integrator](scan_kind="lax")
        import jax
        import jax.numpy as jnp

        def jac(p, T, rtol, atol, t_end, horizon):
            def run(theta):
                q = jax.tree_util.tree_map(lambda a, t: a + jnp.tensordot(theta, t, axes=1), p, T)
                out = core._run(q, rtol, atol, t_end, horizon, False)
                mets = {k: out[k] for k in _METRICS if k in out}
                aux = {k: out[k] for k in ("status", "status_contact", "t", "steps", "segments")}
                return mets, (mets, aux)
            P = jax.tree_util.tree_leaves(T)[0].shape[0]
            return jax.jacfwd(run, has_aux=True)(jnp.zeros(P))

        entry = _CORES[key] = (core, dx._Compiled(jac))
    return entry


def _by_diffrax(sc, model, prms, *, integrator, rtol, atol, max_steps, max_events):
    from ..solvers import diffrax_ode as dx
    import jax
    dx._check(integrator, rtol, atol, max_steps, max_events)
    for c in sc.contacts:
        if isinstance(c.law, Damping) and c.law.law == "brach" and c.law.restitution is not None:
            raise SceneError("method", "Brach's law with a target restitution finds its c2 by "
                             "bisection inside the solve, which forward-mode autodiff cannot see "
                             "through: use method=\"finite-difference\"")
    core, fn = _jvp_core(model, integrator, max_steps, max_events)
    p = jax.tree_util.tree_map(dx._f64, model.params)
    Ts = [_tangent(model, sc, prm) for prm in prms]
    # pad to a bucket of tangent directions (zeros): another choice of parameters of this scene
    # structure reuses the compiled code (an extra direction costs little next to a compile)
    B = max(8, 1 << (len(Ts) - 1).bit_length())
    Ts += [_zeros(model.params)] * (B - len(Ts))
    T = jax.tree_util.tree_map(lambda *xs: np.stack([np.asarray(x, float) for x in xs]), *Ts)
    horizon = float(model.horizon())
    args = (dx._f64(rtol), dx._f64(np.nan if atol is None else atol), dx._f64(np.nan),
            dx._f64(horizon if np.isfinite(horizon) else np.nan))

    def run(p):
        (jac, (prim, aux)), compile_time, wall = fn(p, T, *args)
        status = int(aux["status"])
        if status:
            t = float(aux["t"])
            if status in dx.STATUS:
                raise SimulationError(f"contact {int(aux['status_contact'])} at t = {t:.6g} s: "
                                      f"{dx.STATUS_CODES[status]}")
            raise SimulationError(f"diffrax {integrator}, t = {t:.6g} s: {dx.STATUS_CODES[status]}")
        return jac, prim, aux, compile_time, wall

    jac, prim, aux, compile_time, wall = run(p)
    values = {k: np.asarray(v, float) for k, v in prim.items()}
    derivs = {k: np.array(v, float)[..., : len(prms)] for k, v in jac.items()}
    stats = {"compile_time": compile_time, "wall_time": wall, "steps": int(aux["steps"]),
             "segments": int(aux["segments"]), "integrator": integrator, "rtol": rtol}
    # e near 0: see _E_MIN (the other derivatives stay those of the scene as given)
    low = [j for j, q in enumerate(prms)
           if q.path.endswith(".unloading.restitution") and q.value < _E_MIN]
    if low:
        p2 = jax.tree_util.tree_map(lambda a: a, p)
        for j in low:
            p2["contacts"][int(prms[j].path.split(".")[1])]["e"] = dx._f64(_E_MIN)
        jac2, _, _, _, wall2 = run(p2)
        for k in derivs:
            derivs[k][..., low] = np.asarray(jac2[k], float)[..., low]
        stats["wall_time"] += wall2
        stats["one_sided"] = [prms[j].path for j in low]
    return values, derivs, stats, f"forward-mode autodiff through the diffrax solve ({integrator}, rtol {rtol:g})"


# ---------------------------------------------------------------------------- finite differences
#: Fourth-order first-derivative stencils (offsets in steps, weights over 12 h): central, forward,
#: backward.
_STENCILS = (((-2, -1, 1, 2), (1, -8, 8, -1)),
             ((0, 1, 2, 3, 4), (-25, 48, -36, 16, -3)),
             ((0, -1, -2, -3, -4), (25, -48, 36, -16, 3)))
def _by_fd(sc, prms, needed, *, backend, step, rtol, reference):
    from ..api import resolve, solve
    base_backend, _ = resolve(sc, backend, {})
    opts = {}
    if rtol is not None and base_backend in ("scipy", "diffrax"):
        opts["rtol"] = rtol

    def metrics_of(scene):
        r = solve(scene, method=backend, **opts)
        return r, {k: np.asarray(getattr(r, k), float) for k in needed}

    t0 = time.perf_counter()
    r0, values = metrics_of(sc)
    derivs = {k: np.zeros(np.shape(v) + (len(prms),)) for k, v in values.items()}
    n = 1
    for j, prm in enumerate(prms):
        h = step * reference[j]
        # fourth-order stencils: central, or one-sided at the end of a parameter's range (e = 0,
        # e = 1)
        for offsets, weights in _STENCILS:
            try:
                scenes = {o: sc.with_values({prm.path: prm.value + o * h}) for o in offsets if o}
                break
            except SceneError as e:
                err = e
        else:
            raise SceneError(prm.path, f"no finite-difference stencil of step {h:g} around "
                             f"{prm.value:g} stays a valid scene ({err}); lower step") from None
        got = {o: (values if o == 0 else metrics_of(scenes[o])[1]) for o in offsets}
        n += len(scenes)
        for k in needed:
            derivs[k][..., j] = sum(w * got[o][k] for o, w in zip(offsets, weights)) / (12 * h)
    stats = {"solves": n, "wall_time": time.perf_counter() - t0, "backend": r0.method,
             "step": step}
    return values, derivs, stats, (f"fourth-order central differences of lsc.solve "
                                   f"({r0.method}, relative step {step:g})")


# ---------------------------------------------------------------------------- entry point
def sensitivity(scene, params=None, *, metrics=DEFAULT_METRICS, method: str = "diffrax",
                rtol: float = 1e-12, atol=None, integrator: str = "Dopri8", max_steps: int = 4096,
                max_events: int = 256, step: float = 1e-3, backend: str = "auto") -> Sensitivity:
    """Derivatives of crash metrics with respect to scene parameters, at the scene as given.

    Parameters
    ----------
    scene : dict, path or Scene
        The scene.
    params : sequence of str, optional
        Dotted paths to differentiate with respect to (``"vehicles.0.speed"``,
        ``"vehicles[1].weight"``, ``"contacts.0.loading.stiffness"``, ``"contacts.0.loading.scale"``,
        ``"contacts.0.unloading.restitution"``, ...). Default: :func:`default_params` (each
        vehicle's weight or mass and speed, each contact's stiffness or force scale and
        restitution, each brake's ``mu``).
    metrics : sequence of str
        Result metrics to differentiate (default ΔV, peak acceleration [scene units] and
        duration; also ``peak_acceleration_g``, ``peak_force``, ``max_deformation``,
        ``restitution``, ...).
    method : str
        ``"diffrax"``: forward-mode autodiff through the diffrax solve, events included (needs
        the ``[jax]`` extra); ``"finite-difference"``: central differences of :func:`lsc.solve`.
    rtol, atol, integrator, max_steps, max_events
        diffrax solver settings (as ``lsc.solve(method="diffrax")``; ``max_steps`` per segment).
        With finite differences, ``rtol`` applies where the backend takes it (SciPy, diffrax).
    step : float
        Finite differences: the step, relative to each parameter's reference value.
    backend : str
        Finite differences: the backend of each solve (default ``auto``).

    Returns
    -------
    Sensitivity
        Values, derivatives (metric shape + one axis over the parameters) and elasticities.

    Raises
    ------
    SceneError
        An unknown or non-differentiable parameter or metric.
    SimulationError
        The scene itself cannot be simulated (as :func:`lsc.solve`).
    """
    sc = Scene.load(scene)
    if method not in METHODS:
        raise SceneError("method", f"unknown sensitivity method {method!r}; accepted: "
                         + ", ".join(repr(m) for m in METHODS))
    if isinstance(step, bool) or not isinstance(step, (int, float, np.number)) \
            or not 0 < step < 1:
        raise SceneError("step", "step must be a number in (0, 1) (relative to each "
                                 f"parameter's value), got {step!r}")
    if isinstance(metrics, str):
        metrics = (metrics,)
    metrics = tuple(metrics)
    if not metrics:
        raise SceneError("metrics", "give at least one metric")
    for m in metrics:
        if m not in _METRICS:
            raise SceneError("metrics", f"unknown metric {m!r}; accepted: {', '.join(_METRICS)}")
    paths = default_params(sc) if params is None else [_canonical(p) for p in
                                                        ([params] if isinstance(params, str) else params)]
    if not paths:
        raise SceneError("params", "give at least one parameter path")
    if len(set(paths)) != len(paths):
        raise SceneError("params", "a parameter is listed twice")
    prms = [_describe(sc, p) for p in paths]
    vscale = _closing_scale(sc)
    reference = np.array([abs(q.value) if q.value != 0 else
                          (vscale if q.kind == "velocity" else 1.0 if q.kind == "dimensionless"
                           else np.nan) for q in prms])
    if method == "diffrax":
        from ..model import HybridModel
        try:
            import jax  # noqa: F401
        except ModuleNotFoundError as exc:
            raise SceneError("method", f"method 'diffrax' needs JAX and diffrax ({exc}); install "
                             "them with pip install 'lsc[jax]', or use "
                             "method=\"finite-difference\"") from exc
        model = HybridModel(sc)
        values, derivs, stats, how = _by_diffrax(
            sc, model, prms, integrator=integrator, rtol=rtol, atol=atol,
            max_steps=max_steps, max_events=max_events)
    else:
        if any(not np.isfinite(r) for r in reference):
            bad = [q.path for q, r in zip(prms, reference) if not np.isfinite(r)]
            raise SceneError(bad[0], "is zero: a relative finite-difference step has no scale; "
                                     "use method=\"diffrax\"")
        needed = tuple(dict.fromkeys("peak_acceleration" if m == "peak_acceleration_g" else m
                                     for m in metrics))
        values, derivs, stats, how = _by_fd(sc, prms, needed, backend=backend, step=step,
                                            rtol=rtol, reference=reference)
    g = sc.g
    out_v, out_d, units = {}, {}, {}
    for m in metrics:
        if m == "peak_acceleration_g":
            out_v[m] = values["peak_acceleration"] / g
            out_d[m] = derivs["peak_acceleration"] / g
            units[m] = "g"
        else:
            out_v[m] = values[m]
            out_d[m] = derivs[m]
            units[m] = sc.unit(RESULT_METRICS[m][0])
        out_v[m] = float(out_v[m]) if np.ndim(out_v[m]) == 0 else out_v[m]
    return Sensitivity(sc, tuple(paths), tuple(q.label for q in prms),
                       np.array([q.value for q in prms], float), tuple(q.unit for q in prms),
                       reference, out_v, out_d, units, how, stats)
