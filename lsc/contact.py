"""Contact laws, written once as plain array code for NumPy and ``jax.numpy``.

Every law works on one contact with deformation ``D`` [length] and closing rate ``Ddot``
[velocity] and keeps a small *discrete state* ``st`` (a dict of scalars) that is frozen inside a
segment and changes only at events. A law provides

- ``force(D, Ddot, st)``: the contact force [force], smooth inside a segment (no branch);
- ``events(D, Ddot, st)``: a tuple of event functions, each crossing zero **downward** when the
  event happens (inactive ones stay at a positive constant);
- ``init(D, Ddot, xp)`` and ``on_event(which, D, Ddot, st, xp)``: the discrete state at the start
  and after event ``which``, computed with ``xp.where`` so that the same code traces under JAX.

The paper's IF-D hysteresis is :class:`HysteresisLaw`: inside any segment the force is affine in
``D``, ``F = fa + s (D - da)``, valid for ``lo <= D <= hi``.
"""

from __future__ import annotations

import numpy as np

from .scene import Hysteresis, Restitution, UnloadingStiffness, UnloadingTable

__all__ = ["HysteresisLaw", "make_law", "MODE_OPEN", "MODE_LOADING", "MODE_UNLOADING", "STATUS"]

MODE_OPEN, MODE_LOADING, MODE_UNLOADING = 0, 1, 2
BIG = 1e300

#: Status codes a law may raise in its discrete state (0 = fine), with the user-facing reason.
STATUS = {
    0: "ok",
    1: ("the loading table ends before the vehicles reach a common velocity (the crash needs more "
        "deformation than the IF-D curve gives). Extend the table, or scale its forces up "
        "(lsc.analysis.calibrate_force_scale / `scale = ...` in the loading table), as the paper "
        "did for its measured crash-test curves"),
    2: ("the unloading branch would end at a negative permanent deformation (the straight line from "
        "(D_max, F_max) needed for this restitution passes below D = 0). Give the unloading as a "
        "table or a stiffness, or a lower restitution"),
    3: ("the unloading branch returns more energy than the loading branch absorbed (restitution "
        "above 1): make the unloading stiffer than the loading curve"),
}


def _sel(cond, a: dict, b: dict, xp) -> dict:
    """Field-wise ``where(cond, a, b)`` over two discrete states."""
    return {k: xp.where(cond, a[k], b[k]) for k in a}


class HysteresisLaw:
    """The paper's IF-D hysteresis: loading curve to the common velocity, then unloading.

    Discrete state keys: ``mode`` (open, loading, unloading), ``seg`` (segment index in the loading
    curve or the unloading template), the active affine piece ``da, fa, s`` and its bounds
    ``lo, hi``, ``vm`` (1 while loading: the max-deformation event is armed), the history
    ``dmax, fmax, dperm, ec`` (absorbed energy), the unloading map ``dscale, fscale``, the energy
    the unloading curve returns ``er``, and ``status`` (see :data:`STATUS`).
    """

    name = "hysteresis"
    event_kinds = ("lo", "hi", "vmax")

    def __init__(self, spec: Hysteresis):
        self.spec = spec
        c = spec.loading
        n = c.d.size
        self.n_load = n
        self.extends = c.extends
        pad = 1
        slopes = np.nan_to_num(c.slopes, nan=0.0)
        self.params = {
            "ld": np.append(c.d, [BIG] * pad),
            "lf": np.append(c.f, [c.f[-1]] * pad),
            "ls": np.append(slopes, [0.0] * pad),
            "le": np.append(c.cum_energy, [c.cum_energy[-1]] * pad),
        }
        u = spec.unloading
        if isinstance(u, Restitution):
            self.unload_kind = "restitution"
            self.params["e"] = np.asarray(float(u.e))
            ud, uf = np.array([-1.0, 0.0]), np.array([0.0, 1.0])
        elif isinstance(u, UnloadingStiffness):
            self.unload_kind = "stiffness"
            self.params["su"] = np.asarray(float(u.stiffness))
            ud, uf = np.array([-1.0, 0.0]), np.array([0.0, 1.0])
        elif isinstance(u, UnloadingTable):
            self.unload_kind = "table"
            ud, uf = np.asarray(u.d, float)[::-1].copy(), np.asarray(u.f, float)[::-1].copy()
        else:  # pragma: no cover - the loader only builds the three kinds
            raise TypeError(f"unknown unloading rule {u!r}")
        self.n_unload = ud.size
        self.params["ud"] = ud - ud[-1]  # top of the template at 0
        self.params["uf"] = uf
        # Energy under the template (force 0 → 1 or F0), for the returned energy.
        self.params["ue"] = np.asarray(float(np.sum(0.5 * (uf[1:] + uf[:-1]) * np.diff(ud))))

    # ------------------------------------------------------------------ smooth pieces
    @staticmethod
    def force(D, Ddot, st):
        """Contact force [force]: the active affine piece (0 when open)."""
        return st["fa"] + st["s"] * (D - st["da"])

    @staticmethod
    def events(D, Ddot, st):
        """(lower bound reached going down, upper bound reached going up, closing speed to 0)."""
        return (D - st["lo"], st["hi"] - D, st["vm"] * Ddot + (1.0 - st["vm"]))

    # ------------------------------------------------------------------ segments
    def _zero(self, xp) -> dict:
        z = xp.asarray(0.0)
        return {"mode": xp.asarray(MODE_OPEN), "seg": xp.asarray(0), "da": z, "fa": z, "s": z,
                "lo": xp.asarray(-BIG), "hi": z, "vm": z, "dmax": z, "fmax": z, "dperm": z,
                "ec": z, "dscale": z, "fscale": z, "er": z, "status": xp.asarray(0)}

    def _loading(self, st: dict, seg, p: dict, xp) -> dict:
        """Loading on segment ``seg`` of the loading curve."""
        out = dict(st)
        out.update(mode=xp.asarray(MODE_LOADING), seg=seg, da=p["ld"][seg], fa=p["lf"][seg],
                   s=p["ls"][seg], lo=xp.asarray(-BIG), hi=p["ld"][seg + 1],
                   vm=xp.asarray(1.0))
        if not self.extends:
            ended = seg >= self.n_load - 1
            out["status"] = xp.where(ended, 1, st["status"])
        return out

    def _loading_at(self, st: dict, D, p: dict, xp) -> dict:
        """Loading from deformation ``D`` (the segment that starts at or below it)."""
        seg = xp.searchsorted(p["ld"][: self.n_load], D, side="right") - 1
        seg = xp.clip(seg, 0, self.n_load - 1)
        return self._loading(st, seg, p, xp)

    def _unloading(self, st: dict, u, p: dict, xp) -> dict:
        """Unloading (or reloading) on segment ``u`` of the mapped unloading template."""
        ud, uf = p["ud"], p["uf"]
        Da = st["dmax"] + st["dscale"] * ud[u]
        Db = st["dmax"] + st["dscale"] * ud[u + 1]
        Fa = st["fscale"] * uf[u]
        Fb = st["fscale"] * uf[u + 1]
        out = dict(st)
        width = xp.where(Db != Da, Db - Da, 1.0)
        out.update(mode=xp.asarray(MODE_UNLOADING), seg=u, da=Da, fa=Fa, s=(Fb - Fa) / width,
                   lo=Da, hi=Db, vm=xp.asarray(0.0))
        return out

    def _open(self, st: dict, xp) -> dict:
        """Separated: no force; the contact closes again when ``D`` comes back to ``dperm``."""
        out = dict(st)
        z = xp.asarray(0.0)
        out.update(mode=xp.asarray(MODE_OPEN), seg=xp.asarray(0), da=z, fa=z, s=z,
                   lo=xp.asarray(-BIG), hi=st["dperm"], vm=z)
        return out

    # ------------------------------------------------------------------ transitions
    def init(self, D, Ddot, p: dict, xp=np) -> dict:
        """State at t = 0: loading if touching (``D >= 0``) and closing, else open."""
        st = self._zero(xp)
        touching = (D >= 0) & (Ddot > 0)
        return _sel(touching, self._loading_at(st, D, p, xp), self._open(st, xp), xp)

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
        # No rebound (e = 0, or no force at the common velocity): separate at once.
        instant = (dscale <= 0) | (F <= 0)
        new_open = dict(new)
        new_open.update(dperm=D, dscale=xp.asarray(0.0), er=xp.asarray(0.0))
        return _sel(instant, self._open(new_open, xp),
                    self._unloading(new, xp.asarray(self.n_unload - 2), p, xp), xp)

    def on_event(self, which, D, Ddot, st: dict, p: dict, xp=np) -> dict:
        """Discrete state after event ``which`` (0 = lo, 1 = hi, 2 = vmax) at deformation ``D``."""
        mode, seg = st["mode"], st["seg"]
        loading, unloading = (mode == MODE_LOADING), (mode == MODE_UNLOADING)
        top, bottom = seg >= self.n_unload - 2, seg <= 0
        # hi: next loading segment / next unloading segment up / past D_max onto loading / close
        reload_from_open = (st["dmax"] <= 0) | (st["dperm"] >= st["dmax"])
        hi_open = _sel(reload_from_open, self._loading_at(st, D, p, xp),
                       self._unloading(st, xp.asarray(0), p, xp), xp)
        hi_unl = _sel(top, self._loading_at(st, st["dmax"], p, xp),
                      self._unloading(st, xp.clip(seg + 1, 0, self.n_unload - 2), p, xp), xp)
        hi_load = self._loading(st, xp.clip(seg + 1, 0, self.n_load - 1), p, xp)
        hi = _sel(loading, hi_load, _sel(unloading, hi_unl, hi_open, xp), xp)
        # lo: next unloading segment down, or separation at the permanent set
        lo = _sel(bottom, self._open(st, xp),
                  self._unloading(st, xp.clip(seg - 1, 0, self.n_unload - 2), p, xp), xp)
        lo = _sel(unloading, lo, st, xp)
        # vmax: common velocity while loading
        vm = _sel(loading, self._max_deformation(st, D, p, xp), st, xp)
        return _sel(which == 0, lo, _sel(which == 1, hi, vm, xp), xp)

    # ------------------------------------------------------------------ reporting
    @staticmethod
    def event_name(which: int, before: dict, after: dict) -> str:
        """Name of what happened (for ``Result.events``)."""
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


def make_law(contact):
    """The law object of a scene contact (only the laws the scene declares are built)."""
    if isinstance(contact.law, Hysteresis):
        return HysteresisLaw(contact.law)
    raise TypeError(f"no contact law implements {type(contact.law).__name__}")
