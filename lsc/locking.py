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

A contact locks (:class:`LockPart`, driven by :class:`lsc.model.HybridModel`):

- at its max deformation, where the law would separate at once (``e = 0``, or a rebound below
  the integrators' resolution) and the neighbours press the pair (``0 < F_k < F_max``): before,
  the pair closed again at the same instant, again and again;
- at a turning point on its unloading line (``dD/dt`` through zero) after it closed again at a
  closing speed of at most :data:`LOCK_SPEED` of the speed scale, where the neighbours press it
  (``0 < F_k < F_top``).
"""

from __future__ import annotations

import numpy as np

from .laws import BIG, MODE_LOADING, MODE_OPEN, MODE_UNLOADING, HysteresisLaw
from .model import HybridModel

__all__ = ["LockPart", "LockingModel", "LOCK_SPEED", "LOCK_RESTITUTION", "WATCH_RESTITUTION",
           "locking_model", "can_lock", "warning", "clusters", "cluster_forces"]

#: A contact that closes again at its permanent set at a closing speed of at most this fraction
#: of the speed scale locks at its next turning point on the line, where it is pressed.
LOCK_SPEED = 1e-3

#: A contact with a restitution below this locks at its max deformation where it is pressed: its
#: unloading line is over a million times stiffer than its loading, and a pair pressed on it
#: rings at over a thousand times the contact's frequency (the integrators' step limit).
LOCK_RESTITUTION = 1e-3

#: Only a contact with a restitution below this watches for a slow closing again
#: (:data:`LOCK_SPEED`): from 0.05 up, a chain follows the IF-D law as before, event by event.
WATCH_RESTITUTION = 0.05


class LockPart:
    """The lock of contact ``k`` (a part of the hybrid model, after the laws).

    Discrete state: ``mode`` (1 while locked), ``watch`` (1 after a slow closing onto the line:
    the ``settle`` event is armed), ``kind`` (0: locked at a max deformation, released at zero
    force by the law's own transition; 1: locked on the line, released onto it), ``ftop``
    [force] and ``dlock`` [length], and the law's state before the lock under ``law_*`` keys.

    Events (each crossing zero downward): ``unlock_zero`` (``F_k``), ``unlock_line``
    (``F_top - F_k``), ``settle`` (the closing rate ``dD/dt``); all linear in the state."""

    event_kinds = ("unlock_zero", "unlock_line", "settle")

    def __init__(self, k: int):
        self.k = k

    @staticmethod
    def init() -> dict:
        """Unlocked, not watching."""
        return {"mode": 0, "watch": 0.0, "kind": 0.0, "ftop": 0.0, "dlock": 0.0}

    @staticmethod
    def armed(st) -> tuple:
        """Which events can fire in this state."""
        on = bool(st["mode"])
        return (on, on, bool(st["watch"]) and not on)

    @staticmethod
    def event_linear(laws) -> tuple:
        """Every release condition is affine in the neighbours' IF-D forces: linear."""
        return (True, True, True)

    @staticmethod
    def events(force, closing_rate, st) -> list:
        """``[F_k, F_top - F_k, dD/dt]`` where armed (1 where not)."""
        on, watch = bool(st["mode"]), bool(st["watch"]) and not st["mode"]
        return [force if on else 1.0, st["ftop"] - force if on else 1.0,
                closing_rate if watch else 1.0]

    @staticmethod
    def locked(st, law_state: dict, ftop: float, D: float, kind: int) -> dict:
        """The lock's state when it locks with the law in ``law_state``."""
        out = {"mode": 1, "watch": 0.0, "kind": float(kind), "ftop": float(ftop),
               "dlock": float(D)}
        out.update({"law_" + key: val for key, val in law_state.items()})
        return out

    @staticmethod
    def saved(st) -> dict:
        """The law's state saved when the lock locked."""
        return {key[4:]: (int(val) if key[4:] in ("mode", "seg", "status") else val)
                for key, val in st.items() if key.startswith("law_")}


def clusters(locked, N: int) -> list[tuple[int, int]]:
    """The vehicle ranges ``(a, b)`` (inclusive) joined by the locked contacts ``locked``."""
    out = []
    for k in sorted(locked):
        if out and out[-1][1] == k:
            out[-1] = (out[-1][0], k + 1)
        else:
            out.append((k, k + 1))
    return out


def cluster_forces(F, m, groups, K: int):
    """The contact forces (K, ...) with each locked contact's force from its cluster's motion,
    and each cluster's acceleration: ``[(a, b, accel)]``. ``F``: the contact forces (K, ...)
    [force] (the locked contacts' rows are replaced); ``m`` (N,) [mass]."""
    rows = list(F)
    accels = []
    for a, b in groups:
        left = F[a - 1] if a > 0 else 0.0 * F[0]
        right = F[b] if b < K else 0.0 * F[0]
        mass = float(np.sum(m[a:b + 1]))
        rear = 0.0
        for k in range(a, b):
            rear += float(m[k])
            rows[k] = ((mass - rear) * left + rear * right) / mass
        accels.append((a, b, (left - right) / mass))
    return rows, accels


class LockingModel(HybridModel):
    """A chain's :class:`~lsc.model.HybridModel` with a lock per contact (after the laws and
    effects, in :attr:`parts` and the discrete state). NumPy only: SciPy's backend builds it
    (:func:`locking_model`); the other backends solve the plain model, which has no locks."""

    def _more_parts(self) -> list:
        """One :class:`LockPart` per contact."""
        self.locks = [LockPart(k) for k in range(self.K)]
        return self.locks

    def initial(self, p=None, xp=np):
        """The plain model's initial state, every lock open."""
        y0, disc = super().initial(p, xp)
        return y0, disc + [lock.init() for lock in self.locks]

    def forces(self, y, disc, p, xp=np):
        """Contact forces (K, ...) [force], a locked contact's from its cluster's motion
        (:func:`cluster_forces`)."""
        F = self._law_forces(y, disc, p, xp)
        locked = self.locked(disc)
        if not locked:
            return F
        rows, _ = cluster_forces(F, p["m"], clusters(locked, self.N), self.K)
        return xp.asarray(rows)

    def _law_forces(self, y, disc, p, xp=np):
        """The contact laws' forces (K, ...) [force] (0 for a locked contact)."""
        return HybridModel.forces(self, y, disc, p, xp)

    def accelerations(self, y, disc, p, xp=np):
        """As the plain model's, each vehicle of a cluster at the cluster's one acceleration
        (exactly: no rounding may open the held deformation)."""
        F, net, a = super().accelerations(y, disc, p, xp)
        locked = self.locked(disc)
        if locked:
            _, accels = cluster_forces(self._law_forces(y, disc, p, xp), p["m"],
                                       clusters(locked, self.N), self.K)
            acc = [a[i] for i in range(self.N)]
            for first, last, shared in accels:
                acc[first:last + 1] = [shared] * (last + 1 - first)
            a = xp.asarray(acc)
        return F, net, a

    def _effect_events(self, y, disc, p, xp):
        """The locks' event functions (a chain that can lock has no other effect)."""
        F, _, _ = self.accelerations(y, disc, p, xp)
        _, Dd = self.deformation(y, p, xp)
        off = self._lock_offset
        vals = []
        for lock in self.locks:
            vals.extend(lock.events(F[lock.k], Dd[lock.k], disc[off + lock.k]))
        return vals

    def apply_event(self, i: int, t, y, disc, p, xp=np):
        """The discrete state after event ``i``: its own part's transition (none for a lock's),
        then the locks lock, watch or release as it makes them (:meth:`_relock`)."""
        own = self.events[i][0] < self._lock_offset
        new = super().apply_event(i, t, y, disc, p, xp) if own else list(disc)
        return self._relock(i, y, disc, new, p)

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

    def _hold_force(self, y, disc, p, locked, k) -> float:
        """The force [force] contact ``k`` carries with the contacts ``locked`` locked."""
        F = self._law_forces(y, disc, p)
        rows, _ = cluster_forces(F, p["m"], clusters(locked, self.N), self.K)
        return float(rows[k])

    def _relock(self, i, y, before, new, p):
        """The locks after event ``i`` (its own transition already in ``new``): lock, watch or
        release (:mod:`lsc.locking`), then release every lock its force has left
        (:meth:`_settle_locks`)."""
        j, w = self.events[i]
        off = self._lock_offset
        D, Dd = self.deformation(y, p)
        if j < self.K:
            k, law = j, self.laws[j]
            was, now = before[k], new[k]
            top = law.force(D[k], 0.0, was)
            if w == 2 and was["mode"] == MODE_LOADING and now["mode"] == MODE_OPEN:
                new = self._try_lock(k, y, new, p, was, now, top, 0)
            elif w == 2 and was["mode"] == MODE_LOADING and (
                    new[off + k]["watch"] or self._restitution_below(k, p, LOCK_RESTITUTION)):
                new = self._try_lock(k, y, new, p, was, now, top, 0)
            elif (w == 1 and was["mode"] == MODE_OPEN and now["mode"] == MODE_UNLOADING
                  and Dd[k] <= LOCK_SPEED * self.v_scale
                  and self._restitution_below(k, p, WATCH_RESTITUTION)):
                new[off + k] = dict(new[off + k], watch=1.0)
            if int(new[k]["mode"]) == MODE_OPEN:
                new[off + k] = dict(new[off + k], watch=0.0)
        elif j >= off:
            k = j - off
            if w == 2:   # settle: a turning point on the line after a slow closing
                new[j] = dict(new[j], watch=0.0)
                st = new[k]
                if int(st["mode"]) == MODE_UNLOADING:
                    ftop = self.laws[k].force(D[k], 0.0, st)
                    new = self._try_lock(k, y, new, p, st, st, ftop, 1)
            else:
                new = self._release(k, w == 1, y, new, p)
        return self._settle_locks(y, new, p)

    def _restitution_below(self, k, p, bound: float) -> bool:
        """Whether contact ``k`` unloads by a restitution below ``bound``."""
        return (self.laws[k].unload_kind == "restitution"
                and float(p["contacts"][k]["e"]) < bound)

    def _try_lock(self, k, y, new, p, saved, records, ftop, kind):
        """``new`` with contact ``k`` locked where its neighbours press it inside the law's
        range (``0 < F_k < ftop``); ``saved``: the law's state to release into, ``records``:
        the state whose history (``dmax, fmax, dperm, ec, er``) the locked contact keeps."""
        force = self._hold_force(y, new, p, sorted({*self.locked(new), k}), k)
        if not 0.0 < force < float(ftop):
            return new
        D, _ = self.deformation(y, p)
        new = list(new)
        new[k] = dict(records, mode=MODE_UNLOADING, da=0.0, fa=0.0, s=0.0, lo=-BIG, wl=BIG,
                      hi=BIG, vm=0.0)
        new[self._lock_offset + k] = LockPart.locked(None, saved, float(ftop), float(D[k]),
                                                     kind)
        return new

    def _release(self, k, high: bool, y, new, p):
        """``new`` with contact ``k``'s lock released: onto the law's saved state (reloading
        along its line or curve; ``high``, or a lock on the line), or at zero force from a max
        deformation by the law's own transition (it separates there)."""
        off = self._lock_offset
        lock = new[off + k]
        law_state = LockPart.saved(lock)
        if not high and not lock["kind"]:
            # (at the held deformation: the pair's residual closing rate at the lock, a
            # rounding error, has moved it by a rounding error since)
            mu = self._mu(p, np)
            law_state = self.to_python([self.laws[k].on_event(
                2, lock["dlock"], 0.0, law_state, p["contacts"][k], np, mu=mu[k])])[0]
        new = list(new)
        new[k] = law_state
        new[off + k] = LockPart.init()
        return new

    def _settle_locks(self, y, new, p):
        """Release, one at a time, each lock whose force has left ``(0, F_top)``."""
        for _ in range(len(self.locks) + 1):
            locked = self.locked(new)
            if not locked:
                break
            rows, _ = cluster_forces(self._law_forces(y, new, p), p["m"],
                                     clusters(locked, self.N), self.K)
            out = [(k, float(rows[k]) >= new[self._lock_offset + k]["ftop"]) for k in locked
                   if not 0.0 < float(rows[k]) < new[self._lock_offset + k]["ftop"]]
            if not out:
                break
            new = self._release(*out[0], y, new, p)
        return new


def warning(contacts) -> str:
    """The Result's warning where ``contacts`` (their indices) locked: the motion then left the
    plain IF-D law, which the other backends solve (they have no locks), and may differ from it."""
    which = ", ".join(str(k) for k in contacts)
    return (f"contact(s) {which} locked (pressed shut, the pair moved as one body; see 'Locked "
            f"pairs' in the physics docs): the plain IF-D law, which method 'exact-chain' and "
            f"'diffrax' solve, chatters here and may end differently")


def can_lock(model) -> bool:
    """Whether ``model``'s contacts can lock: a chain (three vehicles or more) of IF-D contacts
    with no brake and no failure effect (whose forces the locked force would need)."""
    return (model.N >= 3 and not model.brakes and not model.failures
            and all(isinstance(law, HysteresisLaw) for law in model.laws))


def locking_model(model):
    """``model`` with its locks (:class:`LockingModel`, built once per model), or ``model``
    itself where it has them or cannot lock."""
    if isinstance(model, LockingModel) or not can_lock(model):
        return model
    if getattr(model, "_locking_model", None) is None:
        model._locking_model = LockingModel(model.scene)
    return model._locking_model
