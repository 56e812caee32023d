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

from .scene import Damping, Hysteresis, Restitution, UnloadingStiffness, UnloadingTable

__all__ = ["HysteresisLaw", "DampingLaw", "make_law", "kelvin_restitution", "kelvin_zeta",
           "hunt_crossley_a", "brach_restitution", "MODE_OPEN", "MODE_LOADING", "MODE_UNLOADING", "STATUS"]

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
    4: ("Brach's law cannot reach the requested restitution at this closing speed with its "
        "compression damping c1 (no restoring damping c2 >= 0 gives it): lower the damping or "
        "raise the restitution"),
    5: ("the post-failure loading table ends before the vehicles reach a common velocity (the "
        "crash needs more deformation after the bumper failed than failure.post_failure gives). "
        "Extend that table, or scale its forces up (`scale = ...` in failure.post_failure)"),
}


#: The narrowest rebound, relative to ``D_max``, that a backend integrating vehicle *positions*
#: resolves (law parameter ``wres``); a narrower one separates at once, its rebound dropped.
#: Such a backend holds a deformation only to the ulps of the positions, so the force on an
#: unloading line ``w`` wide and ``F_max/w`` steep is noise once ``w`` is a few ulps of ``D_max``:
#: at 4 ulps (``e ≈ 3e-8`` on a linear branch) the rebound dropped and the rebound mis-resolved
#: just above it both change a ΔV by a few 1e-8 of the closing speed, a float64 floor of those
#: backends (docs/reliability.rst). The exact backend works relative to the piece's anchor
#: (``(D - da) + wl``) and resolves any width: it sets ``wres = 0``.
REBOUND_RESOLUTION = 4 * float(np.finfo(float).eps)


def _sel(cond, a: dict, b: dict, xp) -> dict:
    """Field-wise ``where(cond, a, b)`` over two discrete states (on NumPy with a scalar ``cond``
    a plain pick of the same values, without a ``where`` per field)."""
    if xp is np and np.ndim(cond) == 0:
        src = a if cond else b
        return {k: src[k] for k in a}
    return {k: xp.where(cond, a[k], b[k]) for k in a}


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

    def __init__(self, spec: Hysteresis, failure=None):
        self.spec = spec
        c = spec.loading
        self.fails = failure is not None and failure.post_failure is not None
        if self.fails:
            c, dfail = c.splice(failure.force, failure.post_failure)
        self.loading = c  # the curve the law follows (spliced at the failure point, if any)
        ld, lf, ls, le = c.pieces()
        n = ld.size
        self.n_load = n
        self.extends = c.extends
        pad = 1
        slopes = np.nan_to_num(ls, nan=0.0)
        self.params = {
            "ld": np.append(ld, [BIG] * pad),
            "lf": np.append(lf, [lf[-1]] * pad),
            "ls": np.append(slopes, [0.0] * pad),
            "le": np.append(le, [le[-1]] * pad),
        }
        if self.fails:
            self.params["dfail"] = np.asarray(dfail)
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
        self.params["wres"] = np.asarray(REBOUND_RESOLUTION)

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
        # No rebound (e = 0, no force at the common velocity, or a rebound narrower than the
        # backend resolves, wres D_max; see REBOUND_RESOLUTION): separate at once.
        # (and a line so narrow that its slope F/dscale would overflow: e² below 1e-300)
        instant = (dscale <= p["wres"] * abs(D)) | (F <= 0) | (dscale <= 1e-300 * F)
        new_open = dict(new)
        new_open.update(dperm=D, dscale=xp.asarray(0.0), er=xp.asarray(0.0))
        return _sel(instant, self._open(new_open, xp),
                    self._unloading(new, xp.asarray(self.n_unload - 2), p, xp), xp)

    def on_event(self, which, D, Ddot, st: dict, p: dict, xp=np, mu=None, w=None) -> dict:
        """Discrete state after event ``which`` (0 = lo, 1 = hi, 2 = vmax) at deformation ``D``
        (every backend resolves ``D`` to its own ulps: integrators in each segment's frame)."""
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



# =========================================================================== damping laws
def _min(a, b):
    """Elementwise minimum written with ``abs`` (NumPy and JAX alike)."""
    return 0.5 * (a + b - abs(a - b))


def kelvin_restitution(zeta):
    """Restitution of the Kelvin law ``k D + c Ḋ`` with force-zero separation, for damping ratio
    ``ζ = c / (2√(kμ)) >= 0``: ``e = exp(-2ζ arccos ζ / √(1-ζ²))`` (arccosh form for ζ > 1)."""
    z = np.asarray(zeta, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        zu, zo = np.clip(z, 0.0, 1.0), np.maximum(z, 1.0)
        under = np.exp(-2 * zu * np.arccos(zu) / np.sqrt((1 - zu) * (1 + zu)))
        over = np.exp(-2 * zo * np.arccosh(zo) / np.sqrt((zo - 1) * (zo + 1)))
    return np.where(z < 1, under, np.where(z > 1, over, np.exp(-2.0)))


def kelvin_zeta(e: float) -> float:
    """The damping ratio ζ whose Kelvin restitution is ``e`` (``0 < e <= 1``)."""
    from scipy.optimize import brentq

    if e >= 1:
        return 0.0
    hi = 1.0
    while float(kelvin_restitution(hi)) > e:
        hi *= 2.0
    return float(brentq(lambda z: float(kelvin_restitution(z)) - e, 0.0, hi,
                        xtol=1e-15, rtol=1e-15))


def hunt_crossley_a(e: float) -> float:
    """``a = α v0`` of the Hunt–Crossley law for restitution ``e`` (``0 < e <= 1``, any
    exponent): the positive root of ``a (1 + e) = ln[(1 + a) / (1 - a e)]``, to a few ulps.

    The relation is solved in the form that resolves it: for a small root (``e`` near 1,
    ``a <= 1/2``) as the series :func:`_hc_series` of ``[ln(1 + a) - ln(1 - a e) - a (1 + e)] / a²``
    (its leading terms cancel exactly); otherwise for ``L = -ln(1 - a e)``
    (``a = -expm1(-L)/e``), in which the relation reads ``L = a (1 + e) - ln(1 + a)``: as
    ``e → 0`` the root ``a`` tends to ``1/e`` with ``1 - a e ≈ e^{-1/e}`` (below 1e-300 at
    ``e = 1e-3``), which ``a`` itself cannot resolve and ``L`` does; that root lies in
    ``(0, (1 + e)/e]``."""
    from scipy.optimize import brentq

    if not 0 < e <= 1:
        raise ValueError(f"the Hunt-Crossley target restitution must be in (0, 1], got {e!r}")
    if e == 1:
        return 0.0
    tol = dict(xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)
    if _hc_series(0.5, e) > 0:   # (it is -(1 - e²)/2 < 0 at a = 0)
        return float(brentq(_hc_series, 0.0, 0.5, args=(e,), **tol))

    def residual(L):   # > 0 below the root, < 0 above it
        a = -np.expm1(-L) / e
        return a * (1 + e) - np.log1p(a) - L

    hi = (1 + e) / e
    return float(-np.expm1(-brentq(residual, 0.25, hi, **tol)) / e)


def _hc_series(a, e):
    """``[ln(1 + a) - ln(1 - a e) - a (1 + e)] / a² = Σ_{n>=2} a^(n-2) [(-1)^(n+1) + e^n] / n``
    for ``0 <= a <= 1/2`` (the even coefficients ``e^n - 1`` from ``expm1``, without
    cancellation)."""
    n = np.arange(2, 60)
    coef = np.where(n % 2 == 1, 1.0 + e ** n, np.expm1(n * np.log1p(-(1.0 - e))))
    return float(np.sum(a ** (n - 2) * coef / n))


def brach_restitution(k, c1, c2, v0, mu):
    """Restitution of Brach's law ``D (k + c Ḋ)`` (``c1`` compressing, ``c2`` restoring) for an
    impact at closing speed ``v0`` of a pair of reduced mass ``mu``, from its energy integral:
    ``G_c2(-e v0) = G_c1(v0)`` with ``G_c(v) = (μ k / c²)(c v/k - ln(1 + c v/k))``."""
    from scipy.optimize import brentq

    def G(c, v):
        u = c * v / k
        return mu * v * v / k * np.where(np.abs(u) < 1e-6, 0.5 - u / 3 + u * u / 4,
                                         (u - np.log1p(u)) / np.where(u == 0, 1, u * u))
    target = G(c1, v0)
    f = lambda e: G(c2, -e * v0) - target  # noqa: E731
    hi = min(1.0, k / (c2 * v0) * (1 - 1e-15)) if c2 > 0 else 1.0
    return float(brentq(f, 0.0, hi, xtol=1e-15, rtol=1e-15))


def _brach_c2(k, c1, e, v0, mu, xp):
    """The restoring coefficient ``c2`` that gives Brach's law restitution ``e`` at closing speed
    ``v0`` (array code: a fixed bisection on ``x = c2 e v0 / k`` in [0, 1))."""
    u1 = c1 * v0 / k
    r1 = xp.where(xp.abs(u1) < 1e-6, 0.5 - u1 / 3 + u1 * u1 / 4,
                  (u1 - xp.log1p(u1)) / xp.where(u1 == 0, 1.0, u1 * u1))
    R = r1 / (e * e)

    def h(x):
        return xp.where(x < 1e-6, 0.5 + x / 3 + x * x / 4,
                        (-x - xp.log1p(-x)) / xp.where(x == 0, 1.0, x * x))

    lo, hi = xp.asarray(0.0), xp.asarray(1.0)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        up = h(mid) < R
        lo, hi = xp.where(up, mid, lo), xp.where(up, hi, mid)
    x = 0.5 * (lo + hi)
    return x * k / (e * v0), R >= 0.5 - 1e-15


class DampingLaw:
    """Spring–dashpot contact laws (the paper's "spring/dashpot" family), tension-free.

    ``kelvin``: ``F = k D + c Ḋ``; ``hunt-crossley``: ``F = k D^n (1 + α Ḋ)``; ``brach``:
    ``F = k D + c D Ḋ`` with ``c = c1`` while compressing and ``c2`` while restoring. The force
    is never negative: the contact separates when it reaches zero (or ``D`` returns to 0) and
    closes again when ``D`` comes back above 0.

    Modes: open, compressing (``Ḋ > 0``), restoring (``Ḋ < 0``). The work done on the contact,
    ``∫ F dD``, is integrated with the motion (one extra state), so the absorbed and returned
    energies are exact to the solver tolerance. Coefficients given as a target restitution are
    converted by the law's own relation: Kelvin ``ζ`` from
    ``e = exp(-2ζ arccos ζ / √(1-ζ²))``; Hunt–Crossley ``α = a / v_c`` with
    ``a (1+e) = ln[(1+a)/(1-a e)]`` and ``v_c`` the closing speed at contact; Brach ``c2`` from
    its energy integral at the closing speed at contact.
    """

    tracks_work = True
    event_kinds = ("separate", "turn", "close", "recompress")

    def features(self) -> set[str]:
        """What a scene with this law uses (:meth:`lsc.model.HybridModel.features`)."""
        return {f"law:{self.name}"}

    def __init__(self, spec, mu_pair: float):
        self.spec = spec
        self.name = spec.law
        k = float(spec.stiffness)
        p = {"k": np.asarray(k)}
        if self.name == "kelvin":
            zeta = kelvin_zeta(spec.restitution) if spec.damping is None else \
                spec.damping / (2 * np.sqrt(k * mu_pair))
            p["zeta"] = np.asarray(float(zeta))
        elif self.name == "hunt-crossley":
            p["n"] = np.asarray(float(spec.exponent))
            if spec.damping is None:
                p["a"] = np.asarray(hunt_crossley_a(spec.restitution))
                p["alpha"] = np.asarray(np.nan)
            else:
                p["a"] = np.asarray(np.nan)
                p["alpha"] = np.asarray(float(spec.damping))
        else:  # brach
            p["c1"] = np.asarray(float(spec.damping or 0.0))
            if spec.damping_restitution is None:
                p["e"] = np.asarray(float(spec.restitution))
                p["c2"] = np.asarray(np.nan)
            else:
                p["e"] = np.asarray(np.nan)
                p["c2"] = np.asarray(float(spec.damping_restitution))
        self.params = p

    # ------------------------------------------------------------------ smooth pieces
    def force(self, D, Ddot, st):
        """Contact force [force] while in contact (0 when open)."""
        on = st["on"]
        if self.name == "kelvin":
            return on * (st["k"] * D + st["c"] * Ddot)
        if self.name == "hunt-crossley":
            # |D|^n sign(D): the smooth-as-possible continuation below D = 0, where only a step's
            # trial stages go (the separation event at D = 0 ends the segment)
            Dn = abs(D) ** st["n"] * (2.0 * (D >= 0) - 1.0)
            return on * st["k"] * Dn * (1.0 + st["c"] * Ddot)
        return on * D * (st["k"] + st["c"] * Ddot)

    def events(self, D, Ddot, st):
        """(separation, max compression, closing, re-compression), all crossing downward."""
        on, comp, rest = st["on"], st["comp"], 1.0 - st["comp"]
        if self.name == "kelvin":
            sep = st["k"] * D + st["c"] * Ddot
        elif self.name == "hunt-crossley":
            sep = _min(D, 1.0 + st["c"] * Ddot)
        else:
            sep = _min(D, st["k"] + st["c"] * Ddot)
        return (on * sep + (1.0 - on),
                on * comp * Ddot + (1.0 - on * comp),
                (1.0 - on) * (-D) + on,
                on * rest * (-Ddot) + (1.0 - on * rest))

    def armed(self, st):
        """Which events can fire in this state (NumPy backends skip the others)."""
        on, comp = bool(st["on"]), bool(st["comp"])
        return (on, on and comp, not on, on and not comp)

    @property
    def affine_force(self) -> bool:
        """Whether the force is affine in the state inside a segment (Kelvin's ``k D + c Ḋ``;
        not Hunt–Crossley's ``k D^n (1 + α Ḋ)`` nor Brach's ``D (k + c Ḋ)``)."""
        return self.name == "kelvin"

    def event_linear(self, laws) -> tuple:
        """Every event is the minimum of linear pieces (:meth:`event_pieces`)."""
        return (True,) * len(self.event_kinds)

    def event_pieces(self, D, Ddot, st):
        """Each event as the minimum of functions linear in ``(D, Ḋ)``: the separation of
        Hunt–Crossley and Brach, where the force reaches zero, is the earlier of ``D = 0`` and
        the zero of its linear factor (``1 + α Ḋ``, ``k + c Ḋ``); the others are linear."""
        sep, turn, close, rec = self.events(D, Ddot, st)
        if self.name == "kelvin":
            return (sep,), (turn,), (close,), (rec,)
        on = st["on"]
        factor = (1.0 if self.name == "hunt-crossley" else st["k"]) + st["c"] * Ddot
        return ((on * D + (1.0 - on), on * factor + (1.0 - on)), (turn,), (close,), (rec,))

    @staticmethod
    def closing_gap(D, st):
        """While open: the deformation still to close before the contact touches again at
        ``D = 0`` [length] (its ``close`` event, ``-D``)."""
        return -D

    # ------------------------------------------------------------------ transitions
    def _zero(self, p, xp):
        z = xp.asarray(0.0)
        st = {"mode": xp.asarray(MODE_OPEN), "on": z, "comp": z, "k": xp.asarray(p["k"], float),
              "c": z, "c2": z, "dmax": z, "fmax": z, "dperm": z, "ec": z, "er": z, "wmark": z,
              "status": xp.asarray(0)}
        if self.name == "hunt-crossley":
            st["n"] = xp.asarray(p["n"], float)
        return st

    def _close(self, st, Ddot, p, xp, mu):
        """Contact (re)starts compressing at closing speed ``Ddot``."""
        out = dict(st)
        one = xp.asarray(1.0)
        out.update(mode=xp.asarray(MODE_LOADING), on=one, comp=one)
        if self.name == "kelvin":
            out["c"] = 2.0 * p["zeta"] * xp.sqrt(p["k"] * mu)
        elif self.name == "hunt-crossley":
            given = p["alpha"] == p["alpha"]  # not NaN
            a = xp.where(given, 0.0, p["a"])
            out["c"] = xp.where(given, xp.where(given, p["alpha"], 0.0),
                                a / xp.where(Ddot > 0, Ddot, 1.0))
        else:
            given = p["c2"] == p["c2"]
            e = xp.where(given, 0.5, p["e"])
            c2, ok = _brach_c2(p["k"], p["c1"], e, xp.where(Ddot > 0, Ddot, 1.0), mu, xp)
            out["c"] = xp.asarray(p["c1"], float)
            out["c2"] = xp.where(given, xp.where(given, p["c2"], 0.0), c2)
            out["status"] = xp.where(given | ok | (e >= 1), st["status"], 4)
            out["c2"] = xp.where(~given & (e >= 1), p["c1"], out["c2"])
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
        if self.name == "brach":
            turn["c"] = st["c2"]
        close = self._close(dict(st, wmark=w), Ddot, p, xp, mu)
        rec = dict(st)
        rec.update(mode=xp.asarray(MODE_LOADING), comp=one, er=st["er"] + st["wmark"] - w,
                   wmark=w)
        if self.name == "brach":
            rec["c"] = xp.asarray(p["c1"], float)
        return _sel(which == 0, sep, _sel(which == 1, turn, _sel(which == 2, close, rec, xp), xp), xp)

    @staticmethod
    def event_name(which: int, before: dict, after: dict) -> str:
        """Name of what happened (for ``Result.events``)."""
        return ("separation", "max_deformation", "contact", "recompression")[which]


def make_law(contact, mu_pair: float = 1.0):
    """The law object of a scene contact (only the laws the scene declares are built).

    ``mu_pair`` is the reduced mass of the two vehicles it joins [mass] (a Kelvin damping given
    as a restitution needs it)."""
    if isinstance(contact.law, Hysteresis):
        return HysteresisLaw(contact.law, getattr(contact, "failure", None))
    if isinstance(contact.law, Damping):
        return DampingLaw(contact.law, mu_pair)
    raise TypeError(f"no contact law implements {type(contact.law).__name__}")
