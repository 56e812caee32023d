"""Least-squares fit of scene parameters to measured crash-test channels.

:func:`fit` adjusts any numeric scene fields, named by their dotted paths
(``"contacts.0.loading.stiffness"``, ``"contacts.0.loading.scale"``, ``"contacts.0.unloading.restitution"``,
``"vehicles.0.speed"``, ``"vehicles.1.weight"``, ...), until the simulated acceleration of each
vehicle with an ``accel_<vehicle>`` channel and the contact force of each contact with a ``force``
channel (:meth:`~lsc.analysis.channels.Channels.match`) agree with the measured ones in the
least-squares sense (:func:`scipy.optimize.least_squares`, trust-region reflective, with bounds).

The time alignment is :func:`~lsc.analysis.compare`'s: the simulation's first contact is put at the
test's time zero, the simulated channels are read on the measured samples from time zero to the
end of the record (or ``window``), and after the simulated crash has ended the simulated
acceleration and force are zero (a scene without braking; with braking the simulation must last
to the end of the window). Each channel's residual (simulated - measured, scene units) is divided
by the channel's peak ``|measured|`` (or multiplied by ``weights[role]``), so channels of
different units can be fitted together.

The Jacobian: with ``method="diffrax"`` by forward-mode autodiff through the diffrax solve of the
sampled channels (:mod:`._fit_jacobian`, :func:`lsc.solvers.diffrax_ode.series.sampled_jacobian`:
the steps the solve took differentiated, event times moving with the parameters), one solve per
point for the residuals and the Jacobian together; otherwise (or with ``jac="2-point"`` /
``"3-point"``) by finite differences of :func:`lsc.solve` (forward or central) on the parameters
relative to their starting values, so the step is relative (``diff_step``, default ``√ε`` resp.
``ε^(1/3)`` of the starting value). ``FitResult.jacobian`` says which.

Standard errors come from the Jacobian ``J`` at the solution (weighted residuals against the
parameters). ``errors="independent"`` gives the ordinary least-squares ones, ``σ² = SSR/(n - p)``,
``cov = σ² (JᵀJ)⁻¹``, which hold for independent residuals of one variance. Filtered test data
are not that: J211 CFC 60 noise is correlated over about a millisecond (ten samples at 10 kHz), and
those formulas then understate the uncertainty several times. The default,
``errors="autocorrelated"``, is the Newey–West (heteroscedasticity and autocorrelation consistent)
sandwich ``(JᵀJ)⁻¹ S (JᵀJ)⁻¹``, ``S`` the Bartlett-weighted lagged products of ``J_t r_t`` within
each channel, up to twice the lag where the channel's residual autocorrelation first turns
negative. The correlation is ``cov`` normalised by the standard errors.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SceneError, SimulationError
from ..outputs import write_file
from ..scene import Scene
from ..toml_text import to_toml
from ._common import path_kind, read_path
from ._fit_errors import covariance
from ._fit_jacobian import choose
from ._fit_problem import _Problem
from .compare import _first_contact, _rate

__all__ = ["fit", "FitResult", "scene_toml", "sampled_channels", "ERRORS"]

#: Accepted ``errors`` values of :func:`fit`.
ERRORS = ("autocorrelated", "independent")

#: Value of a path the scene may leave out (the loader's default).
_DEFAULTS = {"scale": 1.0}


@dataclass(eq=False)
class FitResult:
    """The result of :func:`fit`; every value in the scene's unit system.

    ``values``: path → fitted value; ``initial``: path → starting value; ``standard_errors``:
    path → standard error; ``covariance`` (P, P) and ``correlation`` (P, P), in the order of
    ``params``; ``scene``: the fitted scene (:meth:`to_toml` writes it), ``result``: its crash;
    ``t`` [s]: the fitted samples (time from first contact); ``measured``, ``simulated`` and
    ``residuals`` (simulated - measured): role → array on ``t``; ``weights``: role → the factor its
    residuals were multiplied by; ``iso18571``: role → :class:`~lsc.analysis.ISO18571Rating` of
    the fitted simulation against the test; ``ssr`` (weighted sum of squared residuals), ``dof``
    (samples - parameters), ``sigma`` (``√(ssr/dof)``), ``nfev``, ``message``, ``method``;
    ``errors``: how the standard errors were computed (see :func:`fit`), ``correlation_time``:
    role → the Newey–West bandwidth [s] used for that channel; ``njev``: Jacobian evaluations,
    ``jacobian``: how the Jacobian was taken (autodiff through the diffrax solve, or finite
    differences and why).
    """

    params: tuple
    values: dict
    initial: dict
    standard_errors: dict
    covariance: np.ndarray
    correlation: np.ndarray
    scene: Scene
    result: object
    t: np.ndarray
    measured: dict
    simulated: dict
    residuals: dict
    weights: dict
    iso18571: dict
    ssr: float
    dof: int
    sigma: float
    nfev: int
    message: str
    method: str
    units: dict = field(default_factory=dict)
    channels: object = None
    mapping: dict | None = None
    errors: str = "autocorrelated"
    correlation_time: dict = field(default_factory=dict)
    njev: int = 0
    jacobian: str = ""

    def summary(self) -> str:
        """The fitted values with standard errors, the correlations and the ratings, as text."""
        lines = [f"fit of {len(self.params)} parameter(s) to {', '.join(self.measured)} "
                 f"({self.dof + len(self.params)} samples, {self.nfev} simulations, {self.njev} "
                 f"Jacobians, {self.method}):", f"  Jacobian: {self.jacobian}"]
        for p in self.params:
            u = self.units.get(p, "")
            lines.append(f"  {p} = {self.values[p]:.8g} ± {self.standard_errors[p]:.3g} {u}".rstrip()
                         + f"   (start {self.initial[p]:.6g})")
        if len(self.params) > 1:
            lines.append("  correlation: " + "; ".join(
                f"{a} / {b}: {self.correlation[i, j]:+.3f}" for i, a in enumerate(self.params)
                for j, b in enumerate(self.params) if j > i))
        lines.append(f"  residual r.m.s. (weighted) {self.sigma:.4g}")
        for role, r in self.iso18571.items():
            lines.append(f"  ISO/TS 18571 {role}: {r.total:.3f} (corridor {r.corridor:.3f}, phase "
                         f"{r.phase:.3f}, magnitude {r.magnitude:.3f}, slope {r.slope:.3f})")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """A JSON-ready dict: values, standard errors, correlation, ratings, fit statistics."""
        return {"params": list(self.params), "values": dict(self.values), "initial": dict(self.initial),
                "standard_errors": dict(self.standard_errors), "units": dict(self.units),
                "correlation": self.correlation.tolist(), "ssr": self.ssr, "dof": self.dof,
                "sigma": self.sigma, "nfev": self.nfev, "njev": self.njev, "method": self.method,
                "jacobian": self.jacobian,
                "weights": dict(self.weights),
                "iso18571": {k: r.as_dict() for k, r in self.iso18571.items()}}

    def to_json(self, path, *, overwrite: bool = False) -> Path:
        """:meth:`to_dict` as a JSON file (an existing one refused unless ``overwrite``)."""
        text = json.dumps(self.to_dict(), indent=2) + "\n"
        return write_file(path, lambda f: Path(f).write_text(text, encoding="utf-8"),
                          overwrite=overwrite)

    def to_toml(self, path=None, *, overwrite: bool = False) -> str:
        """The fitted scene as TOML text (written to ``path`` too, if given; an existing file is
        refused unless ``overwrite``); see :func:`scene_toml`."""
        return scene_toml(self.scene, path, overwrite=overwrite)

    def comparison(self, **kwargs):
        """:func:`~lsc.analysis.compare` of the fitted crash with the channels (its ``figure()``
        is the overlay of the paper's Figs. 6-7)."""
        from .compare import compare

        return compare(self.result, self.channels, mapping=self.mapping, **kwargs)


def fit(scene, channels, params, *, initial: dict | None = None, bounds: dict | None = None,
        mapping: dict | None = None, roles=None, weights: dict | None = None, window=None,
        method: str | None = None, jac: str | None = None, diff_step=None, ftol: float = 1e-10,
        xtol: float = 1e-10, gtol: float = 1e-10, max_nfev: int | None = None,
        n_samples: int | None = None, errors: str = "autocorrelated", **options) -> FitResult:
    """Fit scene parameters to measured channels by least squares.

    Parameters
    ----------
    scene : dict, path or Scene
        The scene to fit (its values are the starting values).
    channels : Channels
        The measured channels (:func:`~lsc.analysis.read_channels`), time zero at first contact.
    params : list of str
        Dotted scene paths of the fitted parameters (``"contacts.0.loading.stiffness"``, ...). A
        loading ``scale`` the scene does not set starts at 1.
    initial : dict, optional
        ``{path: starting value}`` (scene units), overriding the scene's values.
    bounds : dict, optional
        ``{path: (lower, upper)}``; default ``[0, 1]`` for a restitution, ``(0, ∞)`` for a
        stiffness, mass, weight or scale, unbounded otherwise.
    mapping : dict, optional
        ``{role: channel name}`` (as for :func:`~lsc.analysis.compare`).
    roles : list of str, optional
        The channel roles fitted (``"accel_<vehicle>"``, ``"force"``, ``"force_2"``, ...); default:
        every acceleration and force role the channels match.
    weights : dict, optional
        ``{role: factor}`` the residuals of a role are multiplied by (default ``1/max|measured|``).
    window : (float, float), optional
        Fitted interval [s] of the record (default: time zero to the end of the record).
    method : str, optional
        Backend of :func:`lsc.solve` (default: the scene's, ``auto``).
    jac : ``"autodiff"``, ``"2-point"`` or ``"3-point"``, optional
        How the Jacobian is taken: by default forward-mode autodiff through the diffrax solve
        where ``method="diffrax"`` (explicit integrator, every path a number of the model),
        else forward finite differences; ``"2-point"`` / ``"3-point"`` force finite differences
        (``FitResult.jacobian`` says which was used).
    diff_step, ftol, xtol, gtol, max_nfev
        As for :func:`scipy.optimize.least_squares` (the step is relative to the starting values).
    n_samples : int, optional
        Samples of each simulation (default: ten per measured sample in the window).
    errors : ``"autocorrelated"`` or ``"independent"``
        Standard errors that allow for residuals correlated in time (filtered noise, model error;
        Newey–West, the default) or the ordinary least-squares ``σ² (JᵀJ)⁻¹``, which assumes
        independent residuals and understates the uncertainty of filtered data several times.
    **options
        Further solver options for :func:`lsc.solve`.

    Raises
    ------
    lsc.SceneError
        A path that is no numeric field, a start outside its bounds, no fitted channel, fewer
        samples than parameters, parameters that the channels cannot tell apart, an unknown
        ``jac``, or ``jac="autodiff"`` where it does not apply.
    lsc.SimulationError
        A simulation on the way fails (the message names the parameter values), or the
        autodiff derivatives are not finite (an event that grazes its surface).
    """
    from scipy.optimize import least_squares

    if errors not in ERRORS:
        raise SceneError("errors", f"one of {', '.join(ERRORS)}, got {errors!r}")
    base = Scene.load(scene)
    params = _checked_params(params)
    start = _starting_values(base, params, initial or {})
    lower, upper = _bounds(params, start, bounds or {})
    ref = np.where(start != 0, np.abs(start), 1.0)
    autodiff, how = choose(base, params, start, method, jac, options)
    problem = _Problem(base, channels, params, ref, mapping, roles, weights, window, method,
                       n_samples, errors, options, autodiff, how)
    sol = least_squares(problem.weighted, start / ref,
                        jac=problem.jacobian if autodiff else jac or "2-point",
                        bounds=(lower / ref, upper / ref), method="trf", diff_step=diff_step, ftol=ftol, xtol=xtol, gtol=gtol,
                        max_nfev=max_nfev, x_scale=1.0)
    if sol.status <= 0:
        raise SimulationError(f"the fit did not converge: {sol.message} (raise max_nfev, or start "
                              f"closer to the solution)")
    return _result(problem, sol, start)


def _result(problem, sol, start: np.ndarray) -> FitResult:
    """The :class:`FitResult` of ``problem`` at the solution ``sol`` of least_squares."""
    p = sol.x * problem.ref
    sc, res, sim = problem.final(sol.x)
    params, roles, t = problem.params, problem.roles, problem.t
    J = sol.jac / problem.ref                              # d(weighted residual)/d(parameter)
    resid = {k: sim[k] - problem.measured[k] for k in roles}
    r = np.concatenate([resid[k] * problem.weights[k] for k in roles])
    ssr = float(r @ r)
    dof = r.size - len(params)
    cov, corr, lags = covariance(J, r, [t.size] * len(roles), problem.errors, params)
    se = np.sqrt(np.diag(cov))
    ratings = {k: _rate(t, problem.measured[k], sim[k]) for k in roles}
    units = {q: _unit(sc, q) for q in params}
    return FitResult(params, dict(zip(params, p.tolist())), dict(zip(params, start.tolist())),
                     dict(zip(params, se.tolist())), cov, corr, sc, res, t,
                     problem.measured, sim, resid, dict(problem.weights), ratings, ssr, dof,
                     math.sqrt(ssr / dof), problem.nfev, str(sol.message), str(res.method),
                     units, problem.channels, problem.mapping, problem.errors,
                     dict(zip(roles, (lag * float(t[1] - t[0]) for lag in lags))),
                     int(sol.njev or 0), problem.how)


def _checked_params(params) -> tuple:
    if isinstance(params, str) or not params:
        raise SceneError("params", "a list of dotted scene paths, e.g. ['contacts.0.loading.stiffness']")
    params = tuple(str(p) for p in params)
    if len(set(params)) != len(params):
        raise SceneError("params", f"a path is given twice: {list(params)}")
    return params


def _starting_values(scene: Scene, params, initial: dict) -> np.ndarray:
    unknown = set(initial) - set(params)
    if unknown:
        raise SceneError("initial", f"{sorted(unknown)} are not fitted parameters: {list(params)}")
    out = []
    for p in params:
        if p in initial:
            value = float(initial[p])
        else:
            try:
                value = read_path(scene, p)
            except SceneError:
                last = p.replace("]", "").split(".")[-1]
                if last not in _DEFAULTS:
                    raise
                value = _DEFAULTS[last]
        scene.with_values({p: value})            # the loader's check that the path is a numeric field
        out.append(value)
    return np.array(out, float)


def _bounds(params, start: np.ndarray, given: dict):
    unknown = set(given) - set(params)
    if unknown:
        raise SceneError("bounds", f"{sorted(unknown)} are not fitted parameters: {list(params)}")
    lower, upper = [], []
    for p, x0 in zip(params, start):
        lo, hi = given.get(p, _default_bounds(p))
        if not lo < x0 < hi:
            raise SceneError(f"bounds.{p}", f"the starting value {x0:g} must lie strictly inside the "
                                            f"bounds ({lo:g}, {hi:g})")
        lower.append(float(lo))
        upper.append(float(hi))
    return np.array(lower), np.array(upper)


def _default_bounds(path: str) -> tuple[float, float]:
    last = path.replace("]", "").split(".")[-1]
    if last == "restitution":
        return 0.0, 1.0
    if last in ("stiffness", "mass", "weight", "scale"):
        return 0.0, math.inf
    return -math.inf, math.inf


def sampled_channels(result, t, *, source: str = "simulation"):
    """What ideal sensors would record of ``result`` on the time base ``t`` [s] (0 = its first
    contact): :class:`~lsc.analysis.channels.Channels` ``accel_<vehicle>``, ``force`` /
    ``deformation`` (``force_2`` ... for later contacts), in the scene's unit system. Before
    first contact all are zero; after the simulated crash (no braking) the accelerations and
    forces are zero and the deformations follow the vehicles' uniform motion.
    """
    from .channels import Channel, Channels

    sc = result.scene
    if any(v.brake is not None for v in sc.vehicles):
        raise SceneError("result", "sampled_channels needs a scene without braking (its motion after "
                                   "the simulation is not known)")
    t = np.asarray(t, float)
    t_sim = result.t - _first_contact(result)
    u = {k: sc.unit(k) for k in ("acceleration", "force", "length")}
    out = {}
    for i, v in enumerate(sc.vehicles):
        name = f"accel_{v.name}"
        out[name] = Channel(name, np.interp(t, t_sim, result.a[:, i], left=0.0, right=0.0),
                            u["acceleration"], "acceleration", source)
    for k in range(len(sc.contacts)):
        suffix = "" if k == 0 else f"_{k + 1}"
        d = np.interp(t, t_sim, result.deformation[:, k], left=0.0)
        after = t > t_sim[-1]
        d[after] += (result.v[-1, k] - result.v[-1, k + 1]) * (t[after] - t_sim[-1])
        out[f"force{suffix}"] = Channel(f"force{suffix}", np.interp(t, t_sim, result.force[:, k], left=0.0,
                                                                    right=0.0), u["force"], "force", source)
        out[f"deformation{suffix}"] = Channel(f"deformation{suffix}", d, u["length"], "displacement", source)
    return Channels(t, out, source)


def _unit(scene: Scene, path: str) -> str:
    kind = path_kind(path)
    return scene.unit(kind) if kind and kind != "dimensionless" else ""


# ---------------------------------------------------------------------------------- TOML

def scene_toml(scene, path=None, *, overwrite: bool = False) -> str:
    """A scene as TOML text that :meth:`lsc.Scene.load` reads back to the same scene (written to
    ``path`` too, if given). Relative CSV paths are made absolute (the scene's ``base_dir``), so the
    file can be written anywhere."""
    sc = Scene.load(scene)
    text = to_toml(_absolute_csv(sc.source, sc.base_dir))
    if path is not None:
        write_file(path, lambda f: Path(f).write_text(text, encoding="utf-8"), overwrite=overwrite)
    return text


def _absolute_csv(node, base_dir):
    if isinstance(node, dict):
        return {k: (str((Path(base_dir or ".") / v).resolve()) if k == "csv" and isinstance(v, str)
                    else _absolute_csv(v, base_dir)) for k, v in node.items()}
    if isinstance(node, list):
        return [_absolute_csv(x, base_dir) for x in node]
    return node
