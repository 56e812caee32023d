"""Locked pairs: an IF-D contact of a chain held shut by its neighbours moves as one body.

A near-plastic contact at its permanent set that a neighbour keeps pushing closes, stops,
separates and closes again, each closing a tiny impact (the IF-D law has no sticking mode): the
integrators chatter to their event limit. While the force that holds such a pair together stays
inside the law's range, between zero and the force of its unloading/reloading line at its
deformation, the pair is a rigid link: its deformation ``D_lock`` is held, its vehicles share one
acceleration, and its force follows from the motion. For a cluster of vehicles ``a..b`` joined by
locked contacts, pushed from behind by ``F_L`` (contact ``a-1``) and held from the front by ``F_R``
(contact ``b``), each vehicle accelerates at ``(F_L - F_R) / M`` (``M``: the cluster's mass) and
the locked contact ``k`` carries

    ``F_k = (M_front F_L + M_rear F_R) / M``

(``M_rear``: the mass of vehicles ``a..k``, ``M_front = M - M_rear``), affine in the state where
``F_L`` and ``F_R`` are IF-D forces. The lock is released when ``F_k`` falls to zero (the pair is
pulled apart: separation, or unloading along the line from ``D_lock``) or rises to ``F_top``, the
line's force at ``D_lock`` (the contact then reloads along its line, or its loading curve). The
held deformation keeps the line's stored energy, and the locked force does no work (``dD/dt = 0``),
so the energy balance holds exactly.

A lock is an approximation of the law (a rigid link in place of ringing on a very stiff
unloading line), acceptable only where the plain law cannot be followed: every chain that the
plain law finishes without chattering gives exactly the numbers it gives without locks. Only a
contact that unloads by a restitution below :data:`WATCH_RESTITUTION`, in a chain of three or
more IF-D contacts with no brake and no failure force, can lock (the model feature
:data:`FEATURE`, :func:`lock_features`), and it locks (:class:`LockPart`, driven by
:class:`LockingModel`):

- (rule 1) at its max deformation where the law separates at once (``e = 0``), or rebounds by less
  than the integrators resolve (``e <`` :data:`LOCK_RESTITUTION`), and the neighbours press
  the pair (``0 < F_k < F_max``): the plain law then closes it again at once, at its max
  deformation, without end (the lock is that chatter's limit; it releases at zero force into
  the law's own rebound, so a press that ends at once loses nothing but the ``e² D_max``
  ringing the integrators do not resolve);
- (rule 2) at the next turning point on its line (``dD/dt`` through zero downward, or its max
  deformation after reloading past ``D_max``), where pressed (``0 < F_k < F_top``), after it
  has closed again :data:`CHATTER_CLOSINGS` times while pressed (at its permanent set, or
  reloading past ``D_max``; ``F_k > 0`` at the closing). A separation where the neighbours do
  not press the pair (``F_k <= 0``: it leaves) starts the count again. A chain that rule 1
  does not lock and whose contacts close again fewer times is the plain law's, bit for bit.

Why :data:`CHATTER_CLOSINGS` = 8: a pressed pair with ``e < 0.05`` that comes back to its
permanent set or to ``D_max`` is not bouncing apart but ringing on its line, about ``1 / e``
times faster than its contact (its line is ``1 / e²`` times stiffer), for as long as the
neighbours press it: hundreds to thousands of events for stiffness ratios of 1:1000. Eight
closings are more than a genuine rebound sequence of such a contact has (each rebound's speed
is ``e`` times the last: ``0.05^8 = 4e-11`` of the first, below the integrators' resolution),
and few enough that a chattering chain locks within a few dozen events.

Exact-chain locks by the same rules on its exact motion (:mod:`lsc.solvers.exact_chain._locks`:
the reduced system of the clusters in closed form). Diffrax runs the same transitions inside its
compiled loop (``xp = jax.numpy``): each condition on the discrete state is then traced, and
both branches are evaluated and selected field by field (:mod:`lsc.lock_law`), where on NumPy
only the branch taken runs, the same operations as a plain ``if`` (SciPy's and exact-chain's
numbers are those of the branching code). Its batch path hands the members whose pairs may lock
to its single solve (:func:`lock_members`).
"""

from __future__ import annotations

import numpy as np

from .laws import BIG, MODE_LOADING, MODE_OPEN, MODE_UNLOADING, HysteresisLaw
from .laws.hysteresis import _lazy
from .lock_law import (PRESS_TOL, cluster_forces, clusters, force_rounding, if_,
                       locked_forces, none, not_, pick, project)
from .model import HybridModel

__all__ = ["LockPart", "LockingModel", "CHATTER_CLOSINGS", "WATCH_RESTITUTION",
           "LOCK_RESTITUTION", "FEATURE", "lock_features", "locking_model", "can_lock", "may_lock",
           "warning", "lock_warnings", "lock_members", "clusters", "cluster_forces",
           "locked_forces", "pressed", "PRESS_TOL"]

#: Closings while pressed after which a contact locks at its next turning point (the module).
CHATTER_CLOSINGS = 8

#: Only a contact unloading by a restitution below this can lock (from 0.05 up, a pressed pair
#: rings on its line at most ~20 times per period of its contact: the integrators follow it).
WATCH_RESTITUTION = 0.05

#: A contact with a restitution below this locks at its max deformation where pressed (rule 1):
#: its rebound, ``e² D_max`` wide, is below 1e-10 of ``D_max`` (SciPy's default rtol), which
#: the integrators do not resolve, and a pair pressed on it rings over 1e5 times faster than
#: its contact (the plain law chatters). From 1e-5 on, only a counted chatter locks.
LOCK_RESTITUTION = 1e-5

#: The model feature of a scene whose pairs may lock (:func:`lock_features`).
FEATURE = "contact:lock"


def can_lock(model) -> bool:
    """Whether ``model``'s contacts can lock: a chain (three vehicles or more) of IF-D contacts
    with no brake and no failure effect (whose forces the locked force would need)."""
    return (model.N >= 3 and not model.brakes and not model.failures
            and all(isinstance(law, HysteresisLaw) for law in model.laws))


def may_lock(model, k: int, p=None, below: float = WATCH_RESTITUTION):
    """Whether contact ``k`` of a chain that :func:`can_lock` may lock: it unloads by a
    restitution below ``below`` (``p``: the parameters, the model's own by default; a traced
    boolean where they are traced)."""
    p = model.params if p is None else p
    return model.laws[k].unload_kind == "restitution" and (p["contacts"][k]["e"] < below)


def lock_members(model, p) -> np.ndarray:
    """(n,) bool: the members of a batch (``p``: parameters with a leading member axis of
    ``n``) whose pairs may lock (:func:`may_lock` on each member's restitutions): a batch path
    that follows the plain law hands them to the single solve, which locks."""
    n = int(np.shape(p["m"])[0])
    out = np.zeros(n, bool)
    if can_lock(model):
        for k, law in enumerate(model.laws):
            if law.unload_kind == "restitution":
                out |= np.broadcast_to(np.asarray(p["contacts"][k]["e"], float), (n,)) \
                    < WATCH_RESTITUTION
    return out


def lock_features(model) -> frozenset[str]:
    """``{FEATURE}`` where some pair of ``model`` may lock, else empty (the backend contract:
    :meth:`lsc.model.HybridModel.features`)."""
    if can_lock(model) and any(may_lock(model, k) for k in range(model.K)):
        return frozenset({FEATURE})
    return frozenset()


def pressed(model, y, disc, p, mask, xp=np) -> tuple[list, list]:
    """``(rows, pressed)``: the forces (K) [force] the contacts carry with those where
    ``mask`` (K booleans) is locked (:func:`locked_forces` of the laws' forces in ``disc``),
    and whether each is pressed: its force positive, or within its rounding of zero
    (:func:`~lsc.lock_law.force_rounding`) and rising (the slopes times the closing rates, by
    the same cluster law): a pair whose pusher touches now is pressed, which an exact backend
    sees (an integrator, a moment later)."""
    F = HybridModel.forces(model, y, disc, p, xp)
    _, Dd = model.deformation(y, p, xp)
    s = xp.stack([xp.asarray(disc[j]["s"], float) for j in range(model.K)])
    rows, _ = locked_forces(F, p["m"], mask, model.K, xp)
    rates, _ = locked_forces(s * Dd, p["m"], mask, model.K, xp)
    tol = force_rounding(model.force_scale(p, xp), y[: model.N], s, xp)
    return rows, [(f > 0.0) | ((f > -tol) & (r > 0.0)) for f, r in zip(rows, rates)]


def closing_step(w: int, was: dict, now: dict):
    """What law event ``w`` (0 lo, 1 hi, 2 vmax) from law state ``was`` to ``now`` did to the
    count of closings: ``(close, open)``, closed again (at the permanent set, or reloaded past
    ``D_max``) and separated (booleans, traced where the states are)."""
    mb, ma = was["mode"], now["mode"]
    close = False
    if w == 1:
        close = ((mb == MODE_OPEN) & (ma != MODE_OPEN)) | (
            (mb == MODE_UNLOADING) & (ma == MODE_LOADING))
    return close, not_(close) & (ma == MODE_OPEN) & (mb != MODE_OPEN)


def recount(close, pressed, count, mode_after, xp=np) -> tuple:
    """``(count, watch)`` after a closing (``close``; else a separation, :func:`closing_step`):
    a closing while pressed counts; a separation while not pressed starts again. ``watch``: 0
    (none), 1 (lock at the next turning point on the line), 2 (lock at the next max
    deformation)."""
    closed = count + pick(pressed, 1.0, 0.0, xp)
    watch = pick(closed < CHATTER_CLOSINGS, 0.0,
                  pick(mode_after == MODE_UNLOADING, 1.0, 2.0, xp), xp)
    return (pick(close, closed, pick(pressed, count, 0.0, xp), xp),
            pick(close, watch, 0.0, xp))


class LockPart:
    """The lock of contact ``k`` (a part of the hybrid model, after the laws).

    Discrete state: ``mode`` (1 while locked), ``count`` (closings while pressed,
    :func:`recount`), ``watch`` (1: the ``settle`` event is armed, the lock fires at the next
    turning point on the line; 2: at the next max deformation), ``kind`` (0: locked at a max
    deformation, released at zero force by the law's own transition; 1: locked on the line,
    released onto it), ``ftop``
    [force] and ``dlock`` [length], and the law's state before the lock under ``law_*`` keys.

    Events (each crossing zero downward): ``unlock_zero`` (``F_k``), ``unlock_line``
    (``F_top - F_k``), ``settle`` (the closing rate ``dD/dt``); all linear in the state."""

    event_kinds = ("unlock_zero", "unlock_line", "settle")

    def __init__(self, k: int):
        self.k = k

    @staticmethod
    def init(law_state: dict | None = None) -> dict:
        """Unlocked, not watching, no closing counted (with ``law_state``, the law's state,
        under the ``law_*`` keys a lock saves: a discrete state of one structure throughout,
        as a compiled loop carries it)."""
        out = {"mode": 0, "count": 0.0, "watch": 0.0, "kind": 0.0, "ftop": 0.0, "dlock": 0.0}
        out.update({"law_" + key: val for key, val in (law_state or {}).items()})
        return out

    @staticmethod
    def armed(st) -> tuple:
        """Which events can fire in this state."""
        on = bool(st["mode"])
        return (on, on, st["watch"] == 1.0 and not on)

    @staticmethod
    def event_linear(laws) -> tuple:
        """Every release condition is affine in the neighbours' IF-D forces: linear."""
        return (True, True, True)

    @staticmethod
    def events(force, closing_rate, st, xp=np) -> list:
        """``[F_k, F_top - F_k, dD/dt]`` where armed (1 where not)."""
        on = st["mode"] != 0
        watch = (st["watch"] == 1.0) & not_(on)
        return [pick(on, force, 1.0, xp), pick(on, st["ftop"] - force, 1.0, xp),
                pick(watch, closing_rate, 1.0, xp)]

    @staticmethod
    def locked(st, law_state: dict, ftop, D, kind: int) -> dict:
        """The lock's state when it locks with the law in ``law_state``."""
        out = {"mode": 1, "count": st["count"], "watch": 0.0, "kind": float(kind),
               "ftop": ftop, "dlock": D}
        out.update({"law_" + key: val for key, val in law_state.items()})
        return out

    @staticmethod
    def saved(st, xp=np) -> dict:
        """The law's state saved when the lock locked."""
        whole = ("mode", "seg", "status") if xp is np else ()
        return {key[4:]: (int(val) if key[4:] in whole else val)
                for key, val in st.items() if key.startswith("law_")}


class LockingModel(HybridModel):
    """A chain's :class:`~lsc.model.HybridModel` with a lock per contact (after the laws and
    effects, in :attr:`parts` and the discrete state), on NumPy or ``jax.numpy`` alike (``xp``):
    SciPy's and diffrax's backends build it (:func:`locking_model`; diffrax runs its
    transitions traced, each condition a select); exact-chain drives its transitions on its
    own exact motion (:mod:`lsc.solvers.exact_chain._locks`)."""

    def _more_parts(self) -> list:
        """One :class:`LockPart` per contact."""
        self.locks = [LockPart(k) for k in range(self.K)]
        return self.locks

    def initial(self, p=None, xp=np):
        """The plain model's initial state, every lock open."""
        y0, disc = super().initial(p, xp)
        return y0, disc + [lock.init(disc[lock.k]) for lock in self.locks]

    def forces(self, y, disc, p, xp=np):
        """Contact forces (K, ...) [force], a locked contact's from its cluster's motion
        (:func:`locked_forces`)."""
        F = self._law_forces(y, disc, p, xp)
        mask = self._mask(disc)
        if none(mask):
            return F
        return xp.asarray(locked_forces(F, p["m"], mask, self.K, xp)[0])

    def project(self, y, disc, p, xp=np):
        """The state (n,) a segment in ``disc`` starts from: :func:`~lsc.lock_law.project`."""
        return project(y, self.N, p["m"], self._mask(disc), xp)

    def _law_forces(self, y, disc, p, xp=np):
        """The contact laws' forces (K, ...) [force] (0 for a locked contact)."""
        return HybridModel.forces(self, y, disc, p, xp)

    def accelerations(self, y, disc, p, xp=np):
        """As the plain model's, each vehicle of a cluster at the cluster's one acceleration
        (exactly: no rounding may open the held deformation)."""
        mask = self._mask(disc)
        if none(mask):
            return super().accelerations(y, disc, p, xp)
        # (can_lock: no brake; the forces and the shared accelerations from one pass)
        rows, join = locked_forces(self._law_forces(y, disc, p, xp), p["m"], mask, self.K, xp)
        F = xp.asarray(rows)
        net = self.net_forces(F, xp)
        a = net / p["m"].reshape((-1,) + (1,) * (net.ndim - 1))
        return F, net, xp.asarray(join(a))

    def _effect_events(self, y, disc, p, xp):
        """The locks' event functions (a chain that can lock has no other effect)."""
        F, _, _ = self.accelerations(y, disc, p, xp)
        _, Dd = self.deformation(y, p, xp)
        off = self._lock_offset
        vals = []
        for lock in self.locks:
            vals.extend(lock.events(F[lock.k], Dd[lock.k], disc[off + lock.k], xp))
        return vals

    def apply_event(self, i: int, t, y, disc, p, xp=np):
        """The discrete state after event ``i``: its own part's transition (none for a lock's),
        then the locks lock, watch or release as it makes them (:meth:`_relock`)."""
        return self.settle(y, self.event_transition(i, t, y, disc, p, xp), p, xp)

    def event_transition(self, i: int, t, y, disc, p, xp=np):
        """:meth:`apply_event` but the release of the locks whose force has left its range
        (:meth:`settle`, the same for every event: a compiled loop applies it once, after the
        transition of whichever event fired)."""
        own = self.events[i][0] < self._lock_offset
        new = super().apply_event(i, t, y, disc, p, xp) if own else list(disc)
        return self._relock(i, y, disc, new, p, xp, settle=False)

    def event_name(self, i: int, before, after) -> str:
        """What event ``i`` was (``+lock`` where it locked its contact; a lock's own event:
        ``lock``, ``unlock``, ``separation`` or ``settle``)."""
        j, _ = self.events[i]
        off = self._lock_offset
        if j >= off:
            return self._lock_name(before[j], after[j], after[j - off])
        name = super().event_name(i, before, after)
        if j < self.K and after[off + j]["mode"] and not before[off + j]["mode"]:
            name = name.replace("+separation", "") + "+lock"
        return name

    def event_index(self, i: int) -> int:
        """The contact (or vehicle) that event ``i`` concerns."""
        j, _ = self.events[i]
        return j - self._lock_offset if j >= self._lock_offset else super().event_index(i)

    @property
    def _lock_offset(self) -> int:
        """The index of the first lock part in :attr:`parts` (and in the discrete state)."""
        return self.K + len(self.brakes) + len(self.failures)

    def locked(self, disc) -> list[int]:
        """The locked contacts in discrete state ``disc``."""
        off = self._lock_offset
        return [lock.k for lock in self.locks if disc[off + lock.k]["mode"]]

    def _mask(self, disc, also=None) -> list:
        """Whether each contact is locked in ``disc`` (K booleans, traced where it is), and
        contact ``also``."""
        off = self._lock_offset
        return [True if k == also else disc[off + k]["mode"] != 0 for k in range(self.K)]

    @staticmethod
    def _lock_name(before, after, law_after) -> str:
        """The name of a lock's event from its states and its law's state after it."""
        if after["mode"] and not before["mode"]:
            return "lock"
        if before["mode"] and not after["mode"]:
            return "separation" if int(law_after["mode"]) == 0 else "unlock"   # 0: open
        return "settle"

    def side_events(self, i: int, before, after) -> list[tuple[str, int]]:
        """``[(name, contact)]``: the locks that event ``i`` released besides its own part (a
        cluster whose push ended with a neighbour's event), named as their own events."""
        j = self.events[i][0]
        out = []
        for lock in self.locks:
            jj = self._lock_offset + lock.k
            if jj != j and before[jj]["mode"] and not after[jj]["mode"]:
                out.append((self._lock_name(before[jj], after[jj], after[lock.k]), lock.k))
        return out

    def _relock(self, i, y, before, new, p, xp=np, settle=True):
        """The locks after event ``i`` (its own transition already in ``new``): lock, count,
        watch or release (:mod:`lsc.locking`), then release every lock its force has left
        (:meth:`settle`)."""
        j, w = self.events[i]
        off = self._lock_offset
        if j < self.K:
            new = if_(may_lock(self, j, p), lambda: self._law_event(j, w, y, before[j], new, p,
                                                                    xp), lambda: new, xp)
        elif j >= off:
            k = j - off
            if w == 2:   # settle: the turning point on the line the watch waited for
                new = list(new)
                new[j] = dict(new[j], watch=0.0)
                st = new[k]

                def lock():
                    D, _ = self.deformation(y, p, xp)
                    ftop = self.laws[k].force(D[k], 0.0, st)
                    return self._try_lock(k, y, new, p, st, st, ftop, 1, xp)
                new = if_(st["mode"] == MODE_UNLOADING, lock, lambda: new, xp)
            else:
                new = self._release(k, w == 1, y, new, p, xp)
        return self.settle(y, new, p, xp) if settle else new

    def _law_event(self, k, w, y, was, new, p, xp=np):
        """``new`` after contact ``k``'s law event ``w`` from law state ``was``: locked at a
        max deformation (an instant separation, or one the watch waited for) where pressed,
        else its closings counted (:func:`recount`)."""
        off = self._lock_offset
        now, lock = new[k], new[off + k]
        tried, locked_now = new, False
        if w == 2:
            at_max = (was["mode"] == MODE_LOADING) & (
                (now["mode"] == MODE_OPEN) | may_lock(self, k, p, LOCK_RESTITUTION)
                | (lock["watch"] == 2.0))

            def lock_at_max():
                D, _ = self.deformation(y, p, xp)
                ftop = self.laws[k].force(D[k], 0.0, was)
                return self._try_lock(k, y, new, p, was, now, ftop, 0, xp)
            tried = if_(at_max, lock_at_max, lambda: new, xp)
            locked_now = at_max & (tried[off + k]["mode"] != 0)
            # (not pressed: the turning point passed; a line too stiff to resolve is watched
            # from the start, its turning points lock where pressed)
            lock = _lazy(at_max, lambda: dict(lock, watch=pick(
                now["mode"] == MODE_UNLOADING, 1.0, 0.0, xp)), lambda: lock, xp)
        close, opened = closing_step(w, was, now)

        def counted():
            press = pressed(self, y, new, p, self._mask(new, k), xp)[1][k]
            count, watch = recount(close, press, lock["count"], now["mode"], xp)
            return dict(lock, count=count, watch=watch)
        lock = _lazy(close | opened, counted, lambda: lock, xp)
        out = list(new)
        out[off + k] = lock
        return if_(locked_now, lambda: tried, lambda: out, xp)

    def _try_lock(self, k, y, new, p, saved, records, ftop, kind, xp=np):
        """``new`` with contact ``k`` locked where its neighbours press it inside the law's
        range (``0 < F_k < ftop``); ``saved``: the law's state to release into, ``records``:
        the state whose history (``dmax, fmax, dperm, ec, er``) the locked contact keeps."""
        rows, press = pressed(self, y, new, p, self._mask(new, k), xp)
        force = rows[k]

        def lock():
            D, _ = self.deformation(y, p, xp)
            out = list(new)
            out[k] = dict(records, mode=MODE_UNLOADING, da=0.0, fa=0.0, s=0.0, lo=-BIG, wl=BIG,
                          hi=BIG, vm=0.0)
            off = self._lock_offset
            out[off + k] = LockPart.locked(new[off + k], saved, ftop, D[k], kind)
            return out
        return if_(press[k] & (force < ftop), lock, lambda: new, xp)

    def _release(self, k, high, y, new, p, xp=np):
        """``new`` with contact ``k``'s lock released: onto the law's saved state (reloading
        along its line or curve; ``high``, or a lock on the line), or at zero force from a max
        deformation by the law's own transition (it separates there)."""
        off = self._lock_offset
        lock = new[off + k]
        law_state = LockPart.saved(lock, xp)

        def at_max():
            # (at the held deformation: the pair's residual closing rate at the lock, a
            # rounding error, has moved it by a rounding error since)
            st = self.laws[k].on_event(2, lock["dlock"], 0.0, law_state, p["contacts"][k], xp,
                                       mu=self._mu(p, xp)[k])
            return self.to_python([st])[0] if xp is np else st
        law_state = _lazy(not_(high) & (lock["kind"] == 0), at_max, lambda: law_state, xp)
        new = list(new)
        new[k] = law_state
        new[off + k] = {**lock, **LockPart.init(), "count": lock["count"]}   # (it chattered)
        return new

    def settle(self, y, new, p, xp=np):
        """Release, one at a time, each lock whose force has left ``(0, F_top)``."""
        off = self._lock_offset
        for _ in range(len(self.locks) + 1):
            mask = self._mask(new)
            if none(mask):
                break
            rows, press = pressed(self, y, new, p, mask, xp)
            out = [mask[k] & not_(press[k] & (rows[k] < new[off + k]["ftop"]))
                   for k in range(self.K)]
            if none(out):
                break
            earlier = False
            for k in range(self.K):
                high = rows[k] >= new[off + k]["ftop"]
                new = if_(out[k] & not_(earlier), lambda k=k, high=high, new=new:
                          self._release(k, high, y, new, p, xp), lambda new=new: new, xp)
                earlier = earlier | out[k]
        return new


def warning(locks) -> str:
    """The Result's warning where contacts locked: ``locks``, ``[(contact, time [s])]``. The
    motion then left the plain IF-D law (which chatters there) for its locked-pair model."""
    times = {}
    for k, t in locks:
        times.setdefault(k, []).append(t)
    which = "; ".join(f"contact {k} at t = {ts[0]:.6g} s" + (f" and {len(ts) - 1} more times "
                      f"to t = {ts[-1]:.6g} s" if len(ts) > 1 else "")
                      for k, ts in sorted(times.items()))
    return (f"a pressed pair locked ({which}): the plain IF-D law chatters there (it closes "
            f"again and again); the pair moved as one body while pressed, a model of that "
            f"chatter's limit (see 'Locked pairs' in the physics docs; methods 'scipy', "
            f"'exact-chain' and 'diffrax' lock by the same rules)")


def lock_warnings(events) -> dict:
    """``{"warnings": [warning]}`` where a pair locked in ``events`` (a run's
    :class:`~lsc.result.Event` list), else ``{}``: a Result's stats."""
    locked = [(e.index, e.time) for e in events if "lock" in e.kind.split("+")]
    return {"warnings": [warning(locked)]} if locked else {}


def locking_model(model):
    """``model`` with its locks (:class:`LockingModel`, built once per model), or ``model``
    itself where it has them or has no pair that may lock (:func:`lock_features`)."""
    if isinstance(model, LockingModel) or not lock_features(model):
        return model
    if getattr(model, "_locking_model", None) is None:
        model._locking_model = LockingModel(model.scene)
    return model._locking_model
