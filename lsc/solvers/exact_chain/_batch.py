"""The exact-chain backend's batch: many chains of one shape advanced together, one NumPy
evaluation per event over every unfinished member.

Each iteration every live member solves its own segment in closed form
(:class:`~._batch_modes.BatchMotion`), finds its earliest event with the guarantee of
:mod:`._roots` (:func:`~._batch_roots.earliest`, the restart rule of :func:`._solve._start`
included: :func:`~._batch_roots.start_times`), folds the peaks between the events into its
first-impact record (:func:`~._batch_peaks.extreme_values`, :mod:`lsc.metrics`) and takes the law's
own transition (``HysteresisLaw.on_event`` on the arrays of the members whose event is on that
contact, in that mode and on that piece). The metrics are :func:`lsc.metrics.metrics` of that record, as a single solve's
Result computes them. A member that reaches :data:`HANDOFF_EVENTS` events is taken on from its
state by the single solve's own segments (:meth:`_Batch._resume`). A member the vectorised
search cannot decide (a tangency, a segment longer than its windows, a law status, a
non-finite state), or that its continuation cannot finish plainly, is solved alone
(:func:`._solve.solve`), so that its numbers and its failure message are the single solve's
own; none is dropped.

Straight loading lines and straight unloading lines only (``BACKEND.batch``): every slope is
>= 0, and a contact never leaves its first loading piece.
"""

from __future__ import annotations

import numpy as np

from ... import metrics as _metrics
from ... import parameters
from ...contact import MODE_OPEN
from ...errors import SceneError, SimulationError
from ...locking import lock_members
from ...impacts import TIME_RESOLUTION
from ...model import OVER_TOL
from ...result import METRICS
from ..base import solve_alone
from ..exact.batch import _Rows
from ._batch_modes import BatchMotion, ModesCache, Sums, mall, many, mmax
from ._batch_peaks import bars, extreme_values
from ._batch_roots import earliest, start_times
from ._modes import deformation_map
from ._locks import LockTransitions
from ._balance import balanced
from ._carry import Carried
from ._lines import rate_omega
from ._solve import START_TOL, _Chain, _transitions, solve as solve_one

__all__ = ["solve_batch", "HANDOFF_EVENTS"]

#: A member still running after this many events (contacts that chatter) is taken on from its
#: state by the single solve's segments (:meth:`_Batch._resume`), which go on to its end or to
#: ``max_events`` (there the single solve, solved again alone, gives its message). (Measured
#: on random 3-car chains: a batch event with ~10 members left costs what ~10 single-solve
#: events do, so neither a lower budget nor a higher one pays; 20,000 members: 36 taken on,
#: 226 to 940 events each, 1.8 s of CPU against 4.7 s solved again from t = 0. A hand-off
#: that waits until few members are left running would pay some 5 % on 50,000, but would make
#: a member's numbers depend on the members beside it, hence on a sweep's chunks: the rule is
#: the member's own event count.)
HANDOFF_EVENTS = 200
#: A member taken on still running after this many events is solved alone from t = 0 all the
#: same (a chain that chatters to ``max_events``: the single solve's own message, whose
#: 10,000 events would otherwise be made twice; random 3-car chains finish in 226 to 1,972).
RESUME_EVENTS = 2_000
_EPS = float(np.finfo(float).eps)
#: Member status codes of :class:`_Batch`.
RUNNING, DONE, ALONE = -1, 0, 1


def solve_batch(model, values: dict, *, progress=None, max_events: int = 10_000) -> dict:
    """Exact metrics of every member of ``values`` (dotted scene path → (n,) array in scene
    units) of ``model``'s chain, at once (the backend contract's ``solve_batch``).

    Returns ``{"metrics": {name: (n, ...) for every name of lsc.result.METRICS}, "status":
    (n,) object array}``: ``"ok"``, or ``"SimulationError: <the single solve's message>"``.
    ``progress(k)``: advanced as ``k`` members finish. ``max_events``: as the single solve's.
    """
    p = parameters.batch_params(model, values)
    if p is None:
        path = next(q for q in values if parameters.batch_params(model, {q: values[q][:1]}) is None)
        raise SceneError(path, "the exact-chain batch sets only paths that map onto the model's "
                               "numbers (speeds, masses, weights, gaps, stiffnesses, restitution, "
                               "loading scale); solve the members one by one (lsc.sweep does)")
    n = p["m"].shape[0]
    run = _Batch(model, p, min(max_events, HANDOFF_EVENTS))
    run.values, run.max_total = values, max_events
    metrics, code = run.solve() if n else ({}, np.zeros(0, int))
    code[lock_members(model, p)] = ALONE   # (pairs that may lock: the single solve locks them)
    shapes = {"scene": (n,), "vehicle": (n, model.N), "contact": (n, model.K)}
    metrics = {name: np.array(metrics[name], float).reshape(shapes[per]) if n
               else np.full(shapes[per], np.nan) for name, (_, per) in METRICS.items()}
    status = np.full(n, "ok", dtype=object)
    if progress is not None and np.any(code == DONE):
        progress(int(np.sum(code == DONE)))
    solve_alone(solve_one, model, values, np.flatnonzero(code != DONE), metrics, status,
                progress=progress, max_events=max_events)
    return {"metrics": metrics, "status": status}


def _contact_params(c: dict) -> dict:
    """One contact's batched law numbers (leading axis n) for the law's array code: tables as
    :class:`~lsc.solvers.exact.batch._Rows` (a member's own entry for a member's index)."""
    return {k: (_Rows(np.ascontiguousarray(np.asarray(v, float).T)) if np.ndim(v) == 2 else
                np.asarray(v, float)) for k, v in c.items()}


def _subset(p: dict, rows) -> dict:
    return {k: (v.take(rows) if isinstance(v, _Rows) else v[rows]) for k, v in p.items()}


#: The metrics that may be NaN (not applicable) in a Result (``lsc.result._NOT_APPLICABLE``).
_MAY_BE_NAN = ("restitution", "restitution_energy", "failure_time")


def _resolved(t0, t1):
    """Whether the clock resolves ``[t0, t1]`` to :data:`lsc.impacts.TIME_RESOLUTION`
    (:func:`lsc.impacts.check_resolved`, on arrays; NaN ``t0``: nothing to check)."""
    with np.errstate(invalid="ignore"):
        span = t1 - t0
        ulp = np.spacing(np.maximum(np.abs(t0), np.abs(t1)))
        return np.isnan(t0) | (span * TIME_RESOLUTION >= ulp)


class _Batch:
    """Every member's state, advanced event by event (see the module docstring)."""

    def __init__(self, model, p: dict, max_events: int):
        self.model, self.max_events = model, max_events
        self.N, self.K = model.N, model.K
        self.C = deformation_map(self.N)
        self.laws = model.laws
        n = p["m"].shape[0]
        self.n = n
        self.m, self.gap = np.asarray(p["m"], float), np.asarray(p["gap"], float)
        self.v0 = np.asarray(p["v0"], float)
        self.cp = [_contact_params(c) for c in p["contacts"]]
        self.v_scale = model.speed_scale(p)
        self.t_scale = model.time_scale(p=p)
        self.horizon = model.horizon(p=p)
        self.g = float(model.scene.g)
        self.modes = ModesCache(n, self.N, self.K)

    # ------------------------------------------------------------------ the run
    def solve(self):
        """``(metrics of lsc.metrics.metrics, code (n,))``: code :data:`DONE` or :data:`ALONE`."""
        n, N, K = self.n, self.N, self.K
        x, v = np.zeros((n, N)), self.v0.copy()
        D, W = x @ self.C.T - self.gap, v @ self.C.T
        with np.errstate(all="ignore"):
            st = [self._full(law.init(D[:, k], W[:, k], self.cp[k], np), n)
                  for k, law in enumerate(self.laws)]
        touching = np.stack([s["mode"] != MODE_OPEN for s in st], axis=1)
        F0 = np.where(touching, np.stack([law.force(D[:, k], 0.0, s) for k, (law, s) in
                                          enumerate(zip(self.laws, st))], axis=1), 0.0)
        first = _metrics.first_impacts_init(touching, v, F0, (F0 @ -self.C) / self.m, np)
        # the working set (ix: each member's index in the batch)
        # (D: the deformations, carried from segment to segment, not re-derived from x:
        # ._solve._Chain)
        w = {"ix": np.arange(n), "x": x, "v": v, "D": D, "t": np.zeros(n),
             "nev": touching.sum(axis=1),
             "v_post": np.full((n, N), np.nan), "since": np.where(touching, 0.0, np.nan)}
        code = np.full(n, RUNNING)
        out = {"t": np.zeros(n), "v": np.zeros((n, N)), "v_post": np.zeros((n, N)),
               **{key: np.zeros((n, K)) for key in ("dmax", "dperm", "ec", "er")}}
        out_first = {k: np.zeros((n,) + np.shape(a)[1:]) for k, a in first.items()}
        status0 = np.any(np.stack([s["status"] for s in st], axis=1) != 0, axis=1)
        code[status0] = ALONE
        keep = ~status0
        while True:
            # (the members over or at the hand-off dropped with those the last round left to
            # the single solve: each working array taken once a round)
            with np.errstate(invalid="ignore"):
                over = keep & self._over(w, st)
            if over.any():
                j = w["ix"][over]
                code[j] = DONE
                out["t"][j], out["v"][j] = w["t"][over], w["v"][over]
                out["v_post"][j] = np.where(np.isnan(w["v_post"][over]), w["v"][over],
                                            w["v_post"][over])
                for key in ("dmax", "dperm", "ec", "er"):
                    out[key][j] = np.stack([s[key][over] for s in st], axis=1)
                for key, a in first.items():
                    out_first[key][j] = a[over]
            keep &= ~over
            limit = keep & (w["nev"] >= self.max_events)
            for i in np.flatnonzero(limit) if self.max_events < self.max_total else ():
                self._resume(i, w, st, first, code, out, out_first)
            code[w["ix"][limit & (code[w["ix"]] != DONE)]] = ALONE
            keep &= ~limit
            if not keep.all():
                w, st, first = (self._take(w, keep), [self._take(s, keep) for s in st],
                                self._take(first, keep))
            if not w["ix"].size:
                break
            w, st, first, keep, fresh = self._step(w, st, first)
            # (a segment the search cannot decide: taken on from its start, as at the hand-off)
            w["nev"][fresh] -= 1
            for i in np.flatnonzero(fresh):
                self._resume(i, w, st, first, code, out, out_first)
            code[w["ix"][~keep & (code[w["ix"]] != DONE)]] = ALONE
        metrics = self._metrics(out, out_first, code)
        code[(code == DONE) & ~self._result_checks(metrics, out, out_first)] = ALONE
        return metrics, code

    def _resume(self, i, w, st, first, code, out, out_first) -> None:
        """Member ``i`` of the working set, at the hand-off's event count, taken on from its
        state by the single solve's own segments (:meth:`._solve._Chain.advance`, the peaks of
        :meth:`~._solve._Chain.spans`, the model's transitions) instead of solved again from
        t = 0 (a chain whose contacts chatter: hundreds of events), its record kept as
        :meth:`_step` keeps it; :data:`DONE` in ``code``, its numbers in ``out`` and
        ``out_first``. Left alone where anything is not plain (locks, a law status, no event,
        a non-finite state, an unresolved impact, :data:`RESUME_EVENTS`, a warning): the single
        solve's own numbers, warnings or message."""
        j, N, K = int(w["ix"][i]), self.N, self.K
        member = self.model.scene.with_values({q: float(a[j]) for q, a in self.values.items()})
        model = type(self.model)(member)
        parts = _transitions(model)
        if isinstance(parts, LockTransitions):
            return
        chain = _Chain(model)
        chain.parts = parts
        disc = model.to_python([{key: a[i] for key, a in s.items()} for s in st])
        t, y, nev = float(w["t"][i]), np.concatenate([w["x"][i], w["v"][i]]), int(w["nev"][i])
        chain.carried, parts = (y, w["D"][i].tolist()), Carried(parts, chain)
        horizon, events, touch = model.crash_horizon, [], []
        try:
            while not parts.is_over(y, disc, t, horizon):
                go_on = nev < min(self.max_total, RESUME_EVENTS)
                step = chain.advance(t, y, disc, horizon) if go_on else None
                if step is None or step.event is None or not np.isfinite(step.y).all():
                    return
                t, y = step.t, np.asarray(step.y, float)
                new = [a if a is was else model.to_python([a])[0] for a, was in
                       zip(parts.apply_event(step.event, t, y, disc, model.params), disc)]
                events.append((t, y[N:2 * N]))
                touch.append([[s["mode"] != MODE_OPEN for s in d[:K]] for d in (disc, new)])
                disc, nev = new, nev + 1
                if any(int(s["status"]) for s in disc[:K]):
                    return
        except SimulationError:
            return
        if chain.warnings():   # (a narrow line's unknown place: the single solve says so)
            return
        rec = {key: a[i:i + 1] for key, a in first.items()}
        since, v_post = w["since"][i], w["v_post"][i]
        # (each event's contacts that close and open, (E, K) at once; what leaves the record
        # as it is skipped: no first impact ongoing, no contact opening or closing)
        was, now = np.moveaxis(np.array(touch, bool).reshape(-1, 2, K), 1, 0)
        closing, opening = now & ~was, was & ~now
        for (t1, v1), closes, opens, shut, part, (_, _, F, a) in zip(
                events, closing, opening, closing.any(axis=1).tolist(),
                opening.any(axis=1).tolist(), chain.spans()):
            ongoing = _metrics.ongoing(rec, np)
            if ongoing.any():
                rec = _metrics.fold_peaks(rec, F[None], a[None], ongoing, np)
            rec = _metrics.event_update(rec, np.array([t1]), v1[None], closes[None],
                                        opens[None], np)
            if part:
                if np.any(opens & ~_resolved(since, t1)):
                    return
                v_post = v1
            if part or shut:
                since = np.where(closes, t1, np.where(opens, np.nan, since))
        code[j] = DONE
        out["t"][j], out["v"][j] = t, y[N:2 * N]
        out["v_post"][j] = np.where(np.isnan(v_post), y[N:2 * N], v_post)
        for key in ("dmax", "dperm", "ec", "er"):
            out[key][j] = [s[key] for s in disc[:K]]
        for key, a in rec.items():
            out_first[key][j] = a[0]

    def _step(self, w, st, first):
        """One segment and one event of every live member: ``(w, st, first, keep, fresh)``,
        ``keep`` False where a member goes to the single solve, ``fresh`` where it is left at
        its segment's start (its search undecided, its event count one too many)."""
        b, N, K = w["ix"].size, self.N, self.K
        ix = w["ix"]
        x0, v0 = w["x"], w["v"]
        D0, W0 = w["D"], v0 @ self.C.T
        # (each contact's numbers the segment reads, stacked (b, K) once)
        S = {key: np.stack([s[key] for s in st], axis=1)
             for key in ("s", "fa", "da", "wl", "lo", "hi", "vm", "mode")}
        slope = S["s"]
        force = S["fa"] + slope * (D0 - S["da"])
        known = self.modes.get(ix, slope)
        motion = BatchMotion(self.m[ix], x0, v0, slope, force, self.C, known)
        self.modes.put(ix, slope, motion, ~known[2])
        omega = np.maximum(motion.fastest, 1.0 / self.t_scale[ix])
        g, armed, tol = self._event_functions(motion, S, D0, W0, x0, v0, ix, omega)
        limit = self.horizon[ix] - w["t"]
        with np.errstate(all="ignore"):
            start = start_times(g, tol, omega, limit)
            start = np.where(armed, start, np.nan)
            late_now = armed & (start > 0)
            if late_now.any():     # (each such function at its own start)
                q, j = np.nonzero(late_now)
                late_now[q, j] = g.take(q, j).each_at(start[q, j][:, None])[:, 0] <= 0
            tau, which, undecided = earliest(g, armed, start, limit)
        keep = ~undecided & (which >= 0) & ~many(late_now)
        fresh = ~keep    # (left where their segment starts, untouched)
        tau = np.where(keep, tau, 0.0)
        x1, v1 = motion.state(tau)
        D = motion.deformations(tau, D0, W0)
        keep &= mall(np.isfinite(x1) & np.isfinite(v1))
        # the peaks of the segment, for the contacts whose first impact is ongoing
        ongoing = _metrics.ongoing(first, np)
        look = keep & many(ongoing)
        if look.any():
            r = np.flatnonzero(look)
            # (a contact loading all along: its closing rate >= 0 up to its own zero, which
            # ends the segment; not where that rate stays on its surface, start NaN)
            rate_start = start[:, 2::3][r]
            vm = S["vm"][r]
            monotone = (vm != 0) & armed[:, 2::3][r] & ~np.isnan(rate_start)
            peaks, unsure = self._peaks(motion, slope, force, ix, r, tau[r], monotone,
                                        vm == 0, S["fa"][r], bars(first, ongoing, r))
            keep[r[unsure]] = False
            F_pk = np.zeros((b, K))
            a_pk = np.zeros((b, N))
            F_pk[r], a_pk[r] = peaks[:, :K], peaks[:, K:]
            first = _metrics.fold_peaks(first, F_pk, a_pk, ongoing & look[:, None], np)
        w = dict(w, x=x1, v=v1, D=D, t=w["t"] + tau, nev=w["nev"] + 1)
        # the law's transition, contact by contact
        Wd = v1 @ self.C.T
        opens = np.zeros((b, K), bool)
        closes = np.zeros((b, K), bool)
        # (the law called once per contact and kind of event, that kind a Python int: the law
        # evaluates that event's transition only, not every kind's and then picks)
        # (and once per mode and piece, those two given as numbers: the law then takes the
        # branches of that mode and piece only, where with arrays it evaluates every branch
        # any member may take and picks, field by field)
        for f in range(3 * K):
            at = np.flatnonzero(keep & (which == f))
            if not at.size:
                continue
            k, law = f // 3, self.laws[f // 3]
            mode, seg = st[k]["mode"][at], st[k]["seg"][at]
            for r in self._alike(at, mode, seg):
                old = {key: a[r] for key, a in st[k].items()}
                old["mode"], old["seg"] = old["mode"][0], old["seg"][0]
                with np.errstate(all="ignore"):
                    new = law.on_event(f % 3, D[r, k], Wd[r, k], old,
                                       _subset(self.cp[k], ix[r]), np)
                for key, a in new.items():     # (a number the law leaves unbatched: broadcast)
                    st[k][key][r] = a
            was, now = mode != MODE_OPEN, st[k]["mode"][at] != MODE_OPEN
            opens[at, k], closes[at, k] = was & ~now, now & ~was
            keep[at[st[k]["status"][at] != 0]] = False
        first = _metrics.event_update(first, w["t"], v1, closes, opens, np)
        # each impact (touch to separation) must be resolved by the clock (check_resolved)
        t_now = w["t"][:, None]
        keep &= ~many(opens & ~_resolved(w["since"], t_now))
        w["since"] = np.where(closes, t_now, np.where(opens, np.nan, w["since"]))
        sep = many(opens)
        w["v_post"] = np.where(sep[:, None], v1, w["v_post"])
        return w, st, first, keep, fresh

    # ------------------------------------------------------------------ pieces
    def _event_functions(self, motion, S, D0, W0, x0, v0, ix, omega):
        """The event functions ``(Sums (b, 3K), armed (b, 3K), tolerance at the start)`` in the
        model's event order (contact ``k``: lower end, upper end, closing rate); ``S``: the
        contacts' states' numbers (b, K) by key; ``omega`` (b,) [1/s]: the start state's rate
        (:meth:`._solve._Chain._earliest`'s)."""
        b, K = D0.shape
        P = motion.P
        dev, rate = motion.rows(P), motion.rates(P)           # ΔD_k, ΔḊ_k as series (b, K)
        length = self.v_scale[ix] * self.t_scale[ix]
        tol_d = START_TOL * length + 16 * _EPS * mmax(np.abs(x0))
        # (a rate's rounding includes the deformation's through the fastest mode that an
        # inexact force drives, as the single solve's, ._lines.rate_omega: a rounding-size k D
        # at a touch would fire max deformation and reload at one instant, over and over)
        tol_w = (START_TOL * self.v_scale[ix] + 16 * _EPS * mmax(np.abs(v0)) + tol_d
                 * rate_omega(self.m[ix], S["s"], S, D0, tol_d, omega, 1.0 / self.t_scale[ix]))
        def three(lower, upper, rate_):     # (b, K, ...) each, to (b, 3K, ...) in that order
            return np.stack([lower, upper, rate_], axis=2).reshape(b, 3 * K, *lower.shape[2:])
        # each contact's: its piece's lower end reached going down, (D - da) + wl; its upper
        # end reached going up, hi - D; its closing rate through zero while loading
        c = three((D0 - S["da"]) + S["wl"], S["hi"] - D0, W0)
        alpha = three(dev.alpha, -dev.alpha, rate.alpha)
        gamma = three(dev.gamma, -dev.gamma, rate.gamma)
        armed = three(S["lo"] > -1e299, S["hi"] < 1e299, S["vm"] != 0)
        tol = np.repeat(np.stack([tol_d, tol_d, tol_w], axis=1)[:, None, :], K, axis=1)
        g = Sums(c, alpha, gamma, motion.kappa, motion.w)
        return g, armed, tol.reshape(b, 3 * K)

    def _peaks(self, motion, slope, force, ix, r, tau, monotone, unloads, top_force, bars):
        """Each contact's largest force and each vehicle's acceleration of largest magnitude
        (signed) over ``[0, τ]`` of members ``r``: ``(peaks (m, K + N), undecided (m,))`` (as
        :meth:`._solve._Chain._peaks`). The extrema are searched on the forces and on the
        accelerations of the vehicles between two contacts; the end vehicles' accelerations
        are their one contact's force over their mass, whose value of largest magnitude is the
        force's, scaled. Only where one of them may have an extremum inside ``[0, τ]``: a
        contact with no slope has a constant force, one loading all along (``monotone`` (m,
        K): its deformation rises up to the segment's end) a monotone one, and a vehicle
        pushed by one such force and a constant one a monotone acceleration; a member whose
        functions are all such takes its extremes at the two ends.

        Nor where the value cannot change the first-impact record: ``bars`` (m, K + N - 2)
        (:func:`._batch_peaks.bars`), what a force or a middle vehicle's acceleration must exceed to be
        folded into it (inf: not folded). A force lies in ``[0, U]``: ``U`` 0 open, the larger
        end loading all along, ``top_force`` (m, K) on an unloading line (``unloads`` (m, K):
        the line's top, ``(D_max, F_max)``, which the deformation stays below), unknown
        otherwise; a middle vehicle's acceleration, the difference of two such forces over
        its mass, is at most the larger ``U`` over its mass. A function whose bound is at most
        its bar is taken at its ends (its extremes there or below the record)."""
        K, N = self.K, self.N
        P = motion.P[r]
        rows = slope[r][:, :, None] * P                                    # (m, K, N)
        a, bq = motion.a[r][:, None, :], motion.b[r][:, None, :]
        fa, fg = rows * a, rows * bq
        inc = -self.C.T[1:N - 1]                                            # (N - 2, K)
        m = self.m[ix[r]]
        mass = m[:, 1:N - 1, None]
        c = np.concatenate([force[r], (force[r] @ inc.T) / mass[:, :, 0]], axis=1)
        alpha = np.concatenate([fa, np.einsum("nk,mkj->mnj", inc, fa) / mass], axis=1)
        gamma = np.concatenate([fg, np.einsum("nk,mkj->mnj", inc, fg) / mass], axis=1)
        series = Sums(c, alpha, gamma, motion.kappa[r], motion.w[r])
        largest = np.arange(K + N - 2) < K
        # the functions that may turn inside [0, τ]: a sloped force not loading all along; a
        # middle vehicle's acceleration between two sloped contacts or one such force
        loaded = slope[r] != 0
        turns = loaded & ~monotone
        pushed = np.abs(inc) @ loaded.T.astype(int)                         # (N - 2, m)
        wild = (np.abs(inc) @ turns.T.astype(int)) > 0
        want = np.concatenate([turns, ((pushed > 1) | wild).T], axis=1)     # (m, K + N - 2)
        end = series.each_at(tau)
        bound = np.where(~loaded, 0.0, np.where(monotone, np.maximum(c[:, :K], end[:, :K]),
                                                np.where(unloads, top_force, np.inf)))
        near = np.abs(inc) > 0
        middle = mmax(np.where(near[None], bound[:, None, :], 0.0)) / m[:, 1:N - 1]
        want &= ~(np.concatenate([bound, middle], axis=1) <= bars)
        search = many(want)
        top, bottom = np.maximum(c, end), np.minimum(c, end)
        undecided = np.zeros(r.size, bool)
        if search.any():
            q = np.flatnonzero(search)
            top[q], bottom[q], undecided[q] = extreme_values(series.take(q), tau[q], largest,
                                                             want[q], bars[q])
        signed = np.where(np.abs(top) >= np.abs(bottom), top, bottom)
        # (contact 0 pushes vehicle 0 back, contact K - 1 pushes vehicle N - 1 forward)
        return np.concatenate([top[:, :K], -signed[:, :1] / m[:, :1], signed[:, K:],
                               signed[:, K - 1:K] / m[:, N - 1:]], axis=1), undecided

    def _result_checks(self, metrics, out, first) -> np.ndarray:
        """(n,): what ``Result.build`` checks besides the impacts (the whole crash resolved by
        the clock, every metric finite where a number is expected) and the single solve's
        energy balance; a member that fails them is solved alone, for its own message."""
        ok = _resolved(np.nanmin(np.where(np.isnan(first["contact_time"]), np.inf,
                                          first["contact_time"]), axis=1), out["t"])
        ok |= np.all(np.isnan(first["contact_time"]), axis=1)
        ok &= balanced(self.m, self.v0, metrics)   # (._balance: the single solve's check)
        for name in METRICS:
            a = metrics[name].reshape(self.n, -1)
            allowed = np.isnan(a) if name in _MAY_BE_NAN else np.zeros(a.shape, bool)
            ok &= np.all(np.isfinite(a) | allowed, axis=1)
        return ok

    def _over(self, w, st) -> np.ndarray:
        """(b,): every contact open and none closing again before the horizon
        (:meth:`HybridModel.contacts_apart`)."""
        ix = w["ix"]
        D, W = w["D"], w["v"] @ self.C.T
        modes = np.stack([s["mode"] for s in st], axis=1)
        gaps = np.stack([law.closing_gap(D[:, k], s) for k, (law, s) in
                         enumerate(zip(self.laws, st))], axis=1)
        late = gaps > W * (self.horizon[ix] - w["t"])[:, None]
        return np.all(modes == 0, axis=1) & np.all((W <= OVER_TOL * self.v_scale[ix][:, None])
                                                   | late, axis=1)

    def _metrics(self, out, first, code):
        """:func:`lsc.metrics.metrics` of every member (NaN where not :data:`DONE`)."""
        records = {key: out[key] for key in ("dmax", "dperm", "ec", "er")}
        with np.errstate(all="ignore"):
            res = _metrics.metrics(first, records, out["v_post"], np.full(self.n, self.g),
                                   np.full((self.n, self.K), np.nan), out["t"], out["v"], np)
        ok = code == DONE
        return {k: np.where(ok.reshape((-1,) + (1,) * (np.ndim(a) - 1)), a, np.nan)
                for k, a in res.items()}

    @staticmethod
    def _alike(at, mode, seg) -> list:
        """The members ``at`` in groups of one mode and one piece (``mode, seg``: theirs)."""
        if (mode == mode[0]).all() and (seg == seg[0]).all():
            return [at]
        pairs, group = np.unique(np.stack([mode, seg], axis=1), axis=0, return_inverse=True)
        return [at[group.reshape(-1) == g] for g in range(len(pairs))]

    @staticmethod
    def _full(st: dict, n: int) -> dict:
        return {k: np.array(np.broadcast_to(a, (n,))) for k, a in st.items()}

    @staticmethod
    def _take(d: dict, keep) -> dict:
        return {k: a[keep] for k, a in d.items()}
