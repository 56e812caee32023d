"""Vehicle and contact effects a scene may name: braking (tyre friction), bumper failure, and any
registered vehicle effect.

Like the contact laws (:mod:`lsc.laws`), each effect is plain array code for NumPy and
``jax.numpy`` with a small discrete state that changes only at events, and every event function
crosses zero downward. The model assembles an effect only when the scene declares it, so a scene
without brakes evaluates no friction term and registers no stop or break-away event.

Each effect declares itself: the table it is given in (``brake = {...}`` in a vehicle,
``failure = {...}`` in a contact), its scene keys (``params_declared``, :class:`~lsc.laws.Param`),
how it reads them (``read``), its model numbers (``build``), the feature it adds to a scene
(``feature``) and whether the generic integrators (SciPy, diffrax) solve it (``integrable``). A
new vehicle effect is one :class:`VehicleEffect` subclass, added with
:func:`register_vehicle_effect`.
"""

from __future__ import annotations

from collections.abc import Set
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .curves import Curve
from .errors import SceneError
from .laws import Hysteresis, Param, laws
from .laws._common import select as _sel

__all__ = ["Brake", "Failure", "VehicleEffect", "BrakeEffect", "FailureEffect",
           "register_vehicle_effect", "unregister_vehicle_effect", "vehicle_effect_classes",
           "vehicle_effects", "integrable_features"]


@dataclass(frozen=True)
class Brake:
    """Coulomb tyre friction on one vehicle: kinetic ``mu`` and static ``mu_static`` (>= mu)."""

    mu: float
    mu_static: float


@dataclass(frozen=True)
class Failure:
    """Bumper failure: the contact ``force`` [force] above which a bumper is deemed to fail, and an
    optional loading curve ``post_failure`` to follow after failure (IF-D law only).

    With ``post_failure`` the bumper fails where its loading curve first reaches ``force``, at
    deformation ``D_f``; loading then goes on along ``post_failure`` counted from there,
    ``F = post_failure(D - D_f)`` (the force may step at ``D_f``; see
    :meth:`~lsc.curves.Curve.splice`)."""

    force: float
    post_failure: Curve | None = None


class VehicleEffect:
    """A force on one vehicle ``i`` beside the contact forces (the base of vehicle effects).

    A subclass declares ``table`` (its key in a vehicle's table), ``example`` (a sample of that
    table, for messages), ``params_declared`` (its keys), ``feature`` (what a scene with it
    uses, ``"effect:<name>"``) and ``integrable`` (whether SciPy and diffrax solve it from its
    array code), and implements :meth:`build` (its model numbers) and :meth:`accel`; an effect
    with events also gives ``event_kinds``, :meth:`events`, :meth:`armed`, :meth:`on_event` and
    :meth:`event_name`. Its discrete state holds at least ``mode`` (0: the crash may end with
    it in this state) and ``status``.
    """

    table = ""
    example = ""
    #: What it is, in a few words (the scene schema's description of its table).
    summary = ""
    params_declared: tuple[Param, ...] = ()
    feature = ""
    integrable = False
    event_kinds: tuple[str, ...] = ()

    def __init__(self, i: int, spec, g: float):
        self.i = i
        self.spec = spec
        self.params = {k: np.asarray(v) for k, v in self.build(dict(spec), g, np).items()}

    # ------------------------------------------------------------------ declaration
    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The keys of its table."""
        return tuple(p.key for p in cls.params_declared)

    @classmethod
    def read(cls, value, path: str, reader):
        """Its description from its table in a vehicle (``reader``: the scene loader's): the
        declared keys read in order, as a read-only mapping key → value."""
        spec = reader.table(value, path, cls.keys(), cls.example)
        values = {}
        for p in cls.params_declared:
            values[p.key] = reader.param(spec, p, path, values)
        return MappingProxyType(values)

    @staticmethod
    def build(values: dict, g, xp) -> dict:  # pragma: no cover - every effect implements it
        """Model numbers from its keys' ``values`` and gravity ``g`` (array code)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ the force
    @staticmethod
    def accel(net, m, st, p):  # pragma: no cover - every effect implements it
        """Acceleration of the vehicle [acceleration] from the net contact force ``net``."""
        raise NotImplementedError

    @staticmethod
    def events(v, net, m, st, p):
        """Its event functions (none by default)."""
        return ()

    @staticmethod
    def armed(st) -> tuple:
        """Which events can fire in this state."""
        return ()

    def event_linear(self, laws) -> tuple:
        """Which events are linear in the state."""
        return ()

    def init(self, v, net, m, p, xp=np) -> dict:
        """State at t = 0."""
        return {"mode": xp.asarray(0), "status": xp.asarray(0)}


class BrakeEffect(VehicleEffect):
    """Coulomb friction at the tyres of vehicle ``i``: ``μ m g`` against the motion.

    Discrete state: ``mode`` 1 sliding (``dir`` = the direction of motion, ±1) or 0 stuck. A
    sliding vehicle decelerates at ``μ g`` until its velocity reaches zero; there it sticks if the
    net contact force is at most ``μ_s m g`` and otherwise slides the way the force pushes. A stuck
    vehicle breaks away when the net contact force exceeds ``μ_s m g``.
    """

    event_kinds = ("stop", "break_forward", "break_backward")
    #: What a scene with this effect uses (:meth:`lsc.model.HybridModel.features`).
    feature = "effect:brake"
    table = "brake"
    example = "{ mu = 0.7, mu_static = 0.8 }"
    summary = "Coulomb tyre friction"
    integrable = True
    params_declared = (
        Param("mu", "dimensionless", "kinetic tyre friction coefficient", minimum=0.0,
              bounded=True),
        Param("mu_static", "dimensionless", "static friction coefficient (>= mu; default mu)",
              default=lambda values: values["mu"], bounded=True, schema=(0, False, None)),
    )

    def __init__(self, i: int, brake, g: float):
        self.i = i
        self.spec = brake
        self.params = {k: np.asarray(v) for k, v in
                       self.build({"mu": brake.mu, "mu_static": brake.mu_static}, g, np).items()}

    @classmethod
    def read(cls, value, path: str, reader) -> Brake:
        """Its :class:`Brake` from a vehicle's ``brake`` table."""
        values = super().read(value, path, reader)
        if values["mu_static"] < values["mu"]:
            raise SceneError(f"{path}.mu_static", f"must be >= mu ({values['mu']:g}), got "
                                                  f"{values['mu_static']:g}")
        return Brake(values["mu"], values["mu_static"])

    @staticmethod
    def build(values, g, xp):
        return {"mu": xp.asarray(values["mu"], float), "mus": xp.asarray(values["mu_static"], float),
                "g": xp.asarray(g, float)}

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
    table = "failure"
    example = '{ force = "5000 lbf" }'
    integrable = True
    params_declared = (Param("force", "force", "the force above which the bumper fails",
                             minimum=0.0),)
    #: Its keys besides the declared numbers: a loading curve to follow after failure.
    table_keys = ("force", "post_failure")

    def __init__(self, k: int, failure):
        self.k = k
        self.params = {"force": np.asarray(float(failure.force))}

    @classmethod
    def read(cls, value, path: str, reader, law) -> Failure:
        """Its :class:`Failure` from a contact's ``failure`` table; ``law``: the contact law's
        description (a post-failure curve applies to the IF-D law only)."""
        spec = reader.table(value, path, cls.table_keys, cls.example)
        force = reader.param(spec, cls.params_declared[0], path, {})
        post = None
        if "post_failure" in spec:
            pp = f"{path}.post_failure"
            if not isinstance(law, Hysteresis):
                raise SceneError(pp, f'a post-failure loading curve applies to the IF-D law (the '
                                     f'default, law = "hysteresis"), not to law = "{law.name}"; '
                                     f'remove it (the failure force alone is reported)')
            post, _ = reader.loading(spec["post_failure"], pp)
            try:
                law.loading.splice(force, post)
            except ValueError as e:
                raise SceneError(pp, str(e)) from None
        return Failure(force, post)

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


# --------------------------------------------------------------------------- registry
#: Vehicle effects by the key of their table in a vehicle (``brake`` first).
_VEHICLE_EFFECTS: dict[str, type] = {"brake": BrakeEffect}


def register_vehicle_effect(cls: type) -> type:
    """Add a vehicle effect class (usable as a decorator): scenes give it as
    ``cls.table = {...}`` in a vehicle."""
    if not cls.table or not cls.feature:
        raise ValueError(f"a vehicle effect needs a table and a feature, {cls.__name__} lacks one")
    _VEHICLE_EFFECTS[cls.table] = cls
    return cls


def unregister_vehicle_effect(table: str) -> None:
    """Remove a vehicle effect added with :func:`register_vehicle_effect` (braking stays)."""
    if table != "brake":
        _VEHICLE_EFFECTS.pop(table, None)


def vehicle_effect_classes() -> dict[str, type]:
    """Every registered vehicle effect: table key → class."""
    return dict(_VEHICLE_EFFECTS)


def vehicle_effects(scene) -> list:
    """The vehicle effects a scene declares, vehicle by vehicle (each vehicle's brake first):
    what the model assembles beside the contact laws."""
    out = []
    for i, v in enumerate(scene.vehicles):
        if v.brake is not None:
            out.append(BrakeEffect(i, v.brake, scene.g))
        for table, spec in getattr(v, "effects", ()):
            out.append(_VEHICLE_EFFECTS[table](i, spec, scene.g))
    return out


class _IntegrableFeatures(Set):
    """A live set of features: the given built-in ones and the ``feature`` of every registered
    law and effect that declares ``integrable`` (read when asked, so a part registered later
    counts)."""

    def __init__(self, builtin):
        self._builtin = frozenset(builtin)

    def _now(self) -> frozenset:
        added = {f"law:{name}" for name, cls in laws().items()
                 if getattr(cls, "integrable", False) and name != "hysteresis"}
        added |= {cls.feature for cls in _VEHICLE_EFFECTS.values() if cls.integrable}
        return self._builtin | added

    def __contains__(self, feature) -> bool:
        return feature in self._now()

    def __iter__(self):
        return iter(sorted(self._now()))

    def __len__(self) -> int:
        return len(self._now())

    __hash__ = object.__hash__

    @classmethod
    def _from_iterable(cls, it):
        return frozenset(it)

    def __repr__(self) -> str:
        return f"integrable_features({sorted(self._now())})"


def integrable_features(builtin) -> Set:
    """What the generic integrators (SciPy, diffrax) solve: the ``builtin`` features and those
    of every registered contact law and vehicle effect whose class declares
    ``integrable = True`` (a live set: parts registered later are in it)."""
    return _IntegrableFeatures(builtin)
