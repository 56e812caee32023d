"""The diffrax backend's segment loop: the whole hybrid solve as one compiled JAX function.

The segment loop is a ``jax.lax.while_loop``; each segment (frozen discrete state) is one
``diffrax.diffeqsolve`` that stops at the first event (located by :mod:`.dips`). The physics is
the shared array code run on ``jax.numpy``: :meth:`HybridModel.rhs`,
:meth:`HybridModel.event_values` and :meth:`HybridModel.apply_event` (the contact laws' and
effects' ``on_event`` transitions, chosen by the traced event index); nothing is re-derived here.
The loop ends when every contact is open and none is closing and no braked vehicle slides
(:meth:`HybridModel.is_over`, written in ``jnp``), at ``t_end``, or on a failure status (the
law's :data:`~lsc.contact.STATUS` codes raise the same :class:`~lsc.errors.SimulationError` as the
NumPy backends: :func:`status_message`).

Steps. diffrax's PID controller picks the steps (:mod:`.wrappers`); none is longer than
:meth:`HybridModel.max_step` (as in the SciPy backend: a step over half an oscillation can cross
an event surface and come back unseen). The scales, default tolerances, frame and end-of-crash
test are the model's (written once for NumPy and ``jax.numpy``).

Frame. Each segment is integrated in its own frame, as in the SciPy backend: positions from
where the vehicles are at its start, less the motion of the centre of mass (velocities less its
velocity; not with brakes), each contact's gap set to minus its deformation there
(:meth:`HybridModel.frame`). A deformation is then resolved to its own ulps, not to those of the
positions: after a metre of travel a near-plastic rebound (``e = 1e-6``, ``1e-12`` of the
deformation wide) lost most of its width to the rounding of the positions, accumulated over
the steps of the rebound.

Restart trap. diffrax fires a downward event when the value goes from ``> 0`` to ``<= 0``. An
event that starts a segment on (or a hair past) its surface, ``g_i / s_i <= 0``, is shifted to
start at exactly ``1e-12``: it fires only once the state moves ``1e-12`` (relative) further *into*
it (a contact that must close at once: a chain touching at rest), never because of round-off at the
restart on the surface just left (``D_max - D`` after the common velocity). An event that starts
ahead of its surface, however close, is left as it is: it fires when it is crossed (a rebound of
restitution 1e-6 is ``1e-12`` of the deformation wide); a crossing later in the first step is not
located at its start, where such an event is within the root tolerance of zero but rising (a
contact that separated a rounding error above its permanent set: see
:meth:`.dips.EventSearch._locate`).

A :class:`SegmentLoop` runs in two modes: ``record`` (single solves: events, segments and the step
nodes for a Result) and metrics only (batches and derivatives: the first-impact record and
the metrics of :mod:`lsc.metrics`).
:func:`segment_loop` caches one per structure and static options.
"""

from __future__ import annotations

import numpy as np

from .compiled import TRACES, Compiled, canon, flat, structure, unflat

import diffrax  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from jax import lax  # noqa: E402

from ... import metrics as M  # noqa: E402
from ...contact import STATUS  # noqa: E402
from ...errors import SceneError  # noqa: E402
from ...moving_frame import Frame  # noqa: E402
from .dips import EVENT_TOL, THETA, EventSearch  # noqa: E402
from .peaks import PeakSearch  # noqa: E402
from .wrappers import INTEGRATORS, SOLVERS, Stash, Unrolled, with_tols  # noqa: E402

__all__ = ["STATUS_CODES", "RECORD_FULL", "SegmentLoop", "segment_loop", "check_settings",
           "status_message"]

# Backend status codes (the law codes 1..5 are lsc.contact.STATUS).
MAX_EVENTS, NO_EVENT, SOLVER_FAILED, NON_FINITE, T_END_EARLY, RECORD_FULL = 10, 11, 12, 13, 14, 15

#: Status code → reason (0: ok; 1..5: the contact law's, :data:`lsc.contact.STATUS`).
STATUS_CODES = {
    0: "ok",
    **{k: v for k, v in STATUS.items() if k},
    MAX_EVENTS: "event limit reached and the crash is not over: raise max_events, or check the "
                "scene for contacts that chatter",
    NO_EVENT: "no event before the horizon although the crash is not over: the contact never "
              "separates (check the unloading branch)",
    SOLVER_FAILED: "the integrator failed (max_steps reached in one segment, or the step size "
                   "collapsed): raise max_steps or loosen rtol",
    NON_FINITE: "the solution became non-finite",
    T_END_EARLY: "the requested end time t_end comes before the crash is over (a contact is still "
                 "loaded or closing): raise solver.t_end or leave it unset",
    RECORD_FULL: "more steps in all than the dense record holds (4 x max_steps): raise max_steps",
}

def _law_status(disc):
    """First nonzero law status code over the contacts' states (0 if none), and that contact."""
    st = jnp.stack([d["status"] for d in disc])
    k = jnp.argmax(st != 0)
    return st[k].astype(jnp.int32), k.astype(jnp.int32)


# ---------------------------------------------------------------------------- the solver
class SegmentLoop(EventSearch, PeakSearch):
    """The compiled segment loop for one scene structure and one set of static options
    (``integrator``, ``max_steps`` per segment, ``max_events``, ``capacity``: nodes of the dense
    record). ``differentiable``: step with diffrax's own solver with a plain ``lax`` stage loop,
    which ``jax.jvp`` can go through (its default checkpointed loop is a ``custom_vjp``, which
    ``jvp`` refuses); otherwise explicit tableaus are unrolled (:class:`~.wrappers.Unrolled`)."""

    def __init__(self, model, integrator: str, max_steps: int, max_events: int,
                 capacity: int | None = None, differentiable: bool = False):
        self.model = model  # any model of this structure: only its structure is used in traces
        self.integrator = integrator
        base = SOLVERS[integrator]()
        # explicit tableaus: unrolled stages (diffrax's own loop is slow under vmap)
        self.solver = Unrolled(base) if isinstance(base, diffrax.AbstractERK) else base
        if differentiable:
            self.solver = SOLVERS[integrator](scan_kind="lax")
        self.max_steps = int(max_steps)
        self.max_events = int(max_events)
        # nodes of the dense record, over the whole solve
        self.capacity = 4 * self.max_steps if capacity is None else int(capacity)
        self.term = diffrax.ODETerm(self._vf)
        # stops at the end of the step where the first event crosses; _locate finds the root
        self.event = diffrax.Event(self._cond, None, direction=False)
        self.fail_contacts = [f.k for f in model.failures]
        # contacts whose law follows a post-failure curve and reports the failure itself
        self.fail_laws = [k for k, law in enumerate(model.laws) if getattr(law, "fails", False)]
        # forces and accelerations can peak between events (damping laws, braking, chains): the
        # metrics solve then searches every step for them; two-car IF-D peaks are at events
        self.interior = (model.N > 2 or bool(model.brakes)
                         or any(type(law).__name__ != "HysteresisLaw" for law in model.laws))
        self.branches = [self._branch(i) for i in range(len(model.events))]
        self.disc_like = jax.eval_shape(lambda p: canon(model.initial(p, jnp)[1]), model.params)
        self.single = Compiled(lambda p, rtol, atol, t_end, horizon:
                                self._run(p, rtol, atol, t_end, horizon, True))
        self.sampler = Compiled(self._sample)
        self.batched = {}
        if isinstance(base, diffrax.AbstractERK):
            tab = base.tableau
            self.evals_per_step = len(tab.c) + 1 - (1 if tab.fsal else 0)
        else:
            self.evals_per_step = None

    # -- what diffrax calls (the numbers travel in args, never in closures)
    def _vf(self, t, y, args):
        return self.model.rhs(t, y, args[0], args[1], jnp)

    def _cond(self, t, y, args, **kwargs):
        disc, p, off, sc, armed = args[:5]
        g = self.model.event_values(t, y, disc, p, jnp) / sc + off
        return jnp.where(armed, jnp.min(g), 1.0)

    def _branch(self, i):
        # (a model whose transitions end with a step common to every event, the release of
        # locked pairs, lsc.locking: that step once, after the switch, in _settle)
        apply = getattr(self.model, "event_transition", self.model.apply_event)

        def transition(t, y, disc, p):
            return canon(apply(i, t, y, disc, p, jnp))
        return transition

    def _settle(self, y, disc, p):
        """The step every transition ends with (:meth:`lsc.locking.LockingModel.settle`;
        none for a plain model)."""
        settle = getattr(self.model, "settle", None)
        return disc if settle is None else canon(settle(y, disc, p, jnp))

    def _run(self, p, rtol, atol, t_end, horizon, record: bool, g=None):
        """The whole hybrid solve. ``t_end``, ``horizon`` [s]: NaN when not given (the horizon:
        when a contact that has not separated is an error; default :meth:`HybridModel.horizon`).
        ``record``: keep events, segments and step nodes for a Result (single solves); else only
        the metrics (batches), ``peak_acceleration_g`` in units of ``g`` [acceleration]."""
        TRACES["core"] += 1
        m = self.model
        N, K, E, S, C, n = m.N, m.K, self.max_events, self.max_steps, self.capacity, m.n_state
        v_scale = m.speed_scale(p, jnp)
        sc = m.event_scales(p, jnp)
        # default atol: positions, velocities, work integrals (as SciPy); per segment, positions
        # to rtol of the active pieces' own scale (a near-plastic rebound line's width)
        own_atol = ~jnp.isnan(atol)
        atol = jnp.broadcast_to(jnp.where(own_atol, atol, m.default_atol(rtol, None, p, jnp)),
                                (n,))

        def segment_atol(disc):
            return jnp.where(own_atol, atol, m.default_atol(rtol, disc, p, jnp))

        # a dip inside a step less deep than this (over each event's scale) only touches the
        # surface (as the SciPy backend's: 100 rtol, the global error of a deformation)
        depth = jnp.maximum(EVENT_TOL, 100 * rtol)
        has_t_end = ~jnp.isnan(t_end)
        crash = jnp.where(jnp.isnan(horizon), m.horizon(p, jnp), horizon)
        horizon = jnp.where(has_t_end, t_end, crash)
        # a contact that would close again only after this has no crash left in it
        over_by = jnp.where(has_t_end, jnp.maximum(crash, t_end), crash)
        inner = with_tols(self.solver, rtol, atol)
        track = (not record) and self.interior
        stepper = Stash(inner, self._peaks if track else None, self._point if track else None,
                         self._hidden)
        y0, disc0 = m.initial(p, jnp)
        disc0 = canon(disc0)

        def contact_modes(disc):
            return jnp.stack([d["mode"] for d in disc[:K]])

        law0, lawk0 = _law_status(disc0[:K])
        c = {"t": jnp.asarray(0.0), "y": y0, "disc": disc0, "status": law0,
             "status_contact": lawk0, "n_ev": jnp.int32(0), "n_seg": jnp.int32(0),
             "finished": m.is_over(y0, disc0, 0.0, over_by, p, jnp, v_scale) & ~has_t_end,
             "steps": jnp.int32(0), "rejected": jnp.int32(0)}
        if record:
            c.update({
                # per event: time, event index, state (n), discrete state after it (flat)
                "rec": jnp.zeros((E, 2 + n + flat(disc0).size)),
                # per segment: first node, last node, its discrete state (0 = initial, e = event e)
                "seg": jnp.zeros((E + 1, 3), jnp.int32),
                # nodes of the dense record: time, state (n)
                "nodes": jnp.zeros((C + S + 1, 1 + n)), "n_nodes": jnp.int32(0),
                # per segment: its frame (the positions at its start, and V)
                "frame": jnp.zeros((E + 1, N + 1))})
        else:
            F0, _, a0 = m.accelerations(y0, disc0, p, jnp)
            failed0 = [disc0[K + len(m.brakes) + j]["failed"] > 0 for j in range(len(m.failures))]
            fail_t = jnp.full(K, jnp.nan)
            for j, k in enumerate(self.fail_contacts):
                fail_t = fail_t.at[k].set(jnp.where(failed0[j], 0.0, jnp.nan))
            for k in self.fail_laws:
                fail_t = fail_t.at[k].set(jnp.where(disc0[k]["failed"] > 0, 0.0, jnp.nan))
            closed0 = contact_modes(disc0) != 0
            c.update(M.first_impacts_init(closed0, y0[N:2 * N], F0, a0, jnp))
            c.update({"y_post": y0, "separated": False,
                      "separation_time": jnp.full(K, jnp.nan), "failure_time": fail_t})

        project = getattr(m, "project", None)   # (lsc.locking: a cluster at one velocity)

        def body(c):
            t, disc = c["t"], c["disc"]
            ys = c["y"] if project is None else project(c["y"], disc, p, jnp)
            frame = m.frame(t, ys, p, jnp)   # the segment's frame
            y, pf = frame.to_frame(t, ys, jnp), frame.params(p)
            # (then free flight to t_end, events disarmed)
            over = m.is_over(y, disc, t, over_by, pf, jnp, v_scale)
            g0 = m.event_values(t, y, disc, pf, jnp) / sc
            off = jnp.where(g0 <= 0, EVENT_TOL - g0, 0.0)  # the restart trap
            args = (disc, pf, off, sc, ~over, depth)
            controller = diffrax.PIDController(rtol=rtol, atol=segment_atol(disc),
                                               dtmax=m.max_step(disc, p, jnp))
            sol = diffrax.diffeqsolve(
                self.term, stepper, t, horizon, None, y, args=args,
                saveat=diffrax.SaveAt(steps=record, t1=True, solver_state=True),
                stepsize_controller=controller, event=self.event, max_steps=S,
                adjoint=diffrax.ForwardMode(), throw=False)
            nacc = sol.stats["num_accepted_steps"].astype(jnp.int32)
            if record:
                last = jnp.maximum(nacc - 1, 0)
                tn = jnp.where(nacc > 0, sol.ts[last], t)
                yn = jnp.where(nacc > 0, sol.ys[last], y)
            else:
                tn, yn = sol.ts[-1], sol.ys[-1]
            fired = sol.result == diffrax.RESULTS.event_occurred
            ok = fired | (sol.result == diffrax.RESULTS.successful)
            _, tp, tb, yp, dense, step_peaks = sol.solver_state
            te, ye, i = self._locate(inner, tp, tb, yp, dense, args)
            tn = jnp.where(fired, te, tn)
            yn = jnp.where(fired, ye, yn)
            # the event applied to the absolute state (as SciPy's): a law's reference
            # deformations (D_max, from which a rebound of e = 1e-6, 16 ulps of D_max wide,
            # is measured) are then the next segment's frame origin to the last bit
            ya = frame.to_abs(tn, yn, jnp)
            new = self._settle(ya, lax.switch(i, self.branches, tn, ya, disc, p), p)
            new = jax.tree_util.tree_map(lambda a, b: jnp.where(fired, a, b), new, disc)
            law, lawk = _law_status(new[:K])
            n_ev = c["n_ev"] + fired.astype(jnp.int32)
            at_end = has_t_end & (tn >= t_end)
            # reaching t_end with only braked vehicles still sliding is no failure (as SciPy)
            finished = (m.is_over(yn, new, tn, over_by, pf, jnp, v_scale)
                        & (~has_t_end | at_end)) | \
                (at_end & ~fired & m.contacts_apart(yn, new, tn, over_by, pf, jnp, v_scale))
            finite = jnp.all(jnp.isfinite(yn)) & jnp.isfinite(tn)
            status = jnp.select(
                [~ok, ~finite, law != 0, ~fired & ~over & ~finished, ~finished & (n_ev >= E)],
                [SOLVER_FAILED, NON_FINITE, law, jnp.where(has_t_end, T_END_EARLY, NO_EVENT),
                 MAX_EVENTS], 0).astype(jnp.int32)
            out = dict(c)
            yf, yn = yn, frame.to_abs(tn, yn, jnp)   # (the frame's state, and the absolute one)
            out.update({
                "t": tn, "y": yn, "disc": new, "status": status,
                "status_contact": jnp.where(law != 0, lawk, c["status_contact"]),
                "finished": finished, "n_ev": n_ev, "n_seg": c["n_seg"] + 1,
                "steps": c["steps"] + nacc,
                "rejected": c["rejected"] + sol.stats["num_rejected_steps"].astype(jnp.int32)})
            if record:
                j, n0, e = c["n_seg"], c["n_nodes"], c["n_ev"]
                ts = jnp.where(jnp.isfinite(sol.ts), sol.ts, t)   # (unused rows: inf)
                saved = jnp.concatenate([sol.ts[:, None], frame.to_abs(ts, sol.ys.T, jnp).T],
                                        axis=1)
                saved = saved.at[last].set(jnp.where(nacc > 0, jnp.concatenate([tn[None], yn]),
                                                     saved[last]))
                block = jnp.concatenate([jnp.concatenate([t[None], ys])[None], saved])
                row = jnp.concatenate([tn[None], i.astype(jnp.float64)[None], yn, flat(new)])
                out.update({
                    "status": jnp.where((status == 0) & (n0 + 1 + nacc > C), RECORD_FULL, status),
                    "nodes": lax.dynamic_update_slice(c["nodes"], block, (n0, jnp.int32(0))),
                    "n_nodes": n0 + 1 + nacc,
                    "seg": lax.dynamic_update_slice(c["seg"], jnp.stack([n0, n0 + nacc, e])[None],
                                                    (j, jnp.int32(0))),
                    "frame": c["frame"].at[j].set(jnp.concatenate([frame.x0, frame.V[None]])),
                    "rec": lax.dynamic_update_slice(c["rec"], row[None], (e, jnp.int32(0)))})
            else:
                # metrics: each contact's first impact (peaks at the event points before and
                # after the transition, and inside the segment's steps, while it is ongoing)
                Fb, _, ab = m.accelerations(yf, disc, pf, jnp)
                Fa, _, aa = m.accelerations(yf, new, pf, jnp)
                mb, ma = contact_modes(disc), contact_modes(new)
                closes = fired & (mb == 0) & (ma != 0)
                opens = fired & (mb != 0) & (ma == 0)
                fail_t = c["failure_time"]
                for jf, k in enumerate(self.fail_contacts):
                    q = K + len(m.brakes) + jf
                    now = fired & (disc[q]["failed"] == 0) & (new[q]["failed"] > 0)
                    fail_t = fail_t.at[k].set(jnp.where(now & jnp.isnan(fail_t[k]), tn, fail_t[k]))
                for k in self.fail_laws:
                    now = fired & (disc[k]["failed"] == 0) & (new[k]["failed"] > 0)
                    fail_t = fail_t.at[k].set(jnp.where(now & jnp.isnan(fail_t[k]), tn, fail_t[k]))
                first = {key: c[key] for key in M.FIRST_KEYS}
                ongoing = M.ongoing(first, jnp)   # in this segment, up to the event (before it)
                first = M.fold_peaks(first, Fb, ab, ongoing, jnp)
                if track:  # between the events: all steps, and the last one up to the event
                    first = M.fold_peaks(first, *step_peaks, ongoing, jnp)
                    first = M.fold_peaks(first, *self._last_peaks(tp, tn, yp, args), ongoing, jnp)
                first = M.event_update(first, tn, yn[N:2 * N], closes, opens, jnp)
                first = M.fold_peaks(first, Fa, aa, M.ongoing(first, jnp), jnp)   # after it
                out.update(first)
                out.update({
                    "failure_time": fail_t,
                    "y_post": jnp.where(jnp.any(opens), yn, c["y_post"]),
                    "separated": c["separated"] | jnp.any(opens),
                    "separation_time": jnp.where(opens, tn, c["separation_time"])})
            return out

        c = lax.while_loop(lambda c: (c["status"] == 0) & ~c["finished"], body, c)
        out = {k: c[k] for k in ("t", "y", "disc", "status", "status_contact", "steps", "rejected")}
        out.update({"segments": c["n_seg"], "events": c["n_ev"], "rtol": rtol, "atol": atol})
        if record:
            out["disc0"] = flat(disc0)
            out.update({k: c[k] for k in ("rec", "seg", "nodes", "n_nodes", "frame")})
        else:
            out.update(self._metrics(c, g, rtol))
        return out

    def _sample(self, p, rtol, atol, discs, st0, st1, sy0, sdisc, sframe, sts):
        """The dense output of the steps ``[st0, st1]`` from ``sy0`` (B,), in discrete state
        ``discs[sdisc]``, at the :data:`THETA` points of each step (B, len(THETA), n): each step
        is re-taken once for its interpolant (a polynomial of degree < len(THETA) in time), in
        its segment's frame (``sframe`` (B, N + 1): positions at the segment start ``sts`` (B,)
        and ``V``), as the solve took it."""
        TRACES["sampler"] += 1
        solver, term = with_tols(self.solver, rtol, atol), self.term
        theta = jnp.asarray(THETA)
        N = self.model.N

        def values(t0, t1, y0, d, fr, ts):
            frame = Frame(ts, fr[:N], fr[N])
            args = (unflat(discs[d], self.disc_like), frame.params(p))
            u0 = frame.to_frame(t0, y0, jnp)
            dense = solver.step(term, t0, t1, u0, args, solver.init(term, t0, t1, u0, args),
                                False)[2]
            h = jnp.where(t1 > t0, t1 - t0, 1.0)
            interp = solver.interpolation_cls(t0=t0, t1=t0 + h, **dense)
            tt = t0 + theta * h
            return frame.to_abs(tt, jax.vmap(interp.evaluate)(tt).T, jnp).T

        return jax.vmap(values)(st0, st1, sy0, sdisc, sframe, sts)

    def _metrics(self, c, g, rtol):
        """The Result metrics (:func:`lsc.metrics.metrics`) from the final carry ``c`` of a
        metrics solve: the headline metrics from the first-impact record, the contacts' records
        and ``v_final`` (after the last separation) over the run; closings within ``rtol`` of
        their time scale are simultaneous (:func:`lsc.metrics.tie_window`)."""
        N, K = self.model.N, self.model.K
        records = {key: jnp.stack([d[key] for d in c["disc"][:K]])
                   for key in ("dmax", "dperm", "ec", "er")}
        post = jnp.where(c["separated"], c["y_post"], c["y"])
        return M.metrics({key: c[key] for key in M.FIRST_KEYS}, records, post[N:2 * N], g,
                         c["failure_time"], c["t"], c["y"][N:2 * N], jnp,
                         separation_time=c["separation_time"], resolution=rtol)

    def run_metrics(self, p, rtol, atol, t_end, horizon, g):
        """The metrics solve of parameters ``p``, traced (not compiled: to be wrapped in ``vmap``
        or ``jvp``): the batch metrics, ``status``, ``status_contact``, ``t``, ``steps`` and
        ``segments``. ``t_end``, ``horizon`` [s]: NaN when not given; ``g`` [acceleration]: the
        unit of ``peak_acceleration_g``."""
        return self._run(p, rtol, atol, t_end, horizon, False, g)

    def run_batched(self, axes, p, rtol, atol, t_end, horizon, g):
        """The metrics solve vmapped over the parameter leaves whose axis is 0 in ``axes`` (and
        over ``horizon`` and ``g`` where they are arrays (B,))."""
        key = jax.tree_util.tree_flatten(axes, is_leaf=lambda x: x is None)
        key = (key[1], tuple(key[0]), np.ndim(horizon), np.ndim(g))
        fn = self.batched.get(key)
        if fn is None:
            fn = self.batched[key] = Compiled(jax.vmap(
                self.run_metrics, in_axes=(axes, None, None, None, 0 if np.ndim(horizon) else None,
                                           0 if np.ndim(g) else None)))
        return fn(p, rtol, atol, t_end, horizon, g)



_CORES: dict = {}


def segment_loop(model, integrator, max_steps, max_events, capacity=None) -> SegmentLoop:
    """The segment loop of ``model``'s structure and these static options (built once: later
    calls with the same structure reuse it, and its compiled functions)."""
    key = (structure(model), integrator, int(max_steps), int(max_events), capacity)
    loop = _CORES.get(key)
    if loop is None:
        loop = _CORES[key] = SegmentLoop(model, integrator, max_steps, max_events, capacity)
    return loop


def check_settings(integrator, rtol, atol, max_steps, max_events) -> None:
    """Refuse an unknown ``integrator`` (not in :data:`INTEGRATORS`) or a tolerance or count out of
    range, with a :class:`~lsc.errors.SceneError` at ``solver.<name>``."""
    if integrator not in INTEGRATORS:
        raise SceneError("solver.integrator", f"unknown diffrax integrator {integrator!r}; "
                         f"accepted: {', '.join(INTEGRATORS)}")
    for name, v in (("rtol", rtol), ("atol", atol)):
        if v is not None and not (np.isfinite(v) and v > 0):
            raise SceneError(f"solver.{name}",
                             f"{name} must be a positive finite number, got {v!r}")
    for name, v in (("max_steps", max_steps), ("max_events", max_events)):
        if int(v) < 1:
            raise SceneError(f"solver.{name}", f"{name} must be a positive integer, got {v!r}")


def status_message(status: int, contact: int, t: float, integrator: str) -> str:
    """The :class:`~lsc.errors.SimulationError` message of a failed solve: status code ``status``
    (:data:`STATUS_CODES`) at time ``t`` [s], ``contact`` the contact whose law failed (for the
    law's codes, :data:`lsc.contact.STATUS`, worded as :meth:`HybridModel.check_status`)."""
    where = f"contact {contact} at" if status in STATUS else f"diffrax {integrator},"
    return f"{where} t = {t:.6g} s: {STATUS_CODES[status]}"
