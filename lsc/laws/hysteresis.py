"""The paper's IF-D hysteresis contact law (:class:`HysteresisLaw`) and its scene description.

Inside any segment the force is affine in ``D``, ``F = fa + s (D - da)``, valid for
``lo <= D <= hi``. The law's scene keys are the ``loading`` curve and the ``unloading`` rule of a
contact; the numbers a study may change without re-loading the scene are declared in
:attr:`HysteresisLaw.params_declared`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..curves import Curve
from ..errors import SceneError
from ._common import BIG, MODE_LOADING, MODE_OPEN, MODE_UNLOADING, REBOUND_RESOLUTION, Param
from ._common import select as _sel


def _lazy(cond, a, b, xp) -> dict:
    """``select(cond, a(), b(), xp)`` for branches given as functions: with a condition known
    now (a Python boolean, on any ``xp``: the event a compiled transition is for; or a NumPy
    boolean scalar, one scene's transition on Python floats or 0-d arrays) only the branch taken
    is evaluated, the same values as evaluating both and picking one (a transition is pure);
    with an array condition, or a NumPy scalar on ``jax.numpy`` (whose branches must agree in
    shape and type), both, then ``select``."""
    if cond is True or cond is False or (isinstance(cond, (np.bool_, np.ndarray))
            and np.ndim(cond) == 0 and not getattr(xp, "__name__", "").startswith("jax")):
        return dict(a() if cond else b())
    if xp is np and isinstance(cond, np.ndarray):
        # (a batch on NumPy whose members all take one branch: the other is not evaluated;
        # each field as select gives it, a new array over the members (a state's fields keep
        # their type whatever the branch))
        every = bool(cond.all())
        if every or not cond.any():
            return {k: np.where(cond, v, v) for k, v in (a() if every else b()).items()}
    return _sel(cond, a(), b(), xp)

__all__ = ["HysteresisLaw", "Hysteresis", "Restitution", "UnloadingStiffness", "UnloadingTable"]


@dataclass(frozen=True)
class Restitution:
    """Straight unloading line to the permanent set that returns ``e**2`` of the absorbed energy."""

    e: float


@dataclass(frozen=True)
class UnloadingStiffness:
    """Straight unloading line of slope ``stiffness`` [force/length] from ``(D_max, F_max)``."""

    stiffness: float


@dataclass(frozen=True, eq=False)
class UnloadingTable:
    """A measured rebound curve in time order, from its start ``(d[0], f[0])`` (``f[0] > 0``) to
    zero force (``f[-1] == 0``), deformation strictly decreasing [length, force]. It is mapped onto
    the simulated start ``(D_max, F_max)``: deformation shifted by ``D_max - d[0]``, force scaled by
    ``F_max / f[0]``."""

    d: np.ndarray
    f: np.ndarray


@dataclass(frozen=True)
class Hysteresis:
    """The paper's IF-D contact law: a loading curve and an unloading rule (``scale``: the factor
    the scene's ``loading.scale`` applied to the loading curve's forces)."""

    loading: Curve
    unloading: Restitution | UnloadingStiffness | UnloadingTable
    scale: float = 1.0
    name = "hysteresis"


def _numbers(c: Curve, u) -> tuple:
    """The law's numbers (:attr:`HysteresisLaw.params` but ``dfail``, as read-only arrays), the
    number of loading pieces, the unloading kind and the unloading template's number of points,
    for loading curve ``c`` and unloading rule ``u``."""
    ld, lf, ls, le = c.pieces()
    pad = 1
    params = {
        "ld": np.append(ld, [BIG] * pad),
        "lf": np.append(lf, [lf[-1]] * pad),
        "ls": np.append(np.nan_to_num(ls, nan=0.0), [0.0] * pad),
        "le": np.append(le, [le[-1]] * pad),
    }
    if isinstance(u, Restitution):
        kind = "restitution"
        params["e"] = np.asarray(float(u.e))
        ud, uf = np.array([-1.0, 0.0]), np.array([0.0, 1.0])
    elif isinstance(u, UnloadingStiffness):
        kind = "stiffness"
        params["su"] = np.asarray(float(u.stiffness))
        ud, uf = np.array([-1.0, 0.0]), np.array([0.0, 1.0])
    elif isinstance(u, UnloadingTable):
        kind = "table"
        ud, uf = np.asarray(u.d, float)[::-1].copy(), np.asarray(u.f, float)[::-1].copy()
    else:  # pragma: no cover - the loader only builds the three kinds
        raise TypeError(f"unknown unloading rule {u!r}")
    params["ud"] = ud - ud[-1]  # top of the template at 0
    params["uf"] = uf
    # Energy under the template (force 0 → 1 or F0), for the returned energy.
    params["ue"] = np.asarray(float(np.sum(0.5 * (uf[1:] + uf[:-1]) * np.diff(ud))))
    params["wres"] = np.asarray(REBOUND_RESOLUTION)
    for value in params.values():
        value.setflags(write=False)
    return params, ld.size, kind, ud.size


class HysteresisLaw:
    """The paper's IF-D hysteresis: loading curve to the common velocity, then unloading.

    Discrete state keys: ``mode`` (open, loading, unloading), ``seg`` (segment index in the loading
    curve or the unloading template), the active affine piece ``da, fa, s`` and its bounds
    ``lo, hi``, ``vm`` (1 while loading: the max-deformation event is armed), the history
    ``dmax, fmax, dperm, ec`` (absorbed energy), the unloading map ``dscale, fscale``, the energy
    the unloading curve returns ``er``, and ``status`` (see :data:`STATUS`).

    Bumper failure with a post-failure curve (``failure.post_failure``): the law follows the
    spliced loading curve (:meth:`~lsc.curves.Curve.splice`: the virgin curve up to the failure
    deformation ``D_f``, parameter ``dfail`` [length], then the post-failure curve counted from
    there; the force may step at ``D_f``, a breakpoint where the next piece starts at its own
    force). The state then also holds ``failed`` (1 once loading has reached ``D_f``), and the
    breakpoint event at ``D_f`` is named ``"failure"``. Unloading works from the spliced curve
    as from any loading curve (``E_c`` is the area under it up to ``D_max``).
    """

    name = "hysteresis"
    #: Other names a scene may give in ``law = ...``.
    aliases = ("if-d", "ifd")
    #: The keys of its contact table (read by :meth:`read`).
    table_keys = ("loading", "unloading")
    #: The scene numbers a study may change without re-loading the scene (see :meth:`numbers`).
    params_declared = (
        Param("loading.stiffness", "stiffness", "a straight loading line F = k D", minimum=0.0),
        Param("loading.scale", "dimensionless", "a factor on the loading curve's forces",
              minimum=0.0, bounded=True),
        Param("unloading.restitution", "dimensionless", "the coefficient of restitution e"),
        Param("unloading.stiffness", "stiffness", "a straight unloading line of this slope",
              minimum=0.0),
    )
    #: The generic integrators (SciPy, diffrax) integrate it from its array code.
    integrable = True
    #: Its numbers do not depend on the vehicles' masses.
    depends_on_mass = False
    event_kinds = ("lo", "hi", "vmax")
    tracks_work = False  # its energies follow exactly from the curves
    #: its force is affine in ``D`` inside a segment (effects watching it have linear events)
    affine_force = True

    def features(self) -> set[str]:
        """What a scene with this law uses (:meth:`lsc.model.HybridModel.features`)."""
        linear = self.spec.loading.is_linear and not self.fails
        out = {"law:ifd", "loading:linear" if linear else "loading:table",
               f"unloading:{self.unload_kind}"}
        return out | ({"effect:post-failure"} if self.fails else set())

    def __init__(self, spec: Hysteresis, failure=None, mu_pair: float = 1.0):
        self.spec = spec
        c = spec.loading
        self.fails = failure is not None and failure.post_failure is not None
        dfail = None
        if self.fails:
            c, dfail = c.splice(failure.force, failure.post_failure)
        self.loading = c  # the curve the law follows (spliced at the failure point, if any)
        self.extends = c.extends
        # the numbers of an unspliced law depend on its (frozen) description alone: built once
        # per description, read-only, and shared by every model of it
        numbers = None if self.fails else spec.__dict__.get("_law_numbers")
        if numbers is None:
            numbers = _numbers(c, spec.unloading)
            if not self.fails:
                object.__setattr__(spec, "_law_numbers", numbers)
        params, self.n_load, self.unload_kind, self.n_unload = numbers
        self.params = dict(params)
        if self.fails:
            self.params["dfail"] = np.asarray(dfail)

    # ------------------------------------------------------------------ declaration
    @classmethod
    def read(cls, spec: dict, path: str, reader) -> Hysteresis:
        """The law's description from a contact's ``loading`` and ``unloading`` keys (``reader``:
        the scene loader's, :class:`lsc.scene.Reader`)."""
        if "loading" not in spec:
            raise SceneError(f"{path}.loading", "is required (e.g. loading = { stiffness = 24000 })")
        loading, scale = reader.loading(spec["loading"], f"{path}.loading")
        if "unloading" not in spec:
            raise SceneError(f"{path}.unloading",
                             "is required: { restitution = e } or { stiffness = ... } or "
                             "{ table = ... } or { csv = ... }")
        unloading = reader.unloading(spec["unloading"], f"{path}.unloading", loading)
        return Hysteresis(loading, unloading, scale)

    @staticmethod
    def value(spec: Hysteresis, key: str) -> float | None:
        """The number the scene gave for declared ``key`` (:attr:`params_declared`), or ``None``
        if this contact's description has none."""
        u = spec.unloading
        return {"loading.stiffness": spec.loading.stiffness if spec.loading.is_linear else None,
                "loading.scale": spec.scale,
                "unloading.restitution": u.e if isinstance(u, Restitution) else None,
                "unloading.stiffness": u.stiffness if isinstance(u, UnloadingStiffness) else None,
                }.get(key)

    def sweepable(self, key: str) -> bool:
        """Whether :meth:`numbers` can change ``key`` without re-loading the scene (a loading
        curve spliced at a failure point moves that point with it: re-load)."""
        if key.startswith("loading.") and self.fails:
            return False
        return self.value(self.spec, key) is not None

    def numbers(self, changes: dict, mu=None, xp=np) -> dict:
        """The law's model numbers (:attr:`params`) with the declared keys of ``changes`` (key →
        array (n,) or scalar, scene units) in place of the scene's: traceable array code.
        ``loading.stiffness`` sets the line's slope, ``loading.scale`` scales the curve's forces
        (relative to the scene's scale), ``unloading.restitution`` and ``unloading.stiffness`` set
        ``e`` and ``su``."""
        p = dict(self.params)
        if "loading.scale" in changes:
            f = (xp.asarray(changes["loading.scale"], float) / self.spec.scale)[..., None]
            for key in ("lf", "ls", "le"):
                p[key] = p[key] * f
        if "loading.stiffness" in changes:
            k = xp.asarray(changes["loading.stiffness"], float)[..., None]
            first = xp.arange(p["ls"].shape[-1]) == 0
            p["ls"] = xp.where(first, k, p["ls"])
        if "unloading.restitution" in changes:
            p["e"] = xp.asarray(changes["unloading.restitution"], float)
        if "unloading.stiffness" in changes:
            p["su"] = xp.asarray(changes["unloading.stiffness"], float)
        return p

    # ------------------------------------------------------------------ smooth pieces
    @staticmethod
    def force(D, Ddot, st):
        """Contact force [force]: the active affine piece (0 when open)."""
        return st["fa"] + st["s"] * (D - st["da"])

    @staticmethod
    def events(D, Ddot, st):
        """(lower bound reached going down, upper bound reached going up, closing speed to 0)."""
        return ((D - st["da"]) + st["wl"], st["hi"] - D, st["vm"] * Ddot + (1.0 - st["vm"]))

    @staticmethod
    def armed(st) -> tuple:
        """Which events can fire in this state (NumPy backends skip the others)."""
        return (st["lo"] > -1e299, st["hi"] < 1e299, st["vm"] != 0)

    def event_linear(self, laws) -> tuple:
        """Every event is the minimum of linear pieces (:meth:`event_pieces`)."""
        return (True,) * len(self.event_kinds)

    @classmethod
    def event_pieces(cls, D, Ddot, st):
        """Each event as the minimum of functions linear in ``(D, Ḋ)``: here each is one
        (deformation bounds and closing rate), so every event is linear in the state."""
        return tuple((g,) for g in cls.events(D, Ddot, st))

    @staticmethod
    def closing_gap(D, st):
        """While open: the deformation still to close before the contact touches again, at its
        permanent set [length] (its ``hi`` event, ``hi - D``)."""
        return st["hi"] - D

    # ------------------------------------------------------------------ segments
    def _zero(self, xp) -> dict:
        z = xp.asarray(0.0)
        st = {"mode": xp.asarray(MODE_OPEN), "seg": xp.asarray(0), "da": z, "fa": z, "s": z,
              "lo": xp.asarray(-BIG), "wl": xp.asarray(BIG), "hi": z, "vm": z, "dmax": z,
              "fmax": z, "dperm": z, "ec": z, "dscale": z, "fscale": z, "er": z,
              "status": xp.asarray(0)}
        if self.fails:
            st["failed"] = z
        return st

    def _loading(self, st: dict, seg, p: dict, xp) -> dict:
        """Loading on segment ``seg`` of the loading curve."""
        out = dict(st)
        out.update(mode=xp.asarray(MODE_LOADING), seg=seg, da=p["ld"][seg], fa=p["lf"][seg],
                   s=p["ls"][seg], lo=xp.asarray(-BIG), wl=xp.asarray(BIG), hi=p["ld"][seg + 1],
                   vm=xp.asarray(1.0))
        if not self.extends:
            ended = seg >= self.n_load - 1
            code = xp.where(p["ld"][seg] >= p["dfail"], 5, 1) if self.fails else 1
            out["status"] = xp.where(ended, code, st["status"])
        if self.fails:  # on a piece at or past the failure point: failed (for good)
            out["failed"] = xp.where(p["ld"][seg] >= p["dfail"], 1.0, st["failed"])
        return out

    def _loading_at(self, st: dict, D, p: dict, xp) -> dict:
        """Loading from deformation ``D`` (the segment that starts at or below it)."""
        seg = xp.searchsorted(p["ld"][: self.n_load], D, side="right") - 1
        seg = xp.clip(seg, 0, self.n_load - 1)
        return self._loading(st, seg, p, xp)

    def _unloading(self, st: dict, u, p: dict, xp) -> dict:
        """Unloading (or reloading) on segment ``u`` of the mapped unloading template.

        The affine piece is anchored at its *top* ``(Db, Fb)`` (``(D_max, F_max)`` itself on
        the first piece, where the motion enters it with the state that defined ``D_max``), and
        its width ``wl = Db - Da`` is taken from the template, ``dscale (ud[u+1] - ud[u])``,
        not from the two rounded absolute bounds: a near-plastic rebound is ``e² D_max`` wide,
        a few thousand ulps of ``D_max`` at ``e = 1e-6``, and bounds rounded to ulps of
        ``D_max`` would put its slope and its end (where the force is zero) off by a part in
        1e4. Anchored at the top, the force at ``D_max`` is ``F_max`` exactly, and ``lo`` is
        ``wl`` below the anchor for a backend that works relative to it (the exact one)."""
        ud, uf = p["ud"], p["uf"]
        Da = st["dmax"] + st["dscale"] * ud[u]
        Db = st["dmax"] + st["dscale"] * ud[u + 1]
        Fa = st["fscale"] * uf[u]
        Fb = st["fscale"] * uf[u + 1]
        wl = st["dscale"] * (ud[u + 1] - ud[u])
        out = dict(st)
        # (a width that would make the slope overflow belongs to an instant separation, and
        # is only evaluated here, unused: see _max_deformation)
        width = xp.where(wl > 1e-300 * abs(Fb - Fa), wl, 1.0)
        out.update(mode=xp.asarray(MODE_UNLOADING), seg=u, da=Db, fa=Fb, s=(Fb - Fa) / width,
                   lo=Da, wl=wl, hi=Db, vm=xp.asarray(0.0))
        return out

    def _open(self, st: dict, xp) -> dict:
        """Separated: no force; the contact closes again when ``D`` comes back to ``dperm``."""
        out = dict(st)
        z = xp.asarray(0.0)
        out.update(mode=xp.asarray(MODE_OPEN), seg=xp.asarray(0), da=z, fa=z, s=z,
                   lo=xp.asarray(-BIG), wl=xp.asarray(BIG), hi=st["dperm"], vm=z)
        return out

    # ------------------------------------------------------------------ transitions
    def init(self, D, Ddot, p: dict, xp=np, mu=None) -> dict:
        """State at t = 0: loading if touching (``D >= 0``) and closing, else open."""
        st = self._zero(xp)
        touching = (D >= 0) & (Ddot > 0)
        return _lazy(touching, lambda: self._loading_at(st, D, p, xp),
                     lambda: self._open(st, xp), xp)

    def _max_deformation(self, st: dict, D, p: dict, xp) -> dict:
        """Common velocity reached: record (D_max, F_max) and switch to the unloading branch."""
        seg = xp.clip(st["seg"], 0, self.n_load - 1)  # (also evaluated, unused, in other modes)
        F = self.force(D, 0.0, st)
        x = D - p["ld"][seg]
        ec = p["le"][seg] + p["lf"][seg] * x + 0.5 * p["ls"][seg] * x * x
        if self.unload_kind == "restitution":
            e = p["e"]
            dscale = xp.where(F > 0, 2.0 * e * e * ec / xp.where(F > 0, F, 1.0), 0.0)
            fscale = F
        elif self.unload_kind == "stiffness":
            dscale = F / p["su"]
            fscale = F
        else:
            dscale = xp.asarray(1.0)
            fscale = F / p["uf"][-1]
        new = dict(st)
        new.update(dmax=D, fmax=F, ec=ec, dscale=dscale, fscale=fscale,
                   dperm=D + dscale * p["ud"][0], er=fscale * dscale * p["ue"])
        status = xp.where(new["dperm"] < -1e-12 * D, 2, st["status"])
        if self.unload_kind != "restitution":
            status = xp.where(new["er"] > ec * (1 + 1e-12), 3, status)
        new["status"] = status
        # No rebound (e = 0, no force at the common velocity, or a rebound narrower than the
        # backend resolves, wres D_max; see REBOUND_RESOLUTION): separate at once.
        # (and a line so narrow that its slope F/dscale would overflow: e² below 1e-300)
        instant = (dscale <= p["wres"] * abs(D)) | (F <= 0) | (dscale <= 1e-300 * F)
        new_open = dict(new)
        new_open.update(dperm=D, dscale=xp.asarray(0.0), er=xp.asarray(0.0))
        return _lazy(instant, lambda: self._open(new_open, xp),
                     lambda: self._unloading(new, xp.asarray(self.n_unload - 2), p, xp), xp)

    def on_event(self, which, D, Ddot, st: dict, p: dict, xp=np, mu=None, w=None) -> dict:
        """Discrete state after event ``which`` (0 = lo, 1 = hi, 2 = vmax) at deformation ``D``
        (every backend resolves ``D`` to its own ulps: integrators in each segment's frame)."""
        mode, seg = st["mode"], st["seg"]
        loading, unloading = (mode == MODE_LOADING), (mode == MODE_UNLOADING)
        top, bottom = seg >= self.n_unload - 2, seg <= 0
        # hi: next loading segment / next unloading segment up / past D_max onto loading / close
        reload_from_open = (st["dmax"] <= 0) | (st["dperm"] >= st["dmax"])
        hi_open = lambda: _lazy(reload_from_open, lambda: self._loading_at(st, D, p, xp),
                                lambda: self._unloading(st, xp.asarray(0), p, xp), xp)
        hi_unl = lambda: _lazy(
            top, lambda: self._loading_at(st, st["dmax"], p, xp),
            lambda: self._unloading(st, xp.clip(seg + 1, 0, self.n_unload - 2), p, xp), xp)
        hi_load = lambda: self._loading(st, xp.clip(seg + 1, 0, self.n_load - 1), p, xp)
        hi = lambda: _lazy(loading, hi_load, lambda: _lazy(unloading, hi_unl, hi_open, xp), xp)
        # lo: next unloading segment down, or separation at the permanent set
        lo = lambda: _lazy(unloading, lambda: _lazy(
            bottom, lambda: self._open(st, xp),
            lambda: self._unloading(st, xp.clip(seg - 1, 0, self.n_unload - 2), p, xp), xp),
            lambda: st, xp)
        # vmax: common velocity while loading
        vm = lambda: _lazy(loading, lambda: self._max_deformation(st, D, p, xp), lambda: st, xp)
        return _lazy(which == 0, lo, lambda: _lazy(which == 1, hi, vm, xp), xp)

    # ------------------------------------------------------------------ reporting
    @classmethod
    def event_name(cls, which: int, before: dict, after: dict) -> str:
        """Name of what happened (for ``Result.events``); the loading reaching the failure
        point of a post-failure curve is ``"failure"`` (``"<name>+failure"`` if something else
        happened with it)."""
        name = cls._event_name(which, before, after)
        if float(after.get("failed", 0.0)) > float(before.get("failed", 0.0)):
            return "failure" if name == "breakpoint" else name + "+failure"
        return name

    @staticmethod
    def _event_name(which: int, before: dict, after: dict) -> str:
        mb, ma = int(before["mode"]), int(after["mode"])
        if which == 2:
            return "max_deformation" if ma == MODE_UNLOADING else "max_deformation+separation"
        if ma == MODE_OPEN and mb != MODE_OPEN:
            return "separation"
        if mb == MODE_OPEN:
            return "contact"
        if mb == MODE_UNLOADING and ma == MODE_LOADING:
            return "reload_past_max"
        return "breakpoint"


