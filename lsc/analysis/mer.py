"""The Momentum–Energy–Restitution (MER) method: ΔVs without a crash pulse (paper Intro, App. A).

With ``μ = m1 m2/(m1+m2)``, closing speed ``vc = v1 - v2`` and restitution ``e`` (Eq. 9), momentum
conservation gives ``ΔV1 = -(1+e) m2 vc/(m1+m2)`` and ``ΔV2 = (1+e) m1 vc/(m1+m2)``. The energy
available for crush is ``E_afc = ½ μ vc²`` (Eq. 4A); a crash with restitution ``e`` dissipates
``E = (1 - e²) E_afc`` (Eq. 6A): the energy the MER literature calls "absorbed by the vehicles"
(crush and heat). Given ``E`` and ``e`` the closing speed is ``vc = √(2E / (μ (1 - e²)))``; given
``vc`` and ``E``, ``e = √(1 - E/E_afc)``.

Note: ``E`` is the energy *lost*; :attr:`lsc.Result.energy_absorbed` is the compression work
``∫_0^{D_max} f dD = E_afc``, of which ``e² E_afc`` is returned on rebound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..scene import Restitution, Scene

__all__ = ["mer", "mer_for", "format_mer", "MER"]


@dataclass(frozen=True)
class MER:
    """MER results (arrays broadcast from the inputs, or floats), in the inputs' coherent units.

    ``delta_v1, delta_v2`` [velocity]; ``closing_speed`` [velocity]; ``restitution`` [-];
    ``energy_available`` (``E_afc``) and ``energy_lost`` (``(1-e²) E_afc``) [energy];
    ``v1_final, v2_final`` [velocity] (NaN when the speeds were not given).
    """

    delta_v1: object
    delta_v2: object
    closing_speed: object
    restitution: object
    energy_available: object
    energy_lost: object
    v1_final: object
    v2_final: object

    @property
    def delta_v(self) -> np.ndarray:
        """``[ΔV1, ΔV2]`` stacked on the last axis [velocity]."""
        return np.stack(np.broadcast_arrays(self.delta_v1, self.delta_v2), axis=-1)


def _out(x):
    x = np.asarray(x, float)
    return x[()] if x.ndim == 0 else x


def mer(m1, m2, v1=None, v2=0.0, *, restitution=None, energy=None) -> MER:
    """MER ΔVs of a collinear two-vehicle crash (vectorised over any broadcastable inputs).

    Parameters
    ----------
    m1, m2 : float or array
        Masses of the rear (1) and front (2) vehicle [mass].
    v1, v2 : float or array, optional
        Speeds before the crash [velocity] (rear, front). Leave ``v1`` out to get the closing
        speed from ``energy`` and ``restitution``.
    restitution : float or array, optional
        Coefficient of restitution ``e`` (Eq. 9) [-].
    energy : float or array, optional
        Kinetic energy lost in the crash (crush and heat), ``(1 - e²) E_afc`` [energy].

    Give two of the three: speeds, ``restitution``, ``energy``.

    Returns
    -------
    MER
    """
    m1, m2 = np.asarray(m1, float), np.asarray(m2, float)
    if np.any(~(m1 > 0)) or np.any(~(m2 > 0)):
        raise SceneError("mass", "masses must be positive")
    mu = m1 * m2 / (m1 + m2)
    given = [v1 is not None, restitution is not None, energy is not None]
    if sum(given) != 2:
        raise SceneError("mer", "give exactly two of: the speeds (v1, v2), restitution, energy")
    e = None if restitution is None else np.asarray(restitution, float)
    E = None if energy is None else np.asarray(energy, float)
    if e is not None and np.any((e < 0) | (e > 1)):
        raise SceneError("restitution", "must be between 0 and 1")
    if E is not None and np.any(E < 0):
        raise SceneError("energy", "the energy lost must be >= 0")
    with np.errstate(invalid="ignore", divide="ignore"):
        if v1 is not None:
            v1a, v2a = np.asarray(v1, float), np.asarray(v2, float)
            vc = v1a - v2a
            e_afc = 0.5 * mu * vc ** 2
            if e is None:
                e = np.sqrt(1.0 - E / e_afc)  # NaN where more is lost than was available
        else:
            vc = np.sqrt(2.0 * E / (mu * (1.0 - e ** 2)))
            e_afc = 0.5 * mu * vc ** 2
            v1a = v2a = np.nan
        dv1 = -(1.0 + e) * m2 * vc / (m1 + m2)
        dv2 = (1.0 + e) * m1 * vc / (m1 + m2)
        lost = (1.0 - e ** 2) * e_afc
    return MER(_out(dv1), _out(dv2), _out(vc), _out(e), _out(e_afc), _out(lost),
               _out(v1a + dv1), _out(v2a + dv2))


def mer_for(obj, *, contact: int = 0) -> MER:
    """MER ΔVs for a two-vehicle scene or result, to set beside the simulation.

    The speeds are those at first contact (the closing speed of the first impact), never those
    at t = 0: with braking before the touch they differ. For a :class:`~lsc.Result` they are read
    off its first impact, and the restitution is the one the simulation achieved by its energies
    (``restitution_energy``, Eq. 10, independent of the simulated velocities); for a scene with
    no braking whose unloading is given as ``restitution`` they are the scene's speeds (nothing
    acts before the touch) and that value; any other scene is solved first.
    Tyre forces during the impact (``brake``) are outside MER: with them the two differ.
    """
    from ..result import Result

    if not isinstance(obj, Result):
        scene = Scene.load(obj)
        _two(scene)
        u = getattr(scene.contacts[contact].law, "unloading", None)
        if isinstance(u, Restitution) and not any(v.brake is not None for v in scene.vehicles):
            (m1, m2), (v1, v2) = scene.masses, scene.speeds
            return mer(m1, m2, v1, v2, restitution=u.e)
        from ..api import solve
        obj = solve(scene)
    _two(obj.scene)
    touch = _first_impact(obj, contact)
    m1, m2 = obj.scene.masses
    v1, v2 = touch.v_start
    return mer(m1, m2, v1, v2, restitution=float(obj.restitution_energy[contact]))


def _first_impact(result, contact: int):
    impact = next((m for m in result.impacts if m.contact == contact), None)
    if impact is None:
        raise SceneError(f"contacts[{contact}]", "the vehicles never touch: there is no impact "
                         "for MER")
    return impact


def _two(scene: Scene) -> None:
    if scene.n_vehicles != 2:
        raise SceneError("vehicles", f"MER applies to two vehicles, the scene has {scene.n_vehicles}")


def format_mer(result) -> str | None:
    """Lines to print beside ``lsc run``'s summary: the MER ΔVs next to the simulated ones
    (``None`` for scenes other than two vehicles)."""
    if result.scene.n_vehicles != 2:
        return None
    m = mer_for(result)
    s = result.scene
    unit = s.unit("velocity")
    names = [v.name for v in s.vehicles]
    touch = _first_impact(result, 0)
    lines = [f"MER cross-check (momentum with e = {m.restitution:.6g}, the simulated energy "
             f"restitution, from the speeds at first contact, t = {touch.t_start:.6g} "
             f"{s.unit('time')}: closing speed {m.closing_speed:.6g} {unit}):"]
    for n, dv_m, dv_s in zip(names, (m.delta_v1, m.delta_v2), result.delta_v):
        lines.append(f"  {n}: delta_v {dv_m:+.6g} {unit} (MER), {dv_s:+.6g} {unit} (simulation), "
                     f"difference {dv_s - dv_m:+.2g}")
    if any(v.brake is not None for v in s.vehicles):
        lines.append("  (tyre forces act in the simulation and not in MER: they differ by the "
                     "braking impulse during the impact)")
    return "\n".join(lines)
