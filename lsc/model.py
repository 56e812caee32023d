"""A scene as a hybrid ODE: continuous state, discrete modes, right-hand side and events.

The continuous state is ``y = (x_1..x_N, v_1..v_N)``, with ``x_i`` the displacement of vehicle
``i`` from where it starts [length] and ``v_i`` its velocity [velocity]; vehicles are listed rear
to front. Contact ``k`` joins vehicles ``k`` and ``k+1``; its deformation is
``D_k = x_k - x_{k+1} - gap_k`` and its force ``F_k >= 0`` pushes vehicle ``k`` back and vehicle
``k+1`` forward.

Only the effects a scene declares are assembled: the model holds one law object per contact (see
:mod:`lsc.contact`) and nothing else, so the right-hand side evaluates no dormant term and
registers no dormant event. Every method takes the array namespace ``xp`` (``numpy`` or
``jax.numpy``) so that all backends run this one copy of the physics.
"""

from __future__ import annotations

import numpy as np

from .contact import STATUS, make_law
from .errors import SimulationError

__all__ = ["HybridModel"]


class HybridModel:
    """The hybrid system of a :class:`~lsc.scene.Scene`.

    Attributes
    ----------
    N, K : int
        Number of vehicles and of contacts.
    laws : list
        One contact-law object per contact.
    params : dict
        Numeric parameters (a pytree of arrays): ``m`` (N,) [mass], ``gap`` (K,) [length],
        ``contacts`` (list of each law's parameter dict).
    events : list of (k, which)
        Event ``i`` is event ``which`` of contact ``k``; all cross zero downward.
    """

    def __init__(self, scene):
        self.scene = scene
        self.N = scene.n_vehicles
        self.K = len(scene.contacts)
        self.laws = [make_law(c) for c in scene.contacts]
        self.params = {
            "m": scene.masses,
            "v0": scene.speeds,
            "gap": np.array([c.gap for c in scene.contacts], dtype=float),
            "contacts": [law.params for law in self.laws],
        }
        self.events = [(k, w) for k, law in enumerate(self.laws) for w in range(len(law.event_kinds))]
        v = scene.speeds
        self.v_scale = float(max(np.max(np.abs(v)), np.max(np.abs(np.diff(v))), 1e-300))

    # ------------------------------------------------------------------ kinematics
    def deformation(self, y, p, xp=np):
        """Deformations ``D`` (K,) [length] and closing rates ``Ddot`` (K,) [velocity]."""
        N = self.N
        x, v = y[:N], y[N:]
        return x[:-1] - x[1:] - p["gap"], v[:-1] - v[1:]

    def initial(self, p=None, xp=np):
        """Initial continuous state ``y0`` (2N,) and discrete state (list of per-contact dicts)."""
        p = self.params if p is None else p
        y0 = xp.concatenate([xp.zeros(self.N), xp.asarray(p["v0"], dtype=float)])
        D, Dd = self.deformation(y0, p, xp)
        disc = [law.init(D[k], Dd[k], p["contacts"][k], xp) for k, law in enumerate(self.laws)]
        return y0, disc

    # ------------------------------------------------------------------ smooth pieces
    def forces(self, y, disc, p, xp=np):
        """Contact forces (K,) [force] in the frozen discrete state."""
        D, Dd = self.deformation(y, p, xp)
        return xp.stack([law.force(D[k], Dd[k], disc[k]) for k, law in enumerate(self.laws)])

    def net_forces(self, F, xp=np):
        """Net force on each vehicle (N, ...) [force] from the contact forces ``F`` (K, ...)."""
        z = xp.zeros((1,) + tuple(F.shape[1:]), dtype=F.dtype)
        return xp.concatenate([z, F]) - xp.concatenate([F, z])

    def rhs(self, t, y, disc, p, xp=np):
        """``dy/dt = (v, a)`` with ``m_i a_i = F_{i-1} - F_i``."""
        F = self.forces(y, disc, p, xp)
        a = self.net_forces(F, xp) / p["m"]  # (N,)
        return xp.concatenate([y[self.N:], a])

    def event_values(self, t, y, disc, p, xp=np):
        """All event functions (n_events,), each crossing zero downward when it fires."""
        D, Dd = self.deformation(y, p, xp)
        vals = []
        for k, law in enumerate(self.laws):
            vals.extend(law.events(D[k], Dd[k], disc[k]))
        return xp.stack([xp.asarray(g, dtype=float) for g in vals])

    def active_events(self, disc) -> list[int]:
        """Indices of the events armed in this discrete state (NumPy backends skip the others)."""
        out = []
        for i, (k, w) in enumerate(self.events):
            st = disc[k]
            if w == 0 and st["lo"] <= -1e299:
                continue
            if w == 1 and st["hi"] >= 1e299:
                continue
            if w == 2 and st["vm"] == 0:
                continue
            out.append(i)
        return out

    # ------------------------------------------------------------------ transitions
    def apply_event(self, i: int, t, y, disc, p, xp=np):
        """Discrete state after event ``i`` at state ``y``; other contacts are unchanged."""
        k, w = self.events[i]
        D, Dd = self.deformation(y, p, xp)
        new = list(disc)
        new[k] = self.laws[k].on_event(w, D[k], Dd[k], disc[k], p["contacts"][k], xp)
        return new

    def event_name(self, i: int, before, after) -> str:
        """What event ``i`` was, from the discrete state before and after it."""
        k, w = self.events[i]
        return self.laws[k].event_name(w, before[k], after[k])

    def check_status(self, disc, t: float) -> None:
        """Raise :class:`SimulationError` if a contact reached a state the physics cannot complete."""
        for k, st in enumerate(disc):
            code = int(st["status"])
            if code:
                raise SimulationError(f"contact {k} at t = {t:.6g} s: {STATUS[code]}")

    def is_over(self, y, disc) -> bool:
        """True when every contact is open and none is closing (no force acts any more)."""
        if any(int(st["mode"]) != 0 for st in disc):
            return False
        _, Dd = self.deformation(np.asarray(y), self.params)
        return bool(np.all(Dd <= 1e-12 * self.v_scale))

    # ------------------------------------------------------------------ scales
    def time_scale(self) -> float:
        """A rough contact time [s] from the stiffest loading slope and the lightest pair."""
        m = self.params["m"]
        mu = np.min(m[:-1] * m[1:] / (m[:-1] + m[1:]))
        slopes = []
        for law in self.laws:
            ls = law.params.get("ls")
            if ls is not None:
                slopes.extend(np.abs(ls[np.isfinite(ls)]))
            if "su" in law.params:
                slopes.append(float(law.params["su"]))
        k = max([s for s in slopes if s > 0] or [1.0])
        return float(np.sqrt(mu / k))

    @staticmethod
    def to_python(disc) -> list[dict]:
        """A NumPy discrete state as plain Python scalars (fast in the NumPy right-hand side)."""
        out = []
        for st in disc:
            out.append({key: (int(v) if key in ("mode", "seg", "status") else float(v))
                        for key, v in st.items()})
        return out
