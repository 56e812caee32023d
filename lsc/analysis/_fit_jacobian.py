"""How :func:`lsc.analysis.fit` takes its Jacobian: forward-mode automatic differentiation
through the diffrax solve of the sampled channels (:class:`Autodiff`, with
:func:`lsc.solvers.diffrax_ode.series.sampled_jacobian`), or finite differences of
:func:`lsc.solve` (:func:`choose` says which, and why).
"""

from __future__ import annotations

import numpy as np

from ..errors import SceneError, SimulationError
from ..model import HybridModel

__all__ = ["JACOBIANS", "choose", "Autodiff", "role_index", "check_end"]

#: Accepted ``jac`` values of :func:`lsc.analysis.fit` (``None``: autodiff where it applies).
JACOBIANS = (None, "autodiff", "2-point", "3-point")
#: Integrators whose steps the autodiff path re-takes (explicit Runge–Kutta).
_EXPLICIT = ("Tsit5", "Dopri5", "Dopri8")


def role_index(scene, role: str) -> tuple[str, int]:
    """``("a", vehicle)`` for ``accel_<vehicle name>``, ``("F", contact)`` for ``force``,
    ``force_2``, ..."""
    if role.startswith("accel_"):
        return "a", [v.name for v in scene.vehicles].index(role[len("accel_"):])
    return "F", 0 if role == "force" else int(role.split("_")[1]) - 1


def check_end(scene, t_last: float, t_sim_end: float) -> None:
    """A scene with braking must be simulated to the end of the fitted window (its motion after
    the simulation is not known); without braking the channels are zero after the crash."""
    if any(v.brake is not None for v in scene.vehicles) and t_last > t_sim_end + 1e-12:
        raise SimulationError(f"the scene has braking and its simulation ends at {t_sim_end:.6g} "
                              f"s, before the fitted window ({t_last:.6g} s): pass a shorter "
                              f"window or a later t_end")


def choose(base, params, start, method, jac, options):
    """``(autodiff, how)``: an :class:`Autodiff` where the Jacobian is taken by autodiff (``jac``
    ``None`` or ``"autodiff"``, the diffrax backend, an explicit integrator, every path a number
    of the model with a tangent), else ``None``; ``how`` says how it is taken (and why not by
    autodiff); ``start``: the parameters' starting values. ``jac="autodiff"`` where it does not
    apply is a :class:`~lsc.SceneError`."""
    if jac not in JACOBIANS:
        raise SceneError("jac", f"one of 'autodiff', '2-point', '3-point' (or leave it out), "
                                f"got {jac!r}")
    fd = f"finite differences ({jac or '2-point'}) of lsc.solve"
    if jac in ("2-point", "3-point"):
        return None, fd
    from ..api import resolve

    backend, opts = resolve(base, method, options)
    why = None
    if backend != "diffrax":
        why = f"autodiff needs method='diffrax' (this fit: {backend})"
    elif opts.get("integrator", "Dopri8") not in _EXPLICIT:
        why = (f"the {opts['integrator']} integrator is implicit (autodiff re-takes the steps of "
               f"{', '.join(_EXPLICIT)})")
    model = HybridModel(base) if why is None else None
    if why is None:
        why = next((w for w in (getattr(law, "autodiff_refused", lambda: None)()
                                for law in model.laws) if w), None)
    if why is None:
        from ..parameters import numbers_at

        for p, x in zip(params, start):
            try:
                numbers_at(model, p, float(x))
            except SceneError as err:
                why = f"{p}: {err.message}"
                break
    if why is not None:
        if jac == "autodiff":
            raise SceneError("jac", f"jac='autodiff' does not apply: {why}")
        return None, f"{fd}; {why}"
    solver = {k: v for k, v in opts.items() if k != "n_samples"}
    how = (f"forward-mode autodiff through the diffrax solve ({solver.get('integrator', 'Dopri8')}"
           f", rtol {solver.get('rtol', 1e-10):g})")
    return Autodiff(base, params, solver), how


class Autodiff:
    """The sampled channels of the diffrax solve of a scene at given parameter values and their
    derivatives with respect to them (scene units), on the fit's samples."""

    def __init__(self, base, params, solver: dict):
        self.base, self.params, self.solver = base, params, solver

    def warm(self, n_samples: int, roles) -> None:
        """Start compiling what the fit's first solve and derivatives run (in the background,
        side by side: :func:`lsc.solvers.diffrax_ode.series.warm`)."""
        from ..solvers.diffrax_ode.series import warm

        accel, force = self._rows(self.base, roles)
        warm(HybridModel(self.base), len(self.params), n_samples, accel=accel, force=force,
             **self.solver)

    @staticmethod
    def _rows(scene, roles):
        where = [role_index(scene, r) for r in roles]
        return ([i for kind, i in where if kind == "a"], [i for kind, i in where if kind == "F"])

    def channels(self, scene, values, t, roles) -> tuple[dict, dict]:
        """``(sim, jac)``: role → simulated channel on ``t`` [s] (time from first contact), role
        → its derivatives (len(t), P) along the parameters at ``values`` (scene units); ``scene``
        is the base scene with ``values`` set."""
        from ..parameters import tangent
        from ..solvers.diffrax_ode.series import sampled_jacobian

        model = HybridModel(scene)
        tangents = [tangent(model, p, v) for p, v in zip(self.params, values)]
        accel, force = self._rows(scene, roles)
        where = [role_index(scene, r) for r in roles]
        vals, ders, info = sampled_jacobian(model, tangents, t, accel=accel, force=force,
                                            **self.solver)
        check_end(scene, float(t[-1]), info["t_end"])
        rows = [accel.index(i) if kind == "a" else len(accel) + force.index(i) for kind, i in where]
        if not (np.all(np.isfinite(vals)) and np.all(np.isfinite(ders))):
            raise SimulationError("the derivative of the simulated channels is not finite (an "
                                  "event grazes its surface): fit with jac='2-point'")
        return ({r: vals[k] for r, k in zip(roles, rows)},
                {r: ders[k] for r, k in zip(roles, rows)})
