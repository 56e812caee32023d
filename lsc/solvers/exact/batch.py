"""The exact backend's batch: one vectorised NumPy stepper over many two-vehicle scenes
(:func:`solve_arrays`), and the backend contract's ``solve_batch`` on top of it.

Every member advances its own segment each iteration (:mod:`.kernels` on arrays); the transitions
between segments are the law's own ``on_event`` on NumPy arrays of many members at once
(:class:`_Rows` gives per-member table lookups). No braking and no post-failure curve (the
declaration's ``batch`` says so): such scenes are solved one by one.
"""

from __future__ import annotations

import numpy as np

from ...contact import BIG, MODE_OPEN, STATUS, HysteresisLaw
from ...curves import Curve
from ...errors import SceneError
from ...result import METRICS
from ...scene import Hysteresis, Restitution, UnloadingStiffness, UnloadingTable
from ... import metrics as _metrics
from ... import parameters
from .arrays import _batch_inputs, arrays_of_model
from .kernels import _end_force, _next_event, _setup, _state
from ..base import solve_alone
from .single import solve as solve_one

#: Status codes of :func:`solve_arrays`: the law's :data:`~lsc.contact.STATUS` and two of its own.
BATCH_STATUS = {
    **STATUS,
    10: "event limit reached before the crash was over (raise max_events)",
    11: ("no further event although the crash is not over (the contact never separates), "
         "or the solution became non-finite"),
}
EVENT_LIMIT, NO_EVENT = 10, 11


class _Rows:
    """A per-member table standing in for one of the law's 1-D parameter arrays.

    Held column-major, ``c[j, i]`` = entry ``j`` of input member ``i`` (shape ``(n, B)``, never
    copied), with ``ix`` the input member of each member in the batch's current order (the
    stepper reorders its members every iteration: only ``ix`` follows, not the table).
    ``rows[j]`` with an integer gives entry ``j`` of every member; with an index array each
    member's own entry; a slice keeps a table. ``np.searchsorted(rows, v)`` (NumPy forwards it
    to :meth:`searchsorted`) searches each member's own row for its own ``v``. This lets the
    law's transition code, written for one scene's 1-D tables, run unchanged on a batch.
    """

    __slots__ = ("c", "ix")

    def __init__(self, c, ix=None):
        self.c, self.ix = c, np.arange(c.shape[1]) if ix is None else ix

    def __getitem__(self, idx):
        if isinstance(idx, slice):
            return _Rows(np.ascontiguousarray(self.c[idx]), self.ix)
        idx = np.asarray(idx)
        if idx.ndim == 0:
            return self.c[int(idx)].take(self.ix)
        flat = idx.astype(np.intp) * self.c.shape[1] + self.ix
        return self.c.reshape(-1).take(flat)

    def searchsorted(self, v, side="left", sorter=None):
        cmp = np.less_equal if side == "right" else np.less
        count = np.zeros(self.ix.size, dtype=np.intp)
        for row in self.c:
            count += cmp(row.take(self.ix), v)
        return count

    def members(self, s0, s1):
        """The same table for members ``s0:s1`` of this one."""
        return _Rows(self.c, self.ix[s0:s1])

    def take(self, keep):
        """The same table for members ``keep`` (indices) of this one, in that order."""
        return _Rows(self.c, self.ix.take(keep))


class _NumpyRuns:
    """``numpy`` for the batch: ``masked`` evaluates a function only where a mask holds (each
    segment kind its own functions), and ``where`` hands back a branch as it is when its condition
    is the same for every member, instead of copying element by element: most of the law's branch
    selections, on a run of members in one mode and after one event. Same results as ``numpy``.
    """

    def __getattr__(self, name):
        return getattr(np, name)

    @staticmethod
    def masked(name, mask, *args):
        """``np.<name>(*args)`` evaluated only where ``mask`` (0 elsewhere)."""
        out = np.zeros(np.broadcast_shapes(np.shape(mask), *(np.shape(a) for a in args)))
        getattr(np, name)(*args, out=out, where=mask)
        return out

    @staticmethod
    def where(cond, a, b):
        if isinstance(cond, np.ndarray) and cond.size > 64:
            # (a condition of more axes, as the first-impact record's: only a branch of the
            # result's full shape is handed back as it is)
            shape = np.shape(a)
            full = cond.ndim == 1 or (shape == np.shape(b)
                                      and np.broadcast_shapes(cond.shape, shape) == shape)
            if full and cond.all():
                return a
            if full and not cond.any():
                return b
        return np.where(cond, a, b)


_NPR = _NumpyRuns()


def _cols(a) -> _Rows:
    """A :class:`_Rows` from a ``(B, n)`` array."""
    return _Rows(np.ascontiguousarray(np.asarray(a, float).T))


def _batch_law(P: dict):
    """One :class:`HysteresisLaw` (its code and its shape constants: table lengths, unloading
    kind) and the batched parameter dict ``p`` for it, built for every member with the same
    arithmetic as ``HysteresisLaw.__init__`` for one scene (the tests compare them), tables as
    :class:`_Rows`. Returns ``(law, p, per_member)``, the keys of ``p`` that vary by member."""
    d, f, end = P["load_d"], P["load_f"], P["end"]
    B, n = d.shape
    dT, fT = np.ascontiguousarray(d.T), np.ascontiguousarray(f.T)   # (n, B): entry, member
    ld, lf, ls, le = (np.empty((n + 1, B)) for _ in range(4))
    ld[:n], ld[n] = dT, BIG
    lf[:n], lf[n] = fT, fT[n - 1]
    dd = dT[1:] - dT[:-1]
    with np.errstate(all="ignore"):
        ls[:n - 1] = (fT[1:] - fT[:-1]) / dd
    ls[n - 1] = 0.0 if end is None else end
    ls[n] = 0.0
    le[0] = 0.0
    np.cumsum(0.5 * (fT[1:] + fT[:-1]) * dd, axis=0, out=le[1:n])
    le[n] = le[n - 1]
    p = {"ld": _Rows(ld), "lf": _Rows(lf), "ls": _Rows(ls), "le": _Rows(le), "wres": 0.0}
    curve = Curve(d[0], f[0], None if end is None else end[0])
    if "e" in P:
        rule = Restitution(float(P["e"][0]))
    elif "su" in P:
        rule = UnloadingStiffness(float(P["su"][0]))
    else:
        rule = UnloadingTable(P["unload_d"][0], P["unload_f"][0])
    law = HysteresisLaw(Hysteresis(curve, rule))
    if "e" in P:
        p.update(e=P["e"], ud=law.params["ud"], uf=law.params["uf"], ue=law.params["ue"])
    elif "su" in P:
        p.update(su=P["su"], ud=law.params["ud"], uf=law.params["uf"], ue=law.params["ue"])
    else:
        ud, uf = P["unload_d"][:, ::-1], P["unload_f"][:, ::-1]
        ud = ud - ud[:, -1:]
        p.update(ud=_cols(ud), uf=_cols(uf),
                 ue=np.sum(0.5 * (uf[:, 1:] + uf[:, :-1]) * np.diff(ud, axis=1), axis=1))
    per_member = [k for k, v in p.items() if isinstance(v, _Rows)]
    per_member += [k for k in ("e", "su") if k in p]
    if "unload_d" in P:
        per_member.append("ue")
    return law, p, per_member


def solve_arrays(params: dict, *, max_events: int = 10_000) -> dict:
    """Exact metrics of many two-vehicle hysteresis scenes at once (vectorised over scenes).

    Parameters (arrays over ``B`` scenes, scene units; scalars broadcast)
    ----------------------------------------------------------------------
    m1, m2 : (B,) masses [mass]; v1, v2 : (B,) initial speeds [velocity]; gap : (B,) [length]
    stiffness : (B,) linear loading [force/length], or load_d, load_f : (B, n) loading tables
        (``D = 0`` first, equal length ``n``) with optional load_end_slope : (B,) (all extend or
        none) [force/length]
    e : (B,) restitution, or unload_stiffness : (B,) [force/length], or unload_d, unload_f :
        (B, nu) measured rebound curves in time order (mapped onto ``(D_max, F_max)``)
    g : optional (B,) gravity [acceleration], for ``peak_acceleration_g``
    failure_force : optional (B,) bumper failure force [force] (inf or nan: none), for
        ``failure_time``

    No braking: the batch has no friction forces (:func:`batch_params` rejects braked scenes,
    and brake parameters here are an error); solve braked scenes one by one with :func:`solve`.

    Every member advances its own segment each iteration (finished members leave the batch);
    the transitions are the law's ``on_event`` on arrays (:class:`_Rows` gives per-member table
    lookups). Returns a dict of the Result metrics: ``delta_v, v_final, peak_acceleration``
    (B, 2) [velocity, acceleration], ``duration, peak_force, max_deformation,
    permanent_deformation, restitution`` (velocity definition), ``restitution_energy,
    energy_absorbed, energy_returned, contact_time, separation_time, failure_time`` (B,; the
    failure time is NaN where the force never exceeds the failure force), ``events`` (B,) and
    ``status`` (B,): 0 ok, else a code of :data:`BATCH_STATUS` (the metrics are then ``nan``).
    """
    P = _batch_inputs(params)
    law, p, per_member = _batch_law(P)
    B = P["B"]
    out = {k: np.full(B, np.nan) for k in ("v1", "v2", "t", "dmax", "fmax", "dperm", "ec", "er",
                                            "ts", "tf")}
    out_status = np.zeros(B, dtype=int)
    out_events = np.zeros(B, dtype=int)
    v1, v2 = P["v1"], P["v2"]
    # the working set: one entry per member still in the batch (ix: its index in the input)
    w = {"ix": np.arange(B), "m1": P["m1"], "m2": P["m2"], "gap": P["gap"],
         "x1": np.zeros(B), "x2": np.zeros(B), "v1": v1.copy(), "v2": v2.copy(), "t": np.zeros(B),
         "ts": np.full(B, np.nan), "tf": np.full(B, np.nan),
         "ff": np.full(B, np.inf) if P["failure_force"] is None else P["failure_force"],
         "vscale": np.maximum(np.maximum(np.abs(v1), np.abs(v2)),
                              np.maximum(np.abs(v1 - v2), 1e-300))}
    with np.errstate(all="ignore"):
        st = law.init(w["x1"] - w["x2"] - w["gap"], v1 - v2, p, np)
        st = {k: np.array(np.broadcast_to(v, (B,))) for k, v in st.items()}
        touching = st["mode"] != MODE_OPEN
        w["nev"] = touching.astype(int)
        w["status"] = st["status"].astype(int)
        # each member's first-impact record (lsc.metrics), carried through the stepper
        F0 = np.where(touching, law.force(w["x1"] - w["x2"] - w["gap"], 0.0, st), 0.0)
        first = _metrics.first_impacts_init(touching[:, None], _pair(v1, v2), F0[:, None],
                                            _accelerations(F0, w), np)
        out_first = {k: np.full(v.shape, np.nan) for k, v in first.items()}
        _fail_on_entry(law, w["x1"] - w["x2"] - w["gap"], st, w)
        while True:
            # members whose crash is over (or cannot go on) leave the batch with their record
            over = (st["mode"] == MODE_OPEN) & (w["v1"] - w["v2"] <= 1e-12 * w["vscale"])
            code = np.where(w["status"] != 0, w["status"],
                            np.where(over, 0, np.where(w["nev"] >= max_events, EVENT_LIMIT, -1)))
            fin = code >= 0
            if fin.any():
                j = w["ix"][fin]
                for key in ("v1", "v2", "t", "ts", "tf"):
                    out[key][j] = w[key][fin]
                for key, v in first.items():
                    out_first[key][j] = v[fin]
                for key in ("dmax", "fmax", "dperm", "ec", "er"):
                    out[key][j] = st[key][fin]
                out_status[j] = code[fin]
                out_events[j] = w["nev"][fin]
                if fin.all():
                    break
            # one segment for every member: the earliest armed event and the state there
            n_live = w["ix"].size
            g = _setup(w["x1"], w["x2"], w["v1"], w["v2"], w["m1"], w["m2"], w["gap"],
                       st["fa"], st["s"], st["da"])
            fail = None
            if P["failure_force"] is not None:  # armed until it has fired (then inf)
                fail = (st["fa"], st["s"], st["da"], w["ff"])
            tau, which, sep = _next_event(_NPR, g, st["da"], st["lo"], st["wl"], st["hi"],
                                          st["vm"], 1e-12 * w["vscale"], fail)
            tau, which = np.broadcast_to(tau, (n_live,)), np.broadcast_to(which, (n_live,))
            bad = ~np.isfinite(tau)
            tau = np.where(bad, 0.0, tau)
            w["x1"], w["x2"], w["v1"], w["v2"] = _state(_NPR, tau, g,
                                                        np.broadcast_to(sep, (n_live,)))
            w["t"] = w["t"] + tau
            bad |= ~np.isfinite(w["x1"] + w["x2"] + w["v1"] + w["v2"])
            D, W = w["x1"] - w["x2"] - w["gap"], w["v1"] - w["v2"]
            F = np.maximum(g.F0, _end_force(np, law, D, st))
            first = _metrics.fold_peaks(first, F[:, None], _accelerations(F, w),
                                        _metrics.ongoing(first, np), _NPR)
            # keep the members still running, grouped by (mode, event): the law's branch
            # selections (where) then see long runs of equal conditions, several times faster
            live = np.flatnonzero(~fin)
            key = (st["mode"] * 4 + which)[live].astype(np.int8)
            order = np.argsort(key, kind="stable")
            perm, key = live[order], key[order]
            w = {k: np.take(v, perm) for k, v in w.items()}
            st = {k: np.take(v, perm) for k, v in st.items()}
            first = {k: np.take(v, perm, axis=0) for k, v in first.items()}
            p = {k: ((v.take(perm) if isinstance(v, _Rows) else np.take(v, perm))
                     if k in per_member else v) for k, v in p.items()}
            which, bad, D, W = (np.take(a, perm) for a in (which, bad, D, W))
            # the law's transition, on each run of members with the same (mode, event)
            b = perm.size
            cuts = [0, *(np.flatnonzero(np.diff(key)) + 1), b]
            parts = []
            for s0, s1 in zip(cuts[:-1], cuts[1:]):
                pg = {k: (v.members(s0, s1) if isinstance(v, _Rows) else v[s0:s1])
                      if k in per_member else v for k, v in p.items()}
                sg = {k: v[s0:s1] for k, v in st.items()}
                ng = law.on_event(which[s0:s1], D[s0:s1], W[s0:s1], sg, pg, _NPR)
                parts.append({k: np.broadcast_to(v, (s1 - s0,)) for k, v in ng.items()})
            new = {k: np.concatenate([pt[k] for pt in parts]) for k in st}
            for k in ("mode", "seg", "status"):
                new[k] = new[k].astype(int, copy=False)
            keep = bad | (which == 3)  # (a bumper failure changes no contact state)
            if keep.any():
                new = {k: np.where(keep, st[k], v) for k, v in new.items()}
                failed = (which == 3) & ~bad
                w["tf"] = np.where(failed, w["t"], w["tf"])
                w["ff"] = np.where(failed, np.inf, w["ff"])
            opened = (new["mode"] == MODE_OPEN) & (st["mode"] != MODE_OPEN)
            closed = (new["mode"] != MODE_OPEN) & (st["mode"] == MODE_OPEN)
            first = _metrics.event_update(first, w["t"], _pair(w["v1"], w["v2"]),
                                          closed[:, None], opened[:, None], _NPR)
            w["ts"] = np.where(opened, w["t"], w["ts"])
            w["nev"] = w["nev"] + ~bad
            w["status"] = np.where(bad, NO_EVENT, new["status"]).astype(int)
            st = new
            _fail_on_entry(law, D, st, w)
    return _batch_metrics(P, out, out_first, out_status, out_events)


def _pair(v1, v2):
    """(b, 2): the two vehicles' values side by side."""
    return np.stack([v1, v2], axis=-1)


def _accelerations(F, w):
    """(b, 2): the vehicles' accelerations [acceleration] under contact force ``F`` (b,)."""
    return _pair(-F / w["m1"], F / w["m2"])


def _fail_on_entry(law, D, st, w) -> None:
    """Bumper failure at a force *step*: where a segment starts above the failure force (a
    preloaded table's force at first touch, or at t = 0), the bumper failed at that instant,
    as a single solve reports it; the crossing event (:func:`_force_rises`) sees only a force
    that rises through the level inside a segment. Updates ``w["tf"]``, ``w["ff"]``."""
    failed = (law.force(D, 0.0, st) > w["ff"]) & np.isnan(w["tf"]) & (st["mode"] != MODE_OPEN)
    if failed.any():
        w["tf"] = np.where(failed, w["t"], w["tf"])
        w["ff"] = np.where(failed, np.inf, w["ff"])


def _batch_metrics(P, out, first, status, events) -> dict:
    """The Result metrics (:func:`lsc.metrics.metrics`) from each member's first-impact record,
    hysteresis record, final time and velocities; NaN where a member did not complete."""
    ok = status == 0
    v_last = _pair(out["v1"], out["v2"])
    records = {k: out[k][:, None] for k in ("dmax", "dperm", "ec", "er")}
    g = np.ones(P["B"]) if P["g"] is None else P["g"]
    with np.errstate(all="ignore"):
        res = _metrics.metrics(first, records, v_last, g, out["tf"][:, None], out["t"], v_last,
                               np, separation_time=out["ts"][:, None])
    if P["g"] is None:
        del res["peak_acceleration_g"]
    res = {k: np.where(ok.reshape((-1,) + (1,) * (np.ndim(v) - 1)), v, np.nan)
           for k, v in res.items()}
    res = {k: v[:, 0] if np.ndim(v) == 2 and k not in _PER_VEHICLE else v
           for k, v in res.items()}
    res["events"] = events
    res["status"] = status
    return res


#: The metrics with one value per vehicle ((B, 2) from :func:`solve_arrays`; the others (B,)).
_PER_VEHICLE = ("delta_v", "v_final", "peak_acceleration", "peak_acceleration_g")


# ============================================================================ the contract
def solve_batch(model, values: dict, *, progress=None, max_events: int = 10_000) -> dict:
    """Exact metrics of every member of ``values`` (dotted scene path → (n,) array in scene
    units, every member valid) of ``model``'s scene, at once.

    Returns ``{"metrics": {name: array (n, ...) for every name of lsc.result.METRICS},
    "status": (n,) object array}``: ``"ok"``, or ``"SimulationError: <message>"`` where a
    member cannot be completed. Members the vectorised stepper does not complete are solved
    alone (:func:`.single.solve` on the member's scene), so that their status is the single
    solve's own message, word for word. ``progress(k)``: called as ``k`` members finish.
    ``max_events``: most discrete events in one member's solve.
    """
    p = parameters.batch_params(model, values)
    if p is None:
        path = next(q for q in values if parameters.batch_params(model, {q: values[q][:1]}) is None)
        raise SceneError(path, "the exact batch sets only paths that map onto the model's "
                               "numbers (speeds, masses, weights, gaps, stiffnesses, restitution, "
                               "loading scale); solve the members one by one (lsc.sweep does)")
    n = p["m"].shape[0]
    status = np.full(n, "ok", dtype=object)
    out = solve_arrays(arrays_of_model(model, p), max_events=max_events) if n else {}
    metrics = {name: _member_axis(out[name] if n else None, n, per, model)
               for name, (_, per) in METRICS.items()}
    good = out["status"] == 0 if n else np.zeros(0, bool)
    if progress is not None and good.any():
        progress(int(good.sum()))
    solve_alone(solve_one, model, values, np.flatnonzero(~good), metrics, status,
                progress=progress, max_events=max_events)
    return {"metrics": metrics, "status": status}


def _member_axis(arr, n: int, per: str, model) -> np.ndarray:
    """A metric of :func:`solve_arrays` with its METRICS shape: (n,), (n, N) or (n, K) (no
    members: ``arr`` is None)."""
    shape = {"scene": (n,), "vehicle": (n, model.N), "contact": (n, model.K)}[per]
    return np.full(shape, np.nan) if arr is None else np.asarray(arr, float).reshape(shape)
