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
and every law is supported (Brach's law with a target restitution only this way). Its step is
relative to each parameter's value, with a floor where that value is tiny against the parameter's
scale (a restitution of 1e-200): see :func:`sensitivity`'s ``step``.

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

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, SimulationError
from ..metrics import TIE_ROUNDING
from ..result import METRICS as RESULT_METRICS
from ..scene import Scene
from ._common import SummaryHTML
from ._sensitivity_autodiff import _E_MIN, _by_diffrax, _tangent  # noqa: F401  (_tangent: tests)
from ._sensitivity_params import _canonical, _closing_scale, _describe, default_params

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


#: ``(offsets, weights, second-order weights)``, each over ``12 h``: the fourth-order central,
#: forward and backward stencils and the second-order estimate from the same points.
_STENCILS = (((-2, -1, 1, 2), (1, -8, 8, -1), (0, -6, 6, 0)),
             ((0, 1, 2, 3, 4), (-25, 48, -36, 16, -3), (-18, 24, -6, 0, 0)),
             ((0, -1, -2, -3, -4), (25, -48, 36, -16, 3), (18, -24, 6, 0, 0)))
#: Where a step is raised to its floor (:func:`_fd_steps`), the fourth- and second-order
#: estimates must agree to this fraction: else the metric is not smooth over the stencil
#: (it spans the parameter's value many times over) and the derivative is refused.
_FLOOR_AGREEMENT = 1e-3
#: The relative resolution of a solve by a backend that takes no ``rtol`` (exact, closed
#: form): its rounding, a few hundred ulps of each metric (the one figure the metrics' tie rule
#: takes for an exact solve's times).
_EXACT_RESOLUTION = TIE_ROUNDING


def _fd_steps(prms, reference, step, resolution, v_scale) -> np.ndarray:
    """Each parameter's finite-difference step: ``step`` times its reference value, but no
    less than ``sqrt(resolution)`` times its scale (the larger of that value and, for a speed,
    the closing scale ``v_scale``, for a dimensionless parameter 1). Below that floor a
    solve's own noise (``resolution`` of each metric) divided by the step swamps the
    difference (a restitution of 1e-200 gave a slope of 1e187 for one of -3); at it, that
    noise is ``sqrt(resolution)`` of a natural derivative (metric scale over parameter scale)."""
    natural = np.array([v_scale if q.kind == "velocity" else 1.0 if q.kind == "dimensionless"
                        else 0.0 for q in prms])
    return np.maximum(step * reference, np.sqrt(resolution) * np.maximum(reference, natural))


def _check_floor(prm, metric, d4, d2, h, noise) -> None:
    """Raise :class:`SimulationError` where the derivatives ``d4`` and ``d2`` (fourth and
    second order, from one stencil of step ``h`` raised to its floor) of ``metric`` with
    respect to ``prm`` disagree by more than :data:`_FLOOR_AGREEMENT` (beyond the solves'
    ``noise`` [metric unit / parameter unit]): the metric is not smooth over the stencil."""
    off = np.abs(np.asarray(d4) - np.asarray(d2))
    if np.all(off <= _FLOOR_AGREEMENT * np.abs(d4) + 100 * noise):
        return
    raise SimulationError(
        f"{prm.path}: the finite-difference derivative of {metric} at {prm.value:g} is not "
        f"resolved: a solve resolves no step below {h:g} there, and over that step the metric "
        "is not smooth (its fourth- and second-order differences disagree; a damping law's "
        "pulse at a vanishing restitution changes over a far smaller scale); give a larger "
        "value, or drop that metric")


def _integrator(sc, opts: dict) -> str:
    """The SciPy integrator of a solve of ``sc`` with ``opts``: the one given, or the one a solve
    naming none picks for it (:func:`lsc.solvers.stiffness.integrator_for`), which a member of a
    stencil might not pick (Radau at its centre, DOP853 a step away)."""
    from ..api import model_of
    from ..solvers import scipy_ode, stiffness

    if opts.get("integrator"):
        return opts["integrator"]
    return stiffness.integrator_for(model_of(sc), opts.get("rtol", scipy_ode.RTOL),
                                    opts.get("atol"))


def _by_fd(sc, prms, needed, *, backend, step, rtol, reference, v_scale):
    from ..api import resolve, solve
    base_backend, _ = resolve(sc, backend, {})
    opts = {}
    if rtol is not None and base_backend in ("scipy", "diffrax"):
        opts["rtol"] = rtol
    if base_backend == "scipy":   # one integrator for every solve of the stencils: the base's
        opts["integrator"] = _integrator(sc, resolve(sc, backend, opts)[1])
    resolution = opts.get("rtol", _EXACT_RESOLUTION)
    steps = _fd_steps(prms, reference, step, resolution, v_scale)

    def metrics_of(scene):
        r = solve(scene, method=backend, **opts)
        return r, {k: np.asarray(getattr(r, k), float) for k in needed}

    t0 = time.perf_counter()
    r0, values = metrics_of(sc)
    derivs = {k: np.zeros(np.shape(v) + (len(prms),)) for k, v in values.items()}
    n = 1
    for j, prm in enumerate(prms):
        h = float(steps[j])
        # fourth-order stencils: central, or one-sided at the end of a parameter's range (e = 0,
        # e = 1)
        for offsets, weights, second in _STENCILS:
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
            def difference(ws, k=k):
                return sum(w * got[o][k] for o, w in zip(offsets, ws)) / (12 * h)

            derivs[k][..., j] = difference(weights)
            if h > step * reference[j]:
                noise = resolution * max(float(np.max(np.abs(got[o][k]), initial=0.0))
                                         for o in offsets) / h
                _check_floor(prm, k, derivs[k][..., j], difference(second), h, noise)
    stats = {"solves": n, "wall_time": time.perf_counter() - t0, "backend": r0.method,
             "step": step, "steps": steps.tolist()}
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
        Finite differences: the step, relative to each parameter's reference value; never
        below ``sqrt(resolution)`` of the parameter's scale (``resolution``: the solve's
        ``rtol``, 1e-13 for an exact backend; the scale: the value, at least the closing speed
        for a speed and 1 for a dimensionless parameter), where the solve's noise would swamp
        the difference. ``stats["steps"]`` holds the steps taken.
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
                                            rtol=rtol, reference=reference, v_scale=vscale)
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
