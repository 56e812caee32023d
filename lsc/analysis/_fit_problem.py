"""The least-squares problem of :func:`lsc.analysis.fit`: the fitted channels and samples, their
weights, and the weighted residuals of a scene's simulation against them (with their Jacobian
where it is taken by autodiff, :mod:`._fit_jacobian`)."""

from __future__ import annotations

import math

import numpy as np

from ..api import solve
from ..errors import SceneError, SimulationError
from ..scene import Scene
from ._fit_jacobian import check_end, role_index
from .compare import _first_contact

__all__: list[str] = []

#: Fitted channel roles: prefix → the result series and kind it is compared with.
_ROLES = {"accel_": "acceleration", "force": "force"}


class _Problem:
    """The weighted residuals of a scene's simulation against its channels, as a function of the
    parameters relative to their reference values (and their Jacobian, where by autodiff)."""

    def __init__(self, base, channels, params, ref, mapping, roles, weights, window, method,
                 n_samples, errors, options, autodiff=None, how=""):
        self.base, self.channels, self.params, self.ref = base, channels, params, ref
        self.mapping, self.method, self.errors = mapping, method, errors
        self.autodiff, self.how = autodiff, how
        self.roles = _fitted_roles(base, channels, mapping, roles)
        self.t, self.inside = _samples(channels, window)
        if self.t.size * len(self.roles) <= len(params):
            raise SceneError("params", f"{len(params)} parameters need more than "
                                       f"{self.t.size * len(self.roles)} fitted samples")
        self.measured = {r: ch.to(base.units)[self.inside] for r, ch in self.roles.items()}
        self.weights = _weights(self.measured, weights or {})
        self.options = {"n_samples": n_samples or 10 * self.t.size, **options}
        self.nfev = 0
        if autodiff is not None:
            autodiff.warm(self.t.size, list(self.roles))
        self._last = None   # (x, residuals, Jacobian, channels) of the last autodiff evaluation

    def scene(self, p: np.ndarray) -> Scene:
        return self.base.with_values({k: float(v) for k, v in zip(self.params, p)})

    def _at(self, p: np.ndarray, call):
        """``call()``, its errors naming the parameter values ``p``."""
        self.nfev += 1
        try:
            return call()
        except (SceneError, SimulationError) as err:
            at = ", ".join(f"{k} = {v:.10g}" for k, v in zip(self.params, p))
            raise type(err)(*_with_context(err, at)) from err

    def simulate(self, p: np.ndarray):
        """The scene at parameters ``p`` (scene units), its result and its channels on ``t``."""
        def run():
            sc = self.scene(p)
            return sc, solve(sc, self.method, **self.options)
        sc, res = self._at(p, run)
        return sc, res, _simulated(res, self.t, self.roles)

    def _stacked(self, series: dict) -> np.ndarray:
        return np.concatenate([series[r] * self.weights[r] for r in self.roles])

    def _differentiated(self, x: np.ndarray):
        """Residuals, Jacobian (relative parameters) and channels by autodiff at ``x`` (the last
        point kept: least_squares asks for the residuals, then the Jacobian, at each point)."""
        if self._last is None or not np.array_equal(self._last[0], x):
            p = x * self.ref
            sim, jac = self._at(p, lambda: self.autodiff.channels(self.scene(p), p, self.t,
                                                                  self.roles))
            r = self._stacked({k: sim[k] - self.measured[k] for k in self.roles})
            self._last = (x.copy(), r, self._stacked(jac) * self.ref, sim)
        return self._last

    def weighted(self, x: np.ndarray) -> np.ndarray:
        if self.autodiff is not None:
            return self._differentiated(x)[1]
        _, _, sim = self.simulate(x * self.ref)
        return self._stacked({k: sim[k] - self.measured[k] for k in self.roles})

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        return self._differentiated(x)[2]

    def final(self, x: np.ndarray):
        """The scene at the solution ``x``, its Result and the channels the fit compared (with
        autodiff: the solve's own, read on ``t`` exactly)."""
        sc, res, sim = self.simulate(x * self.ref)
        if self.autodiff is not None:
            sim = self._differentiated(x)[3]
        return sc, res, sim


def _with_context(err, at: str) -> tuple:
    if isinstance(err, SceneError):
        return err.path, f"{err.message} (at {at})"
    return (f"{err} (at {at}; start the fit closer to the solution or bound the parameters)",)


def _fitted_roles(scene, channels, mapping, roles) -> dict:
    found = channels.match(scene, mapping)
    fittable = {r: ch for r, ch in found.items() if any(r.startswith(p) for p in _ROLES)}
    if roles is None:
        chosen = fittable
    else:
        missing = [r for r in roles if r not in fittable]
        if missing:
            raise SceneError("roles", f"no acceleration or force channel for {missing}; the channels "
                                      f"match: {', '.join(fittable) or '(none)'}")
        chosen = {r: fittable[r] for r in roles}
    if not chosen:
        wanted = ", ".join(f"accel_{v.name}" for v in scene.vehicles)
        raise SceneError(channels.source, f"no channel to fit: name them {wanted} or force (or pass "
                                          f"mapping={{role: channel}}); the channels are: "
                                          f"{', '.join(channels.names)}")
    return chosen


def _samples(channels, window):
    t = channels.t
    t0, t1 = (max(0.0, float(t[0])), float(t[-1])) if window is None else (float(w) for w in window)
    if not (float(t[0]) - 1e-12 <= t0 < t1 <= float(t[-1]) + 1e-12):
        raise SceneError("window", f"the window ({t0:g}, {t1:g}) s must lie inside the record "
                                   f"({float(t[0]):g}, {float(t[-1]):g}) s")
    inside = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    return t[inside], inside


def _weights(measured: dict, given: dict) -> dict:
    unknown = set(given) - set(measured)
    if unknown:
        raise SceneError("weights", f"{sorted(unknown)} are not fitted roles: {list(measured)}")
    out = {}
    for role, values in measured.items():
        peak = float(np.max(np.abs(values)))
        w = float(given[role]) if role in given else (1.0 / peak if peak > 0 else 0.0)
        if not (w > 0 and math.isfinite(w)):
            raise SceneError(f"weights.{role}", f"a positive finite factor (the measured channel is "
                                                f"zero: give its weight), got {w!r}")
        out[role] = w
    return out


def _simulated(res, t: np.ndarray, roles: dict) -> dict:
    """The result's acceleration and force on ``t`` (time from first contact); zero after the end
    for a scene without braking."""
    t_sim = res.t - _first_contact(res)
    check_end(res.scene, float(t[-1]), float(t_sim[-1]))
    out = {}
    for role in roles:
        kind, i = role_index(res.scene, role)
        out[role] = np.interp(t, t_sim, res.a[:, i] if kind == "a" else res.force[:, i],
                              left=0.0, right=0.0)
    return out
