"""A scene as a hybrid ODE: continuous state, discrete modes, right-hand side and events.

The continuous state is ``y = (x_1..x_N, v_1..v_N, W...)``, with ``x_i`` the displacement of
vehicle ``i`` from where it starts [length], ``v_i`` its velocity [velocity], and one work integral
``W_k = ∫ F_k dD_k`` [energy] for each contact whose law needs it (the damping laws; the IF-D
hysteresis has its energies in closed form). Vehicles are listed rear to front; contact ``k``
joins vehicles ``k`` and ``k+1``, its deformation is ``D_k = x_k - x_{k+1} - gap_k`` and its force
``F_k >= 0`` pushes vehicle ``k`` back and vehicle ``k+1`` forward.

Only the effects a scene declares are assembled: one law object per contact (:mod:`lsc.contact`),
a brake effect per braked vehicle and a failure effect per contact with a failure force
(:mod:`lsc.effects`; with a post-failure curve the IF-D law follows the spliced curve and
reports the failure itself), and nothing else: no dormant term, no dormant event. Every method
takes the array namespace ``xp`` (``numpy`` or ``jax.numpy``): all backends run this one copy.

The discrete state ``disc`` is a list: the contacts' states (K), then the brakes', then the
failures'. Events are numbered in the same order; event ``i`` is event ``which`` of part ``j``.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from .contact import STATUS, make_law
from .effects import BrakeEffect, FailureEffect, vehicle_effects
from .errors import SimulationError
from .moving_frame import Frame

__all__ = ["HybridModel", "Frame", "OVER_TOL", "MAX_ANGLE", "EVENT_UNITS"]

#: Closing rates at most this fraction of the speed scale are rounding (``contacts_apart``).
OVER_TOL = 1e-12

#: Longest integrator step, in radians of the frozen contacts' fastest oscillation (``max_step``).
MAX_ANGLE = 0.5

#: The unit of each kind of event function (:meth:`HybridModel.event_scales`); a kind not named
#: here is a length (and a Kelvin law's ``separate``, ``k D + c Ḋ``, is a force).
EVENT_UNITS = {"vmax": "velocity", "turn": "velocity", "recompress": "velocity",
               "stop": "velocity", "break_forward": "force", "break_backward": "force",
               "failure": "force", "unlock_zero": "force", "unlock_line": "force",
               "settle": "velocity"}


def _event_unit(part, kind: str) -> str:
    """The unit (``length``, ``velocity`` or ``force``) of event ``kind`` of ``part``."""
    if kind == "separate" and getattr(part, "name", "") == "kelvin":
        return "force"
    return EVENT_UNITS.get(kind, "length")


class HybridModel:
    """The hybrid system of a :class:`~lsc.scene.Scene`.

    Attributes
    ----------
    N, K : int
        Number of vehicles and of contacts.
    laws, brakes, failures : list
        The assembled parts: one law per contact, the declared brake and failure effects.
    params : dict
        Numeric parameters (a pytree of arrays): ``m`` (N,) [mass], ``v0`` (N,) [velocity],
        ``gap`` (K,) [length], ``contacts``, ``brakes``, ``failures`` (lists of each part's dict).
    events : list of (j, which)
        Event ``i`` is event ``which`` of part ``j``; all cross zero downward.
    work : list of int
        The contacts with a work-integral state ``W`` (state index ``2N + position``).
    """

    def __init__(self, scene):
        self.scene = scene
        self.N = N = scene.n_vehicles
        self.K = len(scene.contacts)
        m = scene.masses
        mu = m[:-1] * m[1:] / (m[:-1] + m[1:])
        self.laws = [make_law(c, mu[k]) for k, c in enumerate(scene.contacts)]
        self.brakes = vehicle_effects(scene)  # brakes and other registered vehicle effects
        # A failure with a post-failure curve is the contact law's own (its loading curve is
        # spliced at the failure point, where its breakpoint event is the failure); a failure
        # force alone is an effect watching the contact force.
        self.failures = [FailureEffect(k, c.failure) for k, c in enumerate(scene.contacts)
                         if c.failure is not None and c.failure.post_failure is None]
        self.parts = [*self.laws, *self.brakes, *self.failures, *self._more_parts()]
        self.work = [k for k, law in enumerate(self.laws) if law.tracks_work]
        self._work_idx = np.asarray(self.work, dtype=int)
        # incidence (N, K): contact k pushes vehicle k back and vehicle k+1 forward
        self._incidence = np.eye(N, self.K, -1) - np.eye(N, self.K)
        self.n_state = 2 * N + len(self.work)
        self.params = {
            "m": m,
            "v0": scene.speeds,
            "gap": np.array([c.gap for c in scene.contacts], dtype=float),
            "contacts": [law.params for law in self.laws],
            "brakes": [b.params for b in self.brakes],
            "failures": [f.params for f in self.failures],
        }
        self.events = [(j, w) for j, part in enumerate(self.parts)
                       for w in range(len(part.event_kinds))]
        #: the unit of each event function: "length", "velocity" or "force"
        self.event_units = tuple(_event_unit(self.parts[j], self.parts[j].event_kinds[w])
                                 for j, w in self.events)
        v = scene.speeds.tolist()   # (speed_scale(), on Python floats: the same number)
        self.v_scale = max(max(map(abs, v)), max(abs(b - a) for a, b in zip(v, v[1:])), 1e-300)

    def _more_parts(self) -> list:
        return []   # (parts after the effects: lsc.locking.LockingModel's locks)

    def features(self) -> frozenset[str]:
        """Everything this scene uses that a backend must solve (its contract,
        :class:`lsc.solvers.base.Backend`): each contact law's (``law:ifd``, ``loading:table``,
        ...), each effect's ``feature`` (``effect:brake``, ...), ``gap:open`` for initial gaps,
        and ``contact:lock`` where a pair may lock (:func:`lsc.locking.lock_features`); once."""
        if "_features" not in self.__dict__:   # (a model is read-only once built)
            from .locking import lock_features   # (lsc.locking builds on this module)
            out = set(lock_features(self)).union(*(law.features() for law in self.laws))
            out |= {part.feature for part in (*self.brakes, *self.failures)}
            if np.any(np.asarray(self.params["gap"], float) > 0):
                out.add("gap:open")
            self.__dict__["_features"] = frozenset(out)
        return self.__dict__["_features"]

    # ------------------------------------------------------------------ kinematics
    def deformation(self, y, p, xp=np):
        """Deformations ``D`` (K, ...) [length] and closing rates ``Ddot`` (K, ...) [velocity]."""
        N = self.N
        x, v = y[:N], y[N:2 * N]
        return x[:-1] - x[1:] - p["gap"], v[:-1] - v[1:]

    def _mu(self, p, xp):
        """The reduced mass of each contact's pair (..., K) [mass]."""
        m = p["m"]
        return m[..., :-1] * m[..., 1:] / (m[..., :-1] + m[..., 1:])

    def initial(self, p=None, xp=np):
        """Initial continuous state ``y0`` and discrete state (list of per-part dicts)."""
        p = self.params if p is None else p
        y0 = xp.concatenate([xp.zeros(self.N), xp.asarray(p["v0"], dtype=float),
                             xp.zeros(len(self.work))])
        D, Dd = self.deformation(y0, p, xp)
        mu = self._mu(p, xp)
        disc = [law.init(D[k], Dd[k], p["contacts"][k], xp, mu=mu[k])
                for k, law in enumerate(self.laws)]
        F = xp.asarray([law.force(D[k], Dd[k], disc[k]) for k, law in enumerate(self.laws)])
        net = self.net_forces(F, xp)
        disc += [b.init(y0[self.N + b.i], net[b.i], p["m"][b.i], p["brakes"][j], xp)
                 for j, b in enumerate(self.brakes)]
        disc += [f.init(F[f.k], p["failures"][j], xp) for j, f in enumerate(self.failures)]
        return y0, disc

    # ------------------------------------------------------------------ smooth pieces
    def forces(self, y, disc, p, xp=np):
        """Contact forces (K, ...) [force] in the frozen discrete state."""
        D, Dd = self.deformation(y, p, xp)
        # (asarray of the list stacks it, as xp.stack would, at a tenth of the cost on NumPy)
        return xp.asarray([law.force(D[k], Dd[k], disc[k]) for k, law in enumerate(self.laws)])

    def net_forces(self, F, xp=np):
        """Net contact force on each vehicle (N, ...) [force] from the contact forces (K, ...):
        ``F_{i-1} - F_i``, through the incidence matrix built once (its entries are 0 and ±1, so
        every product is exact and each sum rounds once, as the difference itself does)."""
        return xp.matmul(self._incidence, F)

    def accelerations(self, y, disc, p, xp=np):
        """Contact forces (K, ...), net contact forces (N, ...) and accelerations (N, ...)."""
        F = self.forces(y, disc, p, xp)
        net = self.net_forces(F, xp)
        m = p["m"].reshape((-1,) + (1,) * (net.ndim - 1))
        a = net / m
        if self.brakes:
            acc = [a[i] for i in range(self.N)]
            off = self.K
            for j, b in enumerate(self.brakes):
                acc[b.i] = b.accel(net[b.i], p["m"][b.i], disc[off + j], p["brakes"][j])
            a = xp.asarray(acc)
        return F, net, a

    def rhs(self, t, y, disc, p, xp=np):
        """``dy/dt = (v, a, dW/dt)`` with ``m_i a_i = F_{i-1} - F_i`` plus the declared effects."""
        F, _, a = self.accelerations(y, disc, p, xp)
        parts = [y[self.N:2 * self.N], a]
        if self.work:
            _, Dd = self.deformation(y, p, xp)
            parts.append(F[self._work_idx] * Dd[self._work_idx])
        return xp.concatenate(parts)

    def event_values(self, t, y, disc, p, xp=np):
        """All event functions (n_events,), each crossing zero downward when it fires."""
        D, Dd = self.deformation(y, p, xp)
        vals = []
        for k, law in enumerate(self.laws):
            vals.extend(law.events(D[k], Dd[k], disc[k]))
        vals.extend(self._effect_events(y, disc, p, xp))
        return xp.asarray(vals, dtype=float)

    def _effect_events(self, y, disc, p, xp):
        """The event functions of the brakes and failures (a list)."""
        vals = []
        if self.brakes or self.failures:
            F, net, _ = self.accelerations(y, disc, p, xp)
            off = self.K
            for j, b in enumerate(self.brakes):
                vals.extend(b.events(y[self.N + b.i], net[b.i], p["m"][b.i], disc[off + j],
                                     p["brakes"][j]))
            off += len(self.brakes)
            for j, f in enumerate(self.failures):
                vals.extend(f.events(F[f.k], disc[off + j], p["failures"][j]))
        return vals

    def event_pieces(self, t, y, disc, p, xp=np):
        """The event functions as pieces (n_pieces, ...): event ``i`` is the minimum of the pieces
        ``j`` with ``piece_event[j] == i`` (a contact law's :meth:`event_pieces`, each linear in
        the state; an effect's event is one piece, linear where ``event_linear`` says so)."""
        D, Dd = self.deformation(y, p, xp)
        vals = []
        for k, law in enumerate(self.laws):
            for pieces in law.event_pieces(D[k], Dd[k], disc[k]):
                vals.extend(pieces)
        vals.extend(self._effect_events(y, disc, p, xp))
        return xp.asarray([xp.broadcast_to(xp.asarray(v, dtype=float), xp.shape(D[0]))
                           for v in vals])

    event_linear = property(lambda self: self._layout[0], doc="(n_events,) bool: linear in y?")
    piece_event = property(lambda self: self._layout[1], doc="(n_pieces,) int: each one's event")
    _layout = cached_property(lambda self: self._piece_layout())  # (built when first asked for)

    def _piece_layout(self):
        """(:attr:`event_linear`, :attr:`piece_event`)."""
        _, disc = self.initial()
        counts = [len(pieces) for k, law in enumerate(self.laws)
                  for pieces in law.event_pieces(0.0, 0.0, disc[k])]
        counts += [1] * (len(self.events) - len(counts))
        linear = [lin for part in self.parts for lin in part.event_linear(self.laws)]
        return (np.asarray(linear, bool),
                np.repeat(np.arange(len(self.events)), counts).astype(int))

    def active_events(self, disc) -> list[int]:
        """Indices of the events armed in this discrete state (NumPy backends skip the others)."""
        armed = [a for j, part in enumerate(self.parts) for a in part.armed(disc[j])]
        return [i for i, a in enumerate(armed) if a]

    # ------------------------------------------------------------------ transitions
    def work_of(self, y, k):
        """The work integral of contact ``k`` in state ``y`` (0 if its law keeps none)."""
        return y[2 * self.N + self.work.index(k)] if k in self.work else 0.0

    def apply_event(self, i: int, t, y, disc, p, xp=np):
        """Discrete state after event ``i`` at state ``y``; the other parts are unchanged."""
        j, w = self.events[i]
        new = list(disc)
        if j < self.K:
            D, Dd = self.deformation(y, p, xp)
            mu = self._mu(p, xp)
            new[j] = self.laws[j].on_event(w, D[j], Dd[j], disc[j], p["contacts"][j], xp,
                                           mu=mu[j], w=self.work_of(y, j))
            return new
        F, net, _ = self.accelerations(y, disc, p, xp)
        b = j - self.K
        if b < len(self.brakes):
            eff = self.brakes[b]
            new[j] = eff.on_event(w, y[self.N + eff.i], net[eff.i], p["m"][eff.i], disc[j],
                                  p["brakes"][b], xp)
            return new
        f = b - len(self.brakes)
        eff = self.failures[f]
        new[j] = eff.on_event(w, F[eff.k], disc[j], p["failures"][f], xp)
        return new

    def event_name(self, i: int, before, after) -> str:
        """What event ``i`` was, from the discrete state before and after it."""
        j, w = self.events[i]
        return self.parts[j].event_name(w, before[j], after[j])

    def side_events(self, i: int, before, after) -> list[tuple[str, int]]:
        """``[(name, index)]``: other parts event ``i`` changed (:mod:`lsc.locking`)."""
        return []

    def event_index(self, i: int) -> int:
        """The contact (or vehicle, for a brake event) that event ``i`` concerns."""
        j, _ = self.events[i]
        if j < self.K:
            return j
        b = j - self.K
        if b < len(self.brakes):
            return self.brakes[b].i
        return self.failures[b - len(self.brakes)].k

    def check_status(self, disc, t: float) -> None:
        """Raise :class:`SimulationError` if a part reached a state the physics cannot complete."""
        for k, st in enumerate(disc[: self.K]):
            code = int(st["status"])
            if code:
                raise SimulationError(f"contact {k} at t = {t:.6g} s: {STATUS[code]}")

    def is_over(self, y, disc, t=0.0, horizon=None, p=None, xp=np, v_scale=None):
        """True when every contact is open for good, or shut between two stuck vehicles
        (:meth:`contacts_apart`), and no braked vehicle slides (no force changes, none can act
        again); arguments as :meth:`contacts_apart` (a traced boolean on ``jax.numpy``)."""
        held = [st["mode"] == 0 for st in disc[self.K: self.K + len(self.brakes)]]
        if xp is np and not all(held):
            return False
        # (a contact shut between two stuck vehicles stays so: nothing moves, no force changes)
        stuck = {b.i for b in self.brakes if isinstance(b, BrakeEffect)}   # (all held)
        shut = [k in stuck and k + 1 in stuck for k in range(self.K)]
        over = self.contacts_apart(y, disc, t, horizon, p, xp, v_scale, shut)
        for h in held:
            over = over & h
        return bool(over) if xp is np else over

    def contacts_apart(self, y, disc, t=0.0, horizon=None, p=None, xp=np, v_scale=None,
                       shut=None):
        """True when every contact (but those ``shut`` (K,) may leave shut: between two stuck
        vehicles, :meth:`is_over`) is open and none will close again (braked vehicles may still
        slide): with every contact open no force acts, each vehicle keeps its speed, and contact
        ``k`` closes again at ``t + gap_k / rate_k`` (``gap_k`` [length]: what is left to close,
        :meth:`~lsc.contact.HysteresisLaw.closing_gap`; ``rate_k``: its closing rate). It will
        not when ``rate_k`` is rounding (at most ``OVER_TOL`` of the speed scale ``v_scale``,
        default :meth:`speed_scale`), or when that time is after ``horizon`` [s] (default
        :meth:`horizon`): a pair of an elastic chain left closing at 1e-11 ft/s, 2 ft apart,
        would close again after 2e11 s. ``t`` [s]: now; ``y`` (n,), ``disc``: one scene's state;
        ``p``, ``xp``: parameters and namespace (``jax.numpy``: a traced boolean)."""
        if p is None:
            p = self.params
            v_scale = self.v_scale if v_scale is None else v_scale
            horizon = self.crash_horizon if horizon is None else horizon
        v_scale = self.speed_scale(p, xp) if v_scale is None else v_scale
        horizon = self.horizon(p, xp) if horizon is None else horizon
        D, Dd = self.deformation(xp.asarray(y), p, xp)
        modes = xp.asarray([st["mode"] for st in disc[: self.K]])   # (one call each: stacked)
        gaps = xp.asarray([law.closing_gap(D[k], disc[k]) for k, law in enumerate(self.laws)],
                          dtype=float)
        late = gaps > Dd * (horizon - t)
        idle = (modes == 0) & ((Dd <= OVER_TOL * v_scale) | late)
        apart = (idle if shut is None else idle | xp.asarray(shut)).all()
        return bool(apart) if xp is np else apart

    # ------------------------------------------------------------------ scales
    # Array code of the parameters ``p`` (default :attr:`params`; every array may carry the
    # same leading batch axes, ``p["m"]`` (..., N)) on NumPy or ``jax.numpy`` (``xp``), traceable
    # by ``jax.jit`` and ``jax.vmap``: each returns an array of the batch shape (a scalar for one
    # scene) unless it says otherwise.
    def speed_scale(self, p=None, xp=np):
        """The speed scale [velocity]: the largest initial speed or speed difference."""
        v = (self.params if p is None else p)["v0"]
        fastest = xp.abs(v).max(axis=-1)
        closing = xp.abs(v[..., 1:] - v[..., :-1]).max(axis=-1)
        return xp.maximum(xp.maximum(fastest, closing), 1e-300)

    def _slopes(self, p, keys, xp):
        """The contacts' slopes named by ``keys`` (..., n) [force/length], each made positive;
        None if no contact has any."""
        batch = xp.shape(p["m"])[:-1]
        slopes = [xp.abs(xp.reshape(c[key], batch + (-1,))) for c in p["contacts"]
                  for key in keys if key in c]
        return xp.concatenate(slopes, axis=-1) if slopes else None

    def time_scale(self, slowest: bool = False, loading: bool = False, p=None, xp=np):
        """A rough contact time [s] from the stiffest slope and the lightest pair (``slowest``:
        from the softest slope and the heaviest pair; ``loading``: leaving out the IF-D laws'
        unloading stiffnesses, for a motion with no contact unloading). Slopes that are zero or
        not finite are left out; with none left the slope is 1."""
        p = self.params if p is None else p
        mus = self._mu(p, xp)
        mu = mus.max(axis=-1) if slowest else mus.min(axis=-1)
        s = self._slopes(p, ("ls", "k") if loading else ("ls", "su", "k"), xp)
        if s is None:
            return xp.sqrt(mu)
        valid = xp.isfinite(s) & (s > 0)
        if slowest:
            k = xp.where(valid, s, xp.inf).min(axis=-1)
            k = xp.where(xp.isfinite(k), k, 1.0)
        else:
            k = xp.where(valid, s, 0.0).max(axis=-1)
            k = xp.where(k > 0, k, 1.0)
        return xp.sqrt(mu / k)

    def force_scale(self, p=None, xp=np):
        """The force scale [force]: the lightest pair's ``μ v / t`` (speed scale over the
        fastest contact time: a linear contact's ``F_max``)."""
        p = self.params if p is None else p
        mu = xp.min(self._mu(p, xp), axis=-1)
        return mu * self.speed_scale(p, xp) / self.time_scale(p=p, xp=xp)

    def event_scales(self, p=None, xp=np):
        """The scale of each event function (..., n_events), by its unit
        (:attr:`event_units`): a length (speed scale times the contact time), the speed scale,
        or the force scale (:meth:`force_scale`)."""
        p = self.params if p is None else p
        batch = xp.shape(p["m"])[:-1]
        v = self.speed_scale(p, xp)
        t = self.time_scale(p=p, xp=xp)
        mu = xp.min(self._mu(p, xp), axis=-1)
        by_unit = {"length": v * t, "velocity": v, "force": mu * v / t}
        if not self.event_units:
            return xp.zeros(batch + (0,))
        return xp.stack([xp.broadcast_to(by_unit[u], batch) for u in self.event_units], axis=-1)

    def horizon(self, p=None, xp=np):
        """A time [s] by which a crash of this scene is over unless a contact never separates:
        a million contact times on the softest slope, plus four times what closing every gap and
        crossing every table takes at the slowest initial closing speed (a gap closed at 1e-4
        ft/s, a table traversed slowly, take far longer than any contact time)."""
        p = self.params if p is None else p
        batch = xp.shape(p["m"])[:-1]
        v = self.speed_scale(p, xp)
        w = p["v0"][..., :-1] - p["v0"][..., 1:]
        w = xp.where(w > 1e-12 * v[..., None], w, xp.inf)
        w_min = w.min(axis=-1)
        w_min = xp.where(xp.isfinite(w_min), w_min, v)
        extent = p["gap"].sum(axis=-1)
        for c in p["contacts"]:
            for key in ("ld", "ud"):   # (a table's last breakpoint: BIG, 1e300, is no extent)
                if key in c:
                    val = xp.abs(xp.reshape(c[key], batch + (-1,)))
                    extent = extent + xp.where(val < 1e299, val, 0.0).max(axis=-1)
        return 1e6 * self.time_scale(slowest=True, p=p, xp=xp) + 4.0 * extent / w_min + 1.0

    #: :meth:`horizon`, computed once [s].
    crash_horizon = cached_property(lambda self: float(self.horizon()))

    def natural_frequency(self, disc, p=None, xp=np):
        """A bound on the highest angular frequency [1/s] of the motion in the frozen discrete
        state ``disc`` (0 when no contact is loaded): each loaded contact's slope, ``|s|`` of the
        IF-D law's active piece ``F = fa + s (D - da)`` (an unloading line's too) or the spring
        ``k`` of a Kelvin or Brach law, acts on both its vehicles;
        ``ω² <= max_i (sum of 2|slope| at vehicle i) / m_i`` (Gershgorin). Hunt-Crossley springs
        (``k D^n``) have no constant slope and count as 0."""
        m = (self.params if p is None else p)["m"]
        batch = xp.shape(m)[:-1]
        load = [0.0] * self.N
        for k, (law, st) in enumerate(zip(self.laws, disc[: self.K])):
            if "s" in st:
                slope = st["s"]
            elif getattr(law, "name", "") in ("kelvin", "brach"):
                slope = st["k"]
            else:
                continue
            slope = xp.where(st["mode"] != 0, 2.0 * xp.abs(slope), 0.0)
            load[k] = load[k] + slope
            load[k + 1] = load[k + 1] + slope
        load = xp.stack([xp.broadcast_to(xp.asarray(v, dtype=float), batch) for v in load],
                        axis=-1)
        return xp.sqrt(xp.max(load / m, axis=-1))

    def position_time(self, disc, T, p=None, xp=np):
        """The time [s] that turns a speed tolerance into a position one in discrete state
        ``disc``: ``T``, the contact time scale of the loading slopes (:meth:`time_scale` with
        ``loading=True``), or
        ``1 / ω`` (:meth:`natural_frequency`) where the active pieces are stiffer. A rebound line
        100 times stiffer than any loading piece (e = 1e-6 after a long zero-force plateau: 1e-14
        ft wide) is then resolved to ``rtol`` of its own width; while loading, the position
        tolerance does not shrink to that of a rebound line that is not yet active (LSODA took
        millions of steps with unloading 1e13 times stiffer than loading)."""
        w = self.natural_frequency(disc, p, xp)
        return xp.where(w * T > 1.0, 1.0 / xp.where(w > 0, w, 1.0), T)

    def max_step(self, disc, p=None, xp=np):
        """The longest integrator step [s] in discrete state ``disc``: ``MAX_ANGLE / ω``
        (:meth:`natural_frequency`), ``inf`` while no contact is loaded. Over longer steps of an
        oscillation the embedded error estimates stop being reliable."""
        w = self.natural_frequency(disc, p, xp)
        return xp.where(w > 0, MAX_ANGLE / xp.where(w > 0, w, 1.0), xp.inf)

    def default_atol(self, rtol, disc=None, p=None, xp=np):
        """The default absolute tolerances (..., n_state) for relative tolerance ``rtol``:
        ``rtol`` times the speed scale for velocities, times :meth:`position_time` for
        positions (the loading contact time, or the active pieces' ``1 / ω`` in discrete state
        ``disc`` where they are stiffer: a near-plastic rebound line; without ``disc`` the
        loading contact time), and times the speed scale and the lightest mass for the work
        integrals (an energy)."""
        p = self.params if p is None else p
        batch = xp.shape(p["m"])[:-1]
        v = self.speed_scale(p, xp)
        rv = rtol * v
        T = self.time_scale(loading=True, p=p, xp=xp)
        if disc is not None:
            T = self.position_time(disc, T, p, xp)
        energy = rv * v * xp.min(p["m"], axis=-1)

        def full(x, n):
            return xp.broadcast_to(xp.expand_dims(x, -1), batch + (n,))
        return xp.concatenate([full(rv * T, self.N), full(rv, self.N),
                               full(energy, len(self.work))], axis=-1)

    def frame(self, t0, y, p=None, xp=np) -> Frame:
        """The frame a segment that starts at time ``t0`` [s] in state ``y`` (n,) is integrated
        in (:class:`Frame`): positions from where the vehicles are at ``t0``, moving with the
        centre of mass (``V = Σ m v / Σ m``), or not at all with brakes, which need each
        vehicle's own velocity (and a held vehicle must stay exactly where it is)."""
        m = (self.params if p is None else p)["m"]
        N = self.N
        V = xp.asarray(0.0) if self.brakes else xp.matmul(m, y[N:2 * N]) / xp.sum(m)
        return Frame(t0, xp.array(y[:N], dtype=float), V)

    @staticmethod
    def to_python(disc) -> list[dict]:
        """A NumPy discrete state as plain Python scalars (fast in the NumPy right-hand side)."""
        return [{key: (int(v) if key in ("mode", "seg", "status") else float(v))
                 for key, v in st.items()} for st in disc]
