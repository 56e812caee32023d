"""The SciPy integrator of a solve that names none: DOP853, or Radau where a damping law's rebound
is stiffer than an explicit integrator follows at the tolerance asked for.

A spring–dashpot contact restoring from its max deformation is held at the speed where its
damping term cancels its spring, ``F(D, -v_h) = 0``: ``v_h = F(D, 0) / (∂F/∂Ḋ)``, Hunt–Crossley
``1/α``, Brach ``k/c2``, Kelvin ``k D/c`` (at ``D = μ v0/c``, where the dashpot alone stops the
closing speed ``v0``: ``v_h = v0/(4ζ²)``). Over the closing speed it is of the order of the
restitution at a small one (``e`` itself as ``e → 0``, for all three). The restoring factor
``F / F(D, 0)`` relaxes to zero at the rate ``λ = (∂F/∂Ḋ)/μ``, about ``1/e`` times the contact's
frequency; an explicit step is stable only for ``h λ`` of a few, and past it the relaxation grows
from step to step. The step-size control sees that growth only once it exceeds the velocity
tolerance (the speed scale times ``rtol``, or ``atol``); where ``v_h`` is below it, the growth
reverses ``Ḋ`` first, and the contact recompresses and turns over and over to the event limit
(DOP853 at ``rtol = 1e-10``: Hunt–Crossley, Kelvin and Brach at every ``e`` from 1e-15 to 1e-11,
and at some up to 50 ``rtol``: 1.2e-9 to 1.8e-9 for Hunt–Crossley, 3e-10 to 8e-10 for Kelvin,
4.6e-9 for Brach; at ``rtol = 1e-6``, Kelvin at 2.6e-4 too, which :data:`HOLD_FACTOR` leaves
to DOP853). Radau, implicit and L-stable, follows the relaxation at any step: it solves those
scenes (Hunt–Crossley: ΔV to 1e-15, max deformation and absorbed energy to 1e-12 and peak force
to 3e-11 of the energy relations, where DOP853 at ``e >= 1e-9`` is at 4e-10 and 1.5e-9).

Not where the hold speed is below :data:`FLOOR` of the closing speed: there DOP853 finishes
(Hunt–Crossley and Kelvin at every ``e`` tried from 1e-20 to 1e-300, as before), while Radau's
finite-difference Jacobian overflows (Hunt–Crossley from ``e`` ≈ 1e-150); Radau solves every
``e`` tried from 1e-30 to 1e-7 with all three laws (Brach below 1e-30 neither solves).

Two vehicles only: in a chain Radau is not yet shown right (a 3-vehicle Hunt–Crossley chain at
``e = 1e-12``, its contacts touching at t = 0: Radau's totals are the plastic ΔV, but it splits
the second contact into an impact of 1e-12 s at zero closing speed and a later one, so the last
vehicle's ΔV, that of its first impact, is 0 where BDF gives one impact and 1.35 m/s), so a
chain keeps DOP853 and its event-limit message.
"""

from __future__ import annotations

import numpy as np

from ..laws import BrachLaw, HuntCrossleyLaw, KelvinLaw

__all__ = ["DEFAULT", "STIFF", "HOLD_FACTOR", "FLOOR", "hold_speed", "stiff_contacts",
           "integrator_for"]

#: The integrator of a solve that names none, where no contact is stiff.
DEFAULT = "DOP853"
#: The integrator of a solve that names none, where a contact is stiff (:func:`stiff_contacts`).
STIFF = "Radau"
#: Below this fraction of the closing speed a hold speed is not stiff (DOP853 finishes, Radau's
#: Jacobian may overflow: the module's docstring).
FLOOR = 1e-30
#: A contact is stiff where its hold speed is below this many velocity tolerances (DOP853 chatters
#: sporadically up to 50, the module's docstring).
HOLD_FACTOR = 100.0


def _hunt_crossley(st, v0, mu):
    return 1.0 / st["c"]                      # 1 + α Ḋ = 0


def _brach(st, v0, mu):
    return st["k"] / st["c"]                  # k + c2 Ḋ = 0 (c = c2 restoring)


def _kelvin(st, v0, mu):
    return st["k"] * mu * v0 / st["c"] ** 2   # k D + c Ḋ = 0 at D = μ v0 / c


#: Each damping law's hold speed [velocity] from its restoring state ``st`` (its coefficients
#: set by the law's own transitions), the closing speed ``v0`` and the pair's reduced mass ``mu``.
_HOLD = {HuntCrossleyLaw: _hunt_crossley, BrachLaw: _brach, KelvinLaw: _kelvin}


def hold_speed(law, v0: float, mu: float) -> float | None:
    """The speed [velocity] at which ``law``'s damping holds its contact restoring after closing
    at ``v0`` [velocity] (the pair's reduced mass ``mu`` [mass]): ``inf`` with no damping,
    ``None`` for a law without one (IF-D, a registered law)."""
    hold = _HOLD.get(type(law))
    if hold is None:
        return None
    p = law.params
    st = law.init(0.0, v0, p, np, mu)             # compressing, its damping set at contact
    st = law.on_event(1, 0.0, 0.0, st, p, np, mu)  # restoring, from its max deformation
    with np.errstate(divide="ignore"):
        return float(hold(st, v0, mu))


def stiff_contacts(model, rtol: float, atol: float | None = None) -> list[tuple[int, float]]:
    """``(contact, hold speed)`` of each damping-law contact of ``model`` whose hold speed
    (:func:`hold_speed`) is below :data:`HOLD_FACTOR` times the velocity tolerance of a SciPy
    solve at ``rtol`` (``atol``, or the speed scale times ``rtol``: the model's default), and
    not below :data:`FLOOR` of the closing speed: the initial one (or the speed scale where the
    pair does not close). Two vehicles only (none for a chain: the module's docstring)."""
    v = np.asarray(model.params["v0"], float)
    m = np.asarray(model.params["m"], float)
    scale = float(model.speed_scale())
    v0 = float(np.max(v[:-1] - v[1:], initial=0.0)) or scale
    tol = float(atol) if atol is not None else rtol * scale
    mu = m[:-1] * m[1:] / (m[:-1] + m[1:])
    if model.N != 2:   # (chains: the module's docstring)
        return []
    out = []
    for k, law in enumerate(model.laws):
        h = hold_speed(law, v0, float(mu[k]))
        if h is not None and FLOOR * v0 <= h < HOLD_FACTOR * tol:
            out.append((k, h))
    return out


def integrator_for(model, rtol: float, atol: float | None = None) -> str:
    """The SciPy integrator of a solve of ``model`` that names none: :data:`STIFF` where a
    contact is stiff at ``rtol`` and ``atol`` (:func:`stiff_contacts`), else :data:`DEFAULT`."""
    return STIFF if stiff_contacts(model, rtol, atol) else DEFAULT
