"""Force-scale calibration of a measured loading table (the paper's constants 1.14, 1.18, 1.16).

A dynamic IF-D curve measured in a crash test ends at the test's maximum deformation, where the
two vehicles had a common velocity. Simulated with the test's masses and speeds, the measured
forces are often too small to bring the vehicles to that common velocity before the table ends
(force and accelerometer data do not follow Newton's second law exactly), and lsc raises
:class:`~lsc.SimulationError`. The paper multiplies the measured forces by the constant ``c`` that
makes the simulated common velocity (the max deformation) fall exactly on the table's last point.

:func:`calibrate_force_scale` finds ``c`` by Brent's method on simulations, which holds for any
scene the backends solve (chains, braking). For two vehicles without external forces it equals the
energy identity :func:`energy_force_scale`: ``c ∫_0^{D_end} f dD = E_afc = ½ μ v0²`` (Appendix A).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from ..api import solve
from ..contact import STATUS
from ..errors import SceneError, SimulationError
from ..scene import Hysteresis, Scene
from ._common import SummaryHTML, check_brent, check_contact, check_keywords, quantity

__all__ = ["calibrate_force_scale", "energy_force_scale", "Calibration"]


@dataclass(eq=False)
class Calibration(SummaryHTML):
    """The result of :func:`calibrate_force_scale`.

    ``factor`` [-]: the loading ``scale`` of the calibrated scene (the multiplier of the table's
    forces as given; it replaces ``previous_scale``, the scale the input scene had, default 1).
    ``scene``: the calibrated scene (``contacts[k].loading.scale = factor``); ``result``: its
    crash. ``d_end`` [length]: the table's last deformation, where the calibrated crash reaches
    its common velocity; ``energy_factor`` [-]: the energy identity's factor (two vehicles without
    brakes; ``None`` otherwise). ``evaluations``: simulations run by the search.
    """

    factor: float
    previous_scale: float
    scene: Scene
    result: object
    contact: int
    d_end: float
    energy_factor: float | None
    evaluations: int

    def summary(self) -> str:
        """One paragraph: the factor and how it was checked."""
        u = self.scene.unit("length")
        k = self.contact
        text = (f"force scale {self.factor:.8g} on contacts[{k}].loading (measured forces x "
                f"{self.factor:.6g}): the vehicles reach their common velocity at D = "
                f"{self.result.max_deformation[k]:.6g} {u}, the table's last point {self.d_end:.6g} {u}")
        if self.previous_scale != 1.0:
            text += f" (the scene had scale = {self.previous_scale:g})"
        if self.energy_factor is not None:
            text += f"; energy identity E_afc / int f dD gives {self.energy_factor:.8g}"
        return text


def energy_force_scale(scene, *, contact: int = 0) -> float:
    """The force factor from the energy identity ``c ∫_0^{D_end} f dD = ½ μ v0²`` [-].

    Two vehicles without brakes only (``μ = m1 m2/(m1+m2)``, ``v0`` the closing speed); the
    factor multiplies the table's forces as given (before any ``scale`` the scene sets).
    """
    sc = Scene.load(scene)
    k = check_contact(sc, contact)
    curve, s0 = _table(sc, k)
    if sc.n_vehicles != 2 or any(v.brake is not None for v in sc.vehicles):
        raise SceneError("contact", "the energy identity holds for two vehicles without brakes; "
                                    "use calibrate_force_scale")
    (m1, m2), (v1, v2) = sc.masses, sc.speeds
    e_afc = 0.5 * m1 * m2 / (m1 + m2) * (v1 - v2) ** 2
    return float(s0 * e_afc / curve.energy(curve.d[-1]))


def calibrate_force_scale(scene, *, contact: int = 0, method: str = "auto", xtol: float = 1e-14,
                          rtol: float = 4 * np.finfo(float).eps, maxiter: int = 200,
                          **options) -> Calibration:
    """The force factor that brings the vehicles to a common velocity at the table's last point.

    Parameters
    ----------
    scene : dict, path or Scene
        A scene whose ``contacts[contact]`` is the IF-D law with a measured loading table (a table,
        CSV or series of tables that ends at its last point).
    contact : int
        The contact to calibrate.
    method : str
        Backend for the simulations (``"auto"``: the exact piecewise backend for two vehicles).
    xtol, rtol, maxiter
        Brent's method tolerances on the factor [-] and iteration limit.
    **options
        Solver options, as for :func:`lsc.solve`.

    Returns
    -------
    Calibration
        ``factor``, the calibrated ``scene`` and its ``result``.

    Notes
    -----
    The search solves the scene with the table extended beyond its last point by a stiff line
    (so that too small a factor still gives a crash, with a max deformation past the end) and
    finds the root of ``D_max(c) - D_end``, which falls strictly with ``c``. The extension is
    never reached at the root. If the calibrated scene then stops a rounding error short of its
    common velocity, the factor is raised by a few units in the last place.
    """
    from scipy.optimize import brentq

    check_keywords("calibrate_force_scale", options,
                   ("contact", "method", "xtol", "rtol", "maxiter"))
    check_brent(xtol, rtol, maxiter)
    base = Scene.load(scene)
    k = check_contact(base, contact)
    curve, s0 = _table(base, k)
    d_end = float(curve.d[-1])
    raw_d, raw_f = curve.d, curve.f / s0
    # a stiff extension beyond the end: 100 table lengths at the table's mean stiffness
    top = max(float(np.max(raw_f)), 1e-300)
    ext = np.array([[d_end * 101.0, raw_f[-1] + top * 100.0]])
    table = np.vstack([np.column_stack([raw_d, raw_f]), ext])
    src = copy.deepcopy(base.source)
    src["name"] = base.name
    evals = [0]

    def extended(c: float) -> Scene:
        s = copy.deepcopy(src)
        s["contacts"][k]["loading"] = {"table": table.tolist(), "scale": float(c)}
        return Scene.load(s, base_dir=base.base_dir)

    def h(c: float) -> float:
        evals[0] += 1
        r = solve(extended(c), method=method, **{"n_samples": 2, **options})
        return float(r.max_deformation[k]) - d_end

    lo, hi = _bracket(h, s0)
    c = hi if h(hi) == 0 else brentq(h, lo, hi, xtol=xtol, rtol=rtol, maxiter=maxiter)
    calibrated, result, c = _complete(src, base, k, c, method, options)
    e_fac = None
    if base.n_vehicles == 2 and all(v.brake is None for v in base.vehicles):
        e_fac = energy_force_scale(base, contact=k)
    return Calibration(float(c), s0, calibrated, result, k, d_end, e_fac, evals[0])


def _table(scene: Scene, k: int):
    """The contact's loading curve (as loaded, scale included) and the scale the scene gave."""
    law = scene.contacts[k].law
    path = f"contacts[{k}].loading"
    if not scene.source:
        raise SceneError("", "calibration needs a scene made by Scene.load (this one has no source)")
    if not isinstance(law, Hysteresis):
        raise SceneError(path, "force-scale calibration applies to the IF-D law with a measured "
                               "loading table")
    fail = scene.contacts[k].failure
    if fail is not None and fail.post_failure is not None:
        raise SceneError(f"contacts[{k}].failure.post_failure",
                         "force-scale calibration applies to a loading table alone; this contact "
                         "goes on along a post-failure curve after the failure force")
    if law.loading.extends:
        raise SceneError(path, "force-scale calibration applies to a measured table that ends at its "
                               "max deformation; this loading curve goes on beyond its last point "
                               "(a stiffness, or a series of stiffnesses)")
    spec = scene.source["contacts"][k]["loading"]
    s0 = quantity(spec["scale"], "dimensionless", scene, f"{path}.scale") if "scale" in spec else 1.0
    if not np.any(law.loading.f > 0):
        raise SceneError(path, "the loading table has no positive force to scale")
    return law.loading, float(s0)


def _bracket(h, c0: float, limit: int = 200):
    """``(lo, hi)`` with ``h(lo) > 0 >= h(hi)``, doubling or halving from ``c0``."""
    c = c0
    v = h(c)
    if v > 0:
        for _ in range(limit):
            lo, c = c, 2.0 * c
            if h(c) <= 0:
                return lo, c
    else:
        for _ in range(limit):
            hi, c = c, 0.5 * c
            try:
                if h(c) > 0:
                    return c, hi
            except SimulationError:  # below what even the extension can stop
                return _bisect_working(h, c, hi), hi
    raise SimulationError("no force scale found that brings the vehicles to a common velocity "
                          "at the end of the loading table")


def _bisect_working(h, bad: float, good: float, limit: int = 100) -> float:
    """A factor between ``bad`` (simulation fails) and ``good`` with ``h > 0``."""
    for _ in range(limit):
        mid = 0.5 * (bad + good)
        try:
            if h(mid) > 0:
                return mid
            good = mid
        except SimulationError:
            bad = mid
    raise SimulationError("no force scale found that brings the vehicles to a common velocity "
                          "at the end of the loading table")


def _complete(src: dict, base: Scene, k: int, c: float, method: str, options: dict):
    """The calibrated scene and its result; the factor is nudged up by a few ulps if the crash
    stops a rounding error short of its common velocity at the table's end."""
    last = None
    for _ in range(60):
        s = copy.deepcopy(src)
        s["contacts"][k]["loading"]["scale"] = float(c)
        sc = Scene.load(s, base_dir=base.base_dir)
        try:
            return sc, solve(sc, method=method, **options), c
        except SimulationError as err:
            if STATUS[1] not in str(err):
                raise
            last = err
            c = math.nextafter(c, math.inf) * (1.0 + 4 * np.finfo(float).eps)
    raise SimulationError(f"the calibrated scene (scale {c:.17g}) does not complete: {last}")
