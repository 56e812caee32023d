"""Spring–dashpot contact laws (the paper's "spring/dashpot" family), tension-free: one class per
law on the shared base :class:`SpringDashpotLaw`.

``kelvin``: ``F = k D + c Ḋ``; ``hunt-crossley``: ``F = k D^n (1 + α Ḋ)``; ``brach``:
``F = k D + c D Ḋ`` with ``c = c1`` while compressing and ``c2`` while restoring. A new law of
this family is one subclass: its name, its scene keys (:class:`~lsc.laws.Param`), its model
numbers (:meth:`SpringDashpotLaw.numbers`) and its force (:meth:`SpringDashpotLaw.spring_force`),
registered with :func:`lsc.laws.register_law`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..units import register_kind
from ._common import MODE_LOADING, MODE_OPEN, MODE_UNLOADING, Param
from ._common import select as _sel
from ._common import smooth_min as _min
from .relations import (MIN_RESTITUTION, brach_c2, finite_slope, hunt_crossley_a,
                        kelvin_dlne_dzeta, kelvin_zeta)

__all__ = ["Damping", "SpringDashpotLaw", "KelvinLaw", "HuntCrossleyLaw", "BrachLaw"]


@dataclass(frozen=True)
class Damping:
    """A spring–dashpot contact law's description (an effect a scene names with ``law = ...``).

    ``law``: its name (``"kelvin"``, ``"hunt-crossley"``, ``"brach"``, or a registered one);
    ``stiffness`` k [force/length^n], ``exponent`` n (Hunt–Crossley), ``damping``: Kelvin c
    [force·time/length], Hunt–Crossley α [time/length], Brach c1 [force·time/length²];
    ``damping_restitution``: Brach c2; or ``restitution``: the target e, converted by the law's
    own relation.
    """

    law: str
    stiffness: float
    exponent: float = 1.0
    damping: float | None = None
    damping_restitution: float | None = None
    restitution: float | None = None

    @property
    def name(self) -> str:
        """The law's name."""
        return self.law


def _target_restitution(e: float) -> str | None:
    if not MIN_RESTITUTION <= e <= 1:
        return (f"a damping law's target restitution must be in [{MIN_RESTITUTION!r}, 1] "
                "(e = 0 needs an infinite damping; below the smallest normal float64 the laws' "
                "dampings overflow: Hunt-Crossley's a tends to 1/e, Kelvin's ratio to "
                f"1/(2 sqrt(e))), got {e!r}")
    return None


#: The keys the spring–dashpot laws share.
STIFFNESS = Param("stiffness", "stiffness", "k: force/length (Hunt–Crossley: force/length^n)",
                  minimum=0.0)
RESTITUTION = Param("restitution", "dimensionless", "the target coefficient of restitution e, "
                    "converted to the damping by the law's own relation", default=None,
                    check=_target_restitution, schema=(MIN_RESTITUTION, False, 1))


def _one_of_damping_or_restitution(law: str) -> str:
    return (f"the {law} law needs exactly one of damping or restitution (the target e, converted "
            "by the law's own relation)")


def _as_float(x, xp):
    return xp.asarray(x, float)


class SpringDashpotLaw:
    """A spring–dashpot law: a force ``F(D, Ḋ) >= 0`` while in contact, no memory but its modes.

    Modes: open, compressing (``Ḋ > 0``), restoring (``Ḋ < 0``). The contact separates when the
    force reaches zero (or ``D`` returns to 0) and closes again when ``D`` comes back above 0.
    The work done on the contact, ``∫ F dD``, is integrated with the motion (one extra state),
    so the absorbed and returned energies are exact to the solver tolerance.

    A subclass declares ``name``, ``params_declared`` (its scene keys, :class:`Param`),
    ``choice`` (keys of which the scene gives exactly one, and the message otherwise), and
    implements :meth:`numbers` (model numbers from the keys' values, array code) and
    :meth:`spring_force`; it may set the damping coefficient ``c`` at contact
    (:meth:`at_contact`) and on turning (:meth:`at_turn`, :meth:`at_recompress`).
    """

    name = ""
    aliases: tuple[str, ...] = ()
    params_declared: tuple[Param, ...] = ()
    #: (keys of which the scene gives exactly one, the message when it gives none or both)
    choice: tuple = ((), "")
    tracks_work = True
    integrable = True
    depends_on_mass = False
    affine_force = False
    event_kinds = ("separate", "turn", "close", "recompress")

    # ------------------------------------------------------------------ declaration
    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The keys of its contact table."""
        return tuple(p.key for p in cls.params_declared)

    @classmethod
    def read(cls, spec: dict, path: str, reader) -> Damping:
        """The law's description from a contact table: its declared keys read in order (keys
        whose unit depends on others after them, the ``choice`` keys after the choice is
        checked)."""
        choice, message = cls.choice
        plain = [p for p in cls.params_declared if p.key not in choice]
        values = {}
        for p in sorted(plain, key=lambda p: callable(p.kind)):
            values[p.key] = reader.param(spec, p, path, values)
        if choice and sum(key in spec for key in choice) != 1:
            raise SceneError(path, message)
        for p in cls.params_declared:
            if p.key in choice and p.key in spec:
                values[p.key] = reader.param(spec, p, path, values)
        return cls.describe({k: v for k, v in values.items() if v is not None})

    @classmethod
    def describe(cls, values: dict):
        """The law's description (what :attr:`spec` holds) from the values read: a
        :class:`Damping` (a law with keys it has no field for returns its own record, whose
        attributes are its keys)."""
        return Damping(cls.name, **values)

    @classmethod
    def value(cls, spec: Damping, key: str) -> float | None:
        """The number the scene gave (or defaulted) for declared ``key``, or ``None``."""
        return getattr(spec, key, None) if key in cls.keys() else None

    def sweepable(self, key: str) -> bool:
        """Whether :meth:`numbers` can change ``key`` without re-loading the scene."""
        return self.value(self.spec, key) is not None

    def values(self) -> dict:
        """The scene's value of every declared key (``None``: not given)."""
        return {key: self.value(self.spec, key) for key in self.keys()}

    def numbers(self, changes: dict, mu, xp=np) -> dict:
        """The law's model numbers (:attr:`params`) from its keys' values, the scene's with
        ``changes`` (key → array, scene units) in their place; ``mu``: the pair's reduced mass
        [mass]. Array code (a target restitution is converted by a root find on NumPy)."""
        values = {**self.values(), **changes}
        return self.build(values, mu, xp)

    @staticmethod
    def build(values: dict, mu, xp) -> dict:  # pragma: no cover - every law implements it
        """Model numbers from the keys' ``values`` (``None``: not given)."""
        raise NotImplementedError

    def features(self) -> set[str]:
        """What a scene with this law uses (:meth:`lsc.model.HybridModel.features`)."""
        return {f"law:{self.name}"}

    def autodiff_refused(self) -> str | None:
        """Why forward-mode autodiff through a solve with this contact gives no true derivative
        (``None``: it does)."""
        return None

    def __init__(self, spec, mu_pair: float = 1.0):
        self.spec = spec
        self.params = {k: np.asarray(v) for k, v in self.numbers({}, mu_pair, np).items()}

    # ------------------------------------------------------------------ the force
    def spring_force(self, D, Ddot, st):  # pragma: no cover - every law implements it
        """The law's force [force] while in contact (may be negative: the contact separates)."""
        raise NotImplementedError

    def separation_pieces(self, D, Ddot, st) -> tuple:
        """The separation event (the force reaching zero) as the minimum of these functions,
        while in contact; by default the force itself."""
        return (self.spring_force(D, Ddot, st),)

    def force(self, D, Ddot, st):
        """Contact force [force] while in contact (0 when open)."""
        return st["on"] * self.spring_force(D, Ddot, st)

    def events(self, D, Ddot, st):
        """(separation, max compression, closing, re-compression), all crossing downward."""
        on, comp, rest = st["on"], st["comp"], 1.0 - st["comp"]
        pieces = self.separation_pieces(D, Ddot, st)
        sep = pieces[0] if len(pieces) == 1 else _min(*pieces)
        return (on * sep + (1.0 - on),
                on * comp * Ddot + (1.0 - on * comp),
                (1.0 - on) * (-D) + on,
                on * rest * (-Ddot) + (1.0 - on * rest))

    def armed(self, st):
        """Which events can fire in this state (NumPy backends skip the others)."""
        on, comp = bool(st["on"]), bool(st["comp"])
        return (on, on and comp, not on, on and not comp)

    def event_linear(self, laws) -> tuple:
        """Every event is the minimum of linear pieces (:meth:`event_pieces`)."""
        return (True,) * len(self.event_kinds)

    def event_pieces(self, D, Ddot, st):
        """Each event as the minimum of functions of ``(D, Ḋ)`` (:meth:`separation_pieces`)."""
        sep, turn, close, rec = self.events(D, Ddot, st)
        pieces = self.separation_pieces(D, Ddot, st)
        if len(pieces) == 1:
            return (sep,), (turn,), (close,), (rec,)
        on = st["on"]
        return (tuple(on * g + (1.0 - on) for g in pieces), (turn,), (close,), (rec,))

    @staticmethod
    def closing_gap(D, st):
        """While open: the deformation still to close before the contact touches again at
        ``D = 0`` [length] (its ``close`` event, ``-D``)."""
        return -D

    # ------------------------------------------------------------------ transitions
    def extra_state(self, p, xp) -> dict:
        """Law-specific entries of the discrete state (numbers the force reads)."""
        return {}

    def _zero(self, p, xp):
        z = xp.asarray(0.0)
        st = {"mode": xp.asarray(MODE_OPEN), "on": z, "comp": z, "k": xp.asarray(p["k"], float),
              "c": z, "c2": z, "dmax": z, "fmax": z, "dperm": z, "ec": z, "er": z, "wmark": z,
              "status": xp.asarray(0)}
        st.update(self.extra_state(p, xp))
        return st

    def at_contact(self, st, Ddot, p, xp, mu) -> dict:
        """State entries set when the contact (re)starts compressing at closing speed
        ``Ddot`` (the damping coefficient ``c``); by default none."""
        return {}

    def at_turn(self, st, p, xp) -> dict:
        """State entries set at the maximum compression; by default none."""
        return {}

    def at_recompress(self, st, p, xp) -> dict:
        """State entries set when a restoring contact compresses again; by default none."""
        return {}

    def _close(self, st, Ddot, p, xp, mu):
        """Contact (re)starts compressing at closing speed ``Ddot``."""
        out = dict(st)
        one = xp.asarray(1.0)
        out.update(mode=xp.asarray(MODE_LOADING), on=one, comp=one)
        out.update(self.at_contact(out, Ddot, p, xp, mu))
        return out

    def init(self, D, Ddot, p, xp=np, mu=1.0):
        """State at t = 0: compressing if touching and closing, else open."""
        st = self._zero(p, xp)
        return _sel((D >= 0) & (Ddot > 0), self._close(st, Ddot, p, xp, mu), st, xp)

    def on_event(self, which, D, Ddot, st, p, xp=np, mu=1.0, w=0.0):
        """State after event ``which`` (0 separate, 1 max compression, 2 close, 3 re-compress);
        ``w`` is the contact's work integral ``∫F dD`` at the event [energy]."""
        z, one = xp.asarray(0.0), xp.asarray(1.0)
        sep = dict(st)
        sep.update(mode=xp.asarray(MODE_OPEN), on=z, comp=z, dperm=D,
                   er=st["er"] + st["wmark"] - w, wmark=w)
        turn = dict(st)
        F0 = self.force(D, 0.0, dict(st, on=one))
        turn.update(mode=xp.asarray(MODE_UNLOADING), comp=z, dmax=xp.maximum(st["dmax"], D),
                    fmax=xp.maximum(st["fmax"], F0), ec=st["ec"] + w - st["wmark"], wmark=w)
        turn.update(self.at_turn(st, p, xp))
        close = self._close(dict(st, wmark=w), Ddot, p, xp, mu)
        rec = dict(st)
        rec.update(mode=xp.asarray(MODE_LOADING), comp=one, er=st["er"] + st["wmark"] - w,
                   wmark=w)
        rec.update(self.at_recompress(st, p, xp))
        return _sel(which == 0, sep, _sel(which == 1, turn, _sel(which == 2, close, rec, xp), xp), xp)

    @staticmethod
    def event_name(which: int, before: dict, after: dict) -> str:
        """Name of what happened (for ``Result.events``)."""
        return ("separation", "max_deformation", "contact", "recompression")[which]


def _root(fn, values, xp, slope=None):
    """``fn`` (a scalar root find) of each value: on NumPy directly; traced by JAX through
    :func:`traced_root` when the law declares the root's derivative ``slope``."""
    if xp is np:
        return np.vectorize(fn, otypes=[float])(np.asarray(values, float))
    if slope is None:
        raise TypeError("a target restitution is converted by a root find on NumPy; "
                        "it cannot be traced")
    return traced_root(fn, slope, values)


def traced_root(fn, slope, values):
    """``fn(values)`` (a scalar root find on NumPy) as a JAX function whose forward-mode
    derivative is the declared ``slope(value, root)`` (``d root / d value``, by the implicit
    function theorem), computed on the host: JAX sees through neither."""
    import jax
    import jax.numpy as jnp

    def host(f, *args):
        return np.vectorize(f, otypes=[float])(*(np.asarray(a, float) for a in args))

    def call(f, *args):
        shape = jax.ShapeDtypeStruct(jnp.shape(args[0]), jnp.result_type(float))
        return jax.pure_callback(lambda *a: host(f, *a).astype(shape.dtype), shape, *args,
                                 vmap_method="expand_dims")

    @jax.custom_jvp
    def root(v):
        return call(fn, v)

    @root.defjvp
    def _(primals, tangents):
        (v,), (dv,) = primals, tangents
        y = root(v)
        if isinstance(v, jax.core.Tracer):   # under jit: on the host, inside the computation
            return y, call(slope, v, y) * dv
        return y, jnp.asarray(host(slope, v, y)) * dv   # eager: its errors raised as they are

    return root(jnp.asarray(values, float))


class KelvinLaw(SpringDashpotLaw):
    """Kelvin: ``F = k D + c Ḋ`` (the force jumps at t = 0), damping ratio
    ``ζ = c / (2√(kμ))``, or ``ζ`` from a target restitution
    ``e = exp(-2ζ arccos ζ / √(1-ζ²))``."""

    name = "kelvin"
    params_declared = (
        STIFFNESS,
        Param("damping", "damping", "Kelvin's c in F = k D + c dD/dt", default=None,
              minimum=0.0, strict=False,
              hint="Kelvin's c multiplies the closing rate: F = k D + c dD/dt"),
        RESTITUTION)
    choice = (("damping", "restitution"), _one_of_damping_or_restitution("kelvin"))
    affine_force = True

    @property
    def depends_on_mass(self) -> bool:
        """ζ of a damping ``c`` depends on the pair's reduced mass."""
        return self.spec.damping is not None

    @staticmethod
    def build(values, mu, xp):
        k = _as_float(values["stiffness"], xp)
        if values["damping"] is None:
            zeta = _root(kelvin_zeta, values["restitution"], xp, KelvinLaw.dzeta_de)
        else:
            zeta = values["damping"] / (2 * xp.sqrt(k * mu))
        return {"k": k, "zeta": _as_float(zeta, xp)}

    @staticmethod
    def dzeta_de(e: float, zeta: float) -> float:
        """``dζ/de`` of the target-restitution conversion (implicit function theorem on
        ``ln e = -2ζ arccos ζ / √(1-ζ²)``): ``1 / (e · d ln e/dζ)``; ``-1/π`` at ``e = 1``.
        Below e ≈ 1e-205 the derivative ``≈ -1/(4 e^1.5)`` is past the float range: a
        :class:`~lsc.SimulationError`."""
        return finite_slope(1.0 / e / kelvin_dlne_dzeta(zeta), "Kelvin's damping ratio",
                             "-1/(4 e^1.5)", e)

    def spring_force(self, D, Ddot, st):
        return st["k"] * D + st["c"] * Ddot

    def at_contact(self, st, Ddot, p, xp, mu):
        return {"c": 2.0 * p["zeta"] * xp.sqrt(p["k"] * mu)}


class HuntCrossleyLaw(SpringDashpotLaw):
    """Hunt–Crossley: ``F = k D^n (1 + α Ḋ)``; ``α`` given, or ``α = a / v_c`` with
    ``a (1+e) = ln[(1+a)/(1-a e)]`` and ``v_c`` the closing speed at contact."""

    name = "hunt-crossley"
    params_declared = (
        Param("stiffness", lambda values: _stiffness_kind(values["exponent"]), STIFFNESS.doc,
              minimum=0.0),
        Param("damping", "slowness", "Hunt–Crossley's α in F = k D^n (1 + α dD/dt)",
              default=None, minimum=0.0, strict=False,
              hint="Hunt–Crossley's α multiplies the closing rate in F = k D^n (1 + α dD/dt): "
                   "it is not a Kelvin damping c"),
        RESTITUTION,
        Param("exponent", "dimensionless", "Hunt–Crossley's n in F = k D^n (1 + α dD/dt)",
              default=1.0, minimum=0.0))
    choice = (("damping", "restitution"), _one_of_damping_or_restitution("hunt-crossley"))

    @staticmethod
    def build(values, mu, xp):
        given = values["damping"] is not None
        nan = xp.asarray(np.nan)
        a = nan if given else _root(hunt_crossley_a, values["restitution"], xp,
                                    HuntCrossleyLaw.da_de)
        return {"k": _as_float(values["stiffness"], xp), "n": _as_float(values["exponent"], xp),
                "a": _as_float(a, xp), "alpha": _as_float(values["damping"] if given else nan, xp)}

    @staticmethod
    def da_de(e: float, a: float) -> float:
        """``da/de`` of the target-restitution conversion (implicit function theorem on
        ``R = a (1+e) - ln[(1+a)/(1-a e)] = 0``): ``-R_e / R_a``, both times ``q = 1 - a e``
        (which underflows to 0 below e ≈ 0.03: the limit ``-a/e``), ``a² e / ((1 + e - 1/(1+a))
        q - e)``; at ``e = 1`` (``a = 0``) the limit of ``a ≈ 3(1 - e²) / (2(1 + e³))``,
        ``-3/2``. Below e ≈ 1.3e-154 the derivative ``≈ -1/e²`` is past the float range: a
        :class:`~lsc.SimulationError`."""
        if a <= 1e-6:
            return -1.5
        q = 1.0 - a * e
        return finite_slope(a * e * (a / ((1 + e - 1 / (1 + a)) * q - e)), "Hunt-Crossley's a",
                             "-1/e^2", e)

    def extra_state(self, p, xp):
        return {"n": xp.asarray(p["n"], float)}

    def spring_force(self, D, Ddot, st):
        # |D|^n sign(D): the smooth-as-possible continuation below D = 0, where only a step's
        # trial stages go (the separation event at D = 0 ends the segment)
        Dn = abs(D) ** st["n"] * (2.0 * (D >= 0) - 1.0)
        return st["k"] * Dn * (1.0 + st["c"] * Ddot)

    def separation_pieces(self, D, Ddot, st):
        """The earlier of ``D = 0`` and ``1 + α Ḋ = 0``."""
        return (D, 1.0 + st["c"] * Ddot)

    def at_contact(self, st, Ddot, p, xp, mu):
        given = p["alpha"] == p["alpha"]  # not NaN
        a = xp.where(given, 0.0, p["a"])
        return {"c": xp.where(given, xp.where(given, p["alpha"], 0.0),
                              a / xp.where(Ddot > 0, Ddot, 1.0))}


class BrachLaw(SpringDashpotLaw):
    """Brach: ``F = k D + c D Ḋ`` with ``c = c1`` compressing and ``c2`` restoring; ``c2``
    given, or from its energy integral at the closing speed at contact for a target
    restitution."""

    name = "brach"
    params_declared = (
        STIFFNESS,
        Param("damping", "damping_per_length", "Brach's c1 (compressing) in F = k D + c D dD/dt",
              default=0.0, minimum=0.0, strict=False,
              hint="Brach's c multiplies D dD/dt in F = k D + c D dD/dt"),
        RESTITUTION,
        Param("damping_restitution", "damping_per_length", "Brach's c2 (restoring)",
              default=None, minimum=0.0, strict=False,
              hint="Brach's c multiplies D dD/dt in F = k D + c D dD/dt"))
    choice = (("damping_restitution", "restitution"), "Brach's law needs exactly one of "
              "damping_restitution (c2) or restitution (the target e, which sets c2)")

    @staticmethod
    def build(values, mu, xp):
        given = values["damping_restitution"] is not None
        nan = xp.asarray(np.nan)
        return {"k": _as_float(values["stiffness"], xp),
                "c1": _as_float(values["damping"], xp),
                "e": _as_float(nan if given else values["restitution"], xp),
                "c2": _as_float(values["damping_restitution"] if given else nan, xp)}

    def autodiff_refused(self) -> str | None:
        """A target restitution's c2 is found by bisection inside the solve."""
        if self.spec.restitution is None:
            return None
        return ("Brach's law with a target restitution finds its c2 by bisection inside the "
                "solve, which forward-mode autodiff cannot see through: use "
                "method=\"finite-difference\"")

    def spring_force(self, D, Ddot, st):
        return D * (st["k"] + st["c"] * Ddot)

    def separation_pieces(self, D, Ddot, st):
        """The earlier of ``D = 0`` and ``k + c Ḋ = 0``."""
        return (D, st["k"] + st["c"] * Ddot)

    def at_contact(self, st, Ddot, p, xp, mu):
        given = p["c2"] == p["c2"]
        e = xp.where(given, 0.5, p["e"])
        c2, ok = brach_c2(p["k"], p["c1"], e, xp.where(Ddot > 0, Ddot, 1.0), mu, xp)
        c2 = xp.where(given, xp.where(given, p["c2"], 0.0), c2)
        return {"c": xp.asarray(p["c1"], float),
                "c2": xp.where(~given & (e >= 1), p["c1"], c2),
                "status": xp.where(given | ok | (e >= 1), st["status"], 4)}

    def at_turn(self, st, p, xp):
        return {"c": st["c2"]}

    def at_recompress(self, st, p, xp):
        return {"c": xp.asarray(p["c1"], float)}


def _stiffness_kind(n: float) -> str:
    """A unit kind for force/length^n (Hunt–Crossley stiffness), registered on first use."""
    if n == 1.0:
        return "stiffness"
    return register_kind(f"stiffness^{n:g}", f"N/m^{n:g}", f"lbf/ft^{n:g}",
                         (f"60000 lbf/ft^{n:g}", f"5e6 N/m^{n:g}"))
