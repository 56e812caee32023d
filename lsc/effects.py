"""Vehicle and contact effects a scene may name: braking (tyre friction) and bumper failure.

Like the contact laws (:mod:`lsc.contact`), each effect is plain array code for NumPy and
``jax.numpy`` with a small discrete state that changes only at events, and every event function
crosses zero downward. The model assembles an effect only when the scene declares it, so a scene
without brakes evaluates no friction term and registers no stop or break-away event.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BrakeEffect", "FailureEffect"]


def _sel(cond, a: dict, b: dict, xp) -> dict:
    """Field-wise ``where(cond, a, b)`` (a plain pick on NumPy with a scalar ``cond``)."""
    if xp is np and np.ndim(cond) == 0:
        src = a if cond else b
        return {k: src[k] for k in a}
    return {k: xp.where(cond, a[k], b[k]) for k in a}


class BrakeEffect:
    """Coulomb friction at the tyres of vehicle ``i``: ``μ m g`` against the motion.

    Discrete state: ``mode`` 1 sliding (``dir`` = the direction of motion, ±1) or 0 stuck. A
    sliding vehicle decelerates at ``μ g`` until its velocity reaches zero; there it sticks if the
    net contact force is at most ``μ_s m g`` and otherwise slides the way the force pushes. A stuck
    vehicle breaks away when the net contact force exceeds ``μ_s m g``.
    """

    event_kinds = ("stop", "break_forward", "break_backward")
    #: What a scene with this effect uses (:meth:`lsc.model.HybridModel.features`).
    feature = "effect:brake"

    def __init__(self, i: int, brake, g: float):
        self.i = i
        self.params = {"mu": np.asarray(float(brake.mu)), "mus": np.asarray(float(brake.mu_static)),
                       "g": np.asarray(float(g))}

    @staticmethod
    def accel(net, m, st, p):
        """Acceleration of the vehicle [acceleration] from the net contact force ``net``."""
        return st["slide"] * (net / m - p["mu"] * p["g"] * st["dir"])

    @staticmethod
    def events(v, net, m, st, p):
        """(velocity through zero while sliding, break-away forward, break-away backward)."""
        slide = st["slide"]
        limit = p["mus"] * m * p["g"]
        return (slide * st["dir"] * v + (1.0 - slide),
                (1.0 - slide) * (limit - net) + slide,
                (1.0 - slide) * (limit + net) + slide)

    @staticmethod
    def armed(st) -> tuple:
        """Which events can fire in this state."""
        s = bool(st["slide"])
        return (s, not s, not s)

    def event_linear(self, laws) -> tuple:
        """Which events are linear in the state, given the contact ``laws``: the stop (its
        velocity) always; the break-aways (the net contact force) when the forces of the
        contacts on either side are affine."""
        near = laws[max(self.i - 1, 0): self.i + 1]
        affine = all(law.affine_force for law in near)
        return (True, affine, affine)

    def _settle(self, v, net, m, p, xp) -> dict:
        """State of a vehicle at velocity ``v`` under net contact force ``net``."""
        moving = v != 0
        pushed = abs(net) > p["mus"] * m * p["g"]
        slide = moving | pushed
        direction = xp.where(moving, xp.sign(v), xp.where(pushed, xp.sign(net), 0.0))
        return {"mode": xp.where(slide, 1, 0), "slide": xp.where(slide, 1.0, 0.0),
                "dir": direction * 1.0, "status": xp.asarray(0)}

    def init(self, v, net, m, p, xp=np) -> dict:
        """State at t = 0."""
        return self._settle(v, net, m, p, xp)

    def on_event(self, which, v, net, m, st, p, xp=np) -> dict:
        """State after event ``which`` (0 stop, 1 break forward, 2 break backward)."""
        stop = self._settle(xp.asarray(0.0), net, m, p, xp)
        fwd = {"mode": xp.asarray(1), "slide": xp.asarray(1.0), "dir": xp.asarray(1.0),
               "status": xp.asarray(0)}
        back = dict(fwd, dir=xp.asarray(-1.0))
        return _sel(which == 0, stop, _sel(which == 1, fwd, back, xp), xp)

    @staticmethod
    def event_name(which: int, before: dict, after: dict) -> str:
        """Name of what happened."""
        if which == 0:
            return "stop" if not float(after["slide"]) else "reversal"
        return "break_away"


class FailureEffect:
    """Bumper failure at contact ``k``: the event fires when the contact force first exceeds the
    failure ``force`` [force]; the result reports whether and when. (A failure with a
    post-failure curve is not this effect: the IF-D law follows the spliced curve and reports
    the failure at its failure point, see :class:`~lsc.contact.HysteresisLaw`.)"""

    event_kinds = ("failure",)
    #: What a scene with this effect uses (:meth:`lsc.model.HybridModel.features`).
    feature = "effect:failure"

    def __init__(self, k: int, failure):
        self.k = k
        self.params = {"force": np.asarray(float(failure.force))}

    @staticmethod
    def events(F, st, p):
        """(failure force minus contact force,), armed until the bumper has failed."""
        return ((1.0 - st["failed"]) * (p["force"] - F) + st["failed"],)

    @staticmethod
    def armed(st) -> tuple:
        return (not bool(st["failed"]),)

    def event_linear(self, laws) -> tuple:
        """Whether the event (failure force less the contact force) is linear in the state:
        when the contact's force is affine."""
        return (bool(laws[self.k].affine_force),)

    def init(self, F, p, xp=np) -> dict:
        """State at t = 0 (failed already if the force starts above the failure force)."""
        return {"mode": xp.asarray(0), "failed": xp.where(F > p["force"], 1.0, 0.0),
                "status": xp.asarray(0)}

    @staticmethod
    def on_event(which, F, st, p, xp=np) -> dict:
        """The bumper has failed."""
        return dict(st, failed=xp.asarray(1.0))

    @staticmethod
    def event_name(which: int, before: dict, after: dict) -> str:
        return "failure"
