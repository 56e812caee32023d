"""Sampled accelerations and contact forces of a diffrax solve on a time grid, with their
derivatives with respect to the scene's parameters (:func:`sampled_jacobian`; used by
:func:`lsc.analysis.fit`).

The solve is the single solve's compiled segment loop (:func:`~.single.record`: the same compiled
function as :func:`lsc.solve` with ``method="diffrax"``, its steps and events). The derivatives are
forward-mode automatic differentiation (``jax.jvp``, one tangent per parameter, vmapped) through
the integrator's steps as the solve took them, each step re-taken from its recorded start
(as the Result's dense output re-takes it), and through the events:

* a step ``y1 = Φ(y0, disc, p)`` carries the tangent ``δy1 = Φ_y δy0 + Φ_disc δdisc + Φ_p``
  (the step times held: the derivative of the solution at fixed times, not of where the step-size
  controller happened to put its steps);
* an event moves with the parameters: its time by the implicit function theorem on its event
  function ``g_i(t*, y(t*), disc, p) = 0``, ``dt*/dp = -(g_y δy + g_disc δdisc + g_p) / (g_t +
  g_y f⁻)``; the discrete state after it (a reached maximum deformation, the unloading line
  through it) is :meth:`~lsc.model.HybridModel.apply_event` differentiated along the moved event
  point ``(t*, y + f⁻ dt*)``; the state tangent at fixed time then jumps by ``(f⁻ - f⁺) dt*``
  (``f⁻``, ``f⁺``: the right-hand sides before and after);
* a sample at time ``τ`` after the first contact is read on the interpolant of the step that
  holds ``t_c + τ``, ``t_c`` the first contact's time (an event time, with its derivative), and
  differentiated along the step's start tangent, the discrete state's and the parameters'.

Values and derivatives come out of one compiled function, compiled once per scene structure,
number of samples and channels, and power-of-two bucket of steps and events.
"""

from __future__ import annotations

import numpy as np

from .compiled import Compiled, bucket, canon, f64, flat, structure, unflat

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from jax import lax  # noqa: E402

from ...errors import SceneError  # noqa: E402
from ...moving_frame import Frame  # noqa: E402
from .core import check_settings, segment_loop  # noqa: E402
from .single import RECORD_NODES, events_of, record, record_args  # noqa: E402
from .wrappers import SOLVERS  # noqa: E402

__all__ = ["sampled_jacobian", "warm"]

_STEP, _EVENT, _NONE = 0, 1, 2
#: XLA options of the derivatives' program: its compilation is most of a first fit's time, its
#: run a few milliseconds; without LLVM's optimisations it compiles in ~2/3 of the time and
#: runs several times slower (measured: 2.0 vs 3.0 s of CPU to compile, 3-9 vs 1 ms a run).
_FAST_COMPILE = {"xla_backend_optimization_level": 0}
_FUNCTIONS: dict = {}


def _items(model, out, discs):
    """The record as a time-ordered list of items: each step (from its recorded start node) and
    each event (after the step that ends on it), with the segment's frame and discrete state;
    ``(arrays, event_item)``: field → array over the items, and event number → item."""
    n = model.n_state
    nodes = out["nodes"][: int(out["n_nodes"])]
    node_t, node_y = nodes[:, 0], nodes[:, 1:]
    nseg, E, rec = int(out["segments"]), int(out["events"]), out["rec"]
    seg, frames = out["seg"][:nseg], out["frame"][:nseg]
    parts, event_item, count = [], {}, 0
    for s in range(nseg):
        a, b, e = (int(v) for v in seg[s])
        j = np.arange(a, b)
        m = j.size
        step = {"kind": np.full(m, _STEP), "t0": node_t[j], "t1": node_t[j + 1], "y0": node_y[j],
                "ev": np.zeros(m, int)}
        ends = e < E and (s == nseg - 1 or int(seg[s + 1, 2]) > e)
        if ends:   # the segment ends on event e: the step before it ends at the event point
            event_item[e] = count + m
            step = {k: np.concatenate([v, w]) for (k, v), w in zip(step.items(), (
                [_EVENT], [rec[e, 0]], [rec[e, 0]], rec[e, 2:2 + n][None], [int(rec[e, 1])]))}
        size = m + int(ends)
        step.update({"row": np.repeat(discs[e][None], size, axis=0),
                     "row1": np.repeat(discs[e + int(ends)][None], size, axis=0),
                     "frame": np.repeat(frames[s][None], size, axis=0),
                     "ts": np.full(size, node_t[a])})
        parts.append(step)
        count += size
    items = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    B = bucket(count, 64)
    pad = np.resize(np.arange(count), B)   # padding: copies of real items, marked as none
    items = {k: v[pad] for k, v in items.items()}
    items["kind"][count:] = _NONE
    return items, event_item


def _function(core, accel, force):
    """The compiled function of a segment loop ``core`` and the sampled channels (vehicle
    indices ``accel``, contact indices ``force``): values (R, G) and derivatives (R, G, P)."""
    key = (structure(core.model), core.integrator, core.max_steps, core.max_events,
           tuple(accel), tuple(force))
    fn = _FUNCTIONS.get(key)
    if fn is None:
        fn = _FUNCTIONS[key] = Compiled(_traced(core, list(accel), list(force)), _FAST_COMPILE)
    return fn


def _traced(core, accel, force):
    m, term, like, N = core.model, core.term, core.disc_like, core.model.N
    # diffrax's own step with its stage loop (one right-hand side in the compiled program, where
    # the segment loop's unrolled tableau has one per stage): the same step up to rounding
    solver = SOLVERS[core.integrator](scan_kind="lax")

    def run(p, T, items, gidx, inside, tau, t_c, fc_item):
        P = jax.tree_util.tree_leaves(T)[0].shape[0]
        eye, zero = jnp.eye(P), jnp.zeros(P)

        def at(theta):   # the parameters moved by theta along the tangents
            return jax.tree_util.tree_map(lambda a, t: a + jnp.tensordot(theta, t, axes=1), p, T)

        def along(f, primals, tangents, axes):
            """f at primals, and its derivative along each of P tangents (axes: their P axis):
            (value, (P, ...))."""
            value, lin = jax.linearize(f, *primals)
            return value, jax.vmap(lin, in_axes=axes)(*tangents)

        def derivs(f, primals, tangents, axes):
            """The derivatives of f at primals along each of P tangents: (P, ...)."""
            return jax.vmap(lambda *t: jax.jvp(f, primals, t)[1], in_axes=axes)(*tangents)

        def frame_of(it):
            return Frame(it["ts"], it["frame"][:N], it["frame"][N])

        def step(carry, it):
            dy, dr = carry

            def phi(theta, y0, row):
                """A recorded step re-taken from y0: the state at its end (absolute), and its
                interpolant's coefficients (the segment's frame)."""
                frame = frame_of(it)
                args = (unflat(row, like), frame.params(at(theta)))
                t0, t1 = it["t0"], it["t1"]
                u0 = frame.to_frame(t0, y0, jnp)
                u1, _, dense, _, _ = solver.step(term, t0, t1, u0, args,
                                                 solver.init(term, t0, t1, u0, args), False)
                return frame.to_abs(t1, u1, jnp), dense
            (_, dense), (dy1, ddense) = along(phi, (zero, it["y0"], it["row"]), (eye, dy, dr),
                                              (0, 1, 1))
            return (dy1.T, dr), (zero, dense, ddense)

        def event(carry, it):
            dy, dr = carry
            te, y, row, i = it["t0"], it["y0"], it["row"], it["ev"]

            def g(t, y, row, theta):
                return m.event_values(t, y, unflat(row, like), at(theta), jnp)[i]

            def f(t, y, row, theta):
                return m.rhs(t, y, unflat(row, like), at(theta), jnp)

            def after(t, y, row, theta):
                return flat(lax.switch(i, core.branches, t, y, unflat(row, like), at(theta)))

            num = derivs(lambda y, r, th: g(te, y, r, th), (y, row, zero), (dy, dr, eye),
                         (1, 1, 0))
            fm = f(te, y, row, zero)
            gdot = jax.jvp(lambda t, y: g(t, y, row, zero), (te, y), (jnp.ones_like(te), fm))[1]
            dte = -num / gdot
            moved = dy + fm[:, None] * dte[None, :]          # of the state at the event point
            dr1 = derivs(after, (te, y, row, zero), (dte, moved, dr, eye), (0, 1, 1, 0))
            fp = f(te, y, it['row1'], zero)
            return (moved - fp[:, None] * dte[None, :], dr1.T), (dte, *none_dense)

        def body(carry, it):
            new, out = lax.switch(it["kind"], [step, event, lambda c, it: (c, (zero, *none_dense))],
                                  carry, it)
            return new, (carry, out)

        # the shapes of a step's interpolant coefficients (zeros for the other items)
        it0 = jax.tree_util.tree_map(lambda a: a[0], items)
        shapes = jax.eval_shape(lambda: step((jnp.zeros((m.n_state, P)),
                                              jnp.zeros((it0["row"].shape[0], P))), it0)[1][1:])
        none_dense = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)
        _, dy0 = along(lambda th: m.initial(at(th), jnp)[0], (zero,), (eye,), (0,))
        _, dr0 = along(lambda th: flat(canon(m.initial(at(th), jnp)[1])), (zero,), (eye,), (0,))
        _, ((_, drs), (dtes, dense, ddense)) = lax.scan(body, (dy0.T, dr0.T), items)
        dt_c = jnp.where(fc_item >= 0, dtes[jnp.maximum(fc_item, 0)], zero)

        def sample(k, ok, s):
            it, d, dd = jax.tree_util.tree_map(lambda a: a[k], (items, dense, ddense))
            frame, h = frame_of(it), it["t1"] - it["t0"]

            def channels(d, tc, row, theta):
                interp = solver.interpolation_cls(t0=it["t0"], t1=it["t1"], **d)
                t = s + tc   # (held inside the step; the derivative is the unclipped one)
                t = t + lax.stop_gradient(jnp.clip(t, it["t0"], it["t1"]) - t)
                y = frame.to_abs(t, interp.evaluate(t), jnp)
                F, _, a = m.accelerations(y, unflat(row, like), at(theta), jnp)
                return jnp.concatenate([a[jnp.asarray(accel, int)], F[jnp.asarray(force, int)]])
            ok = ok & (h > 0)
            val, der = along(channels, (d, t_c, it["row"], zero), (dd, dt_c, drs[k], eye),
                             (0, 0, 1, 0))
            return jnp.where(ok, val, 0.0), jnp.where(ok, der.T, 0.0)

        vals, ders = jax.vmap(sample)(gidx, inside, tau)
        return vals.T, jnp.moveaxis(ders, 0, 1)

    return run


def sampled_jacobian(model, tangents, tau, *, accel=(), force=(), integrator: str = "Dopri8",
                     rtol: float = 1e-10, atol=None, t_end=None, max_steps: int = 2048,
                     max_events: int = 256):
    """The accelerations of vehicles ``accel`` and the forces of contacts ``force`` of the
    diffrax solve of ``model`` at times ``tau`` [s] after its first contact, and their
    derivatives along each of ``tangents`` (pytrees shaped as ``model.params``: ``∂ params / ∂
    parameter``, :func:`lsc.parameters.tangent`).

    Zero (with zero derivatives) before the solve's start and after its end. Solver options as
    :func:`~.single.solve` (explicit integrators only: Tsit5, Dopri5, Dopri8). Returns ``(values,
    derivatives, info)``: (R, G), (R, G, P) (rows: ``accel`` then ``force``), and ``t_end`` [s]
    (the solve's end, from first contact), ``first_contact`` [s], ``compile_time``,
    ``wall_time`` [s]. Raises :class:`~lsc.errors.SimulationError` where the solve fails.
    """
    core, p, out, ct, wall = record(model, integrator=integrator, rtol=rtol, atol=atol,
                                    t_end=t_end, max_steps=max_steps, max_events=max_events)
    if core.evals_per_step is None:
        raise SceneError("solver.integrator", f"the derivatives re-take explicit Runge-Kutta "
                                              f"steps (Tsit5, Dopri5, Dopri8), not {integrator}'s")
    discs, _, events, _ = events_of(model, core, out)
    items, event_item = _items(model, out, discs)
    # the first contact (compare's alignment): at 0 where a contact is closed at the start, else
    # the first contact event (its time moves with the parameters), else the start
    E = int(out["events"])
    start = len(events) - E
    later = [e for e in range(E) if events[start + e].kind == "contact"]
    t_c, fc_item = 0.0, -1
    if not start and later:
        t_c, fc_item = events[start + later[0]].time, event_item[later[0]]
    t_abs = np.asarray(tau, float) + t_c
    steps = np.flatnonzero(items["kind"] == _STEP)
    k = np.clip(np.searchsorted(items["t0"][steps], t_abs, side="right") - 1, 0, steps.size - 1)
    gidx = steps[k]
    inside = (t_abs >= items["t0"][gidx]) & (t_abs <= items["t1"][gidx])
    T = jax.tree_util.tree_map(lambda *xs: np.stack([np.asarray(x, float) for x in xs]),
                               *tangents)
    fn = _function(core, accel, force)
    arrays = {k: (v.astype(np.int32) if k in ("kind", "ev") else f64(v)) for k, v in items.items()}
    (vals, ders), ct2, w2 = fn(p, T, arrays, gidx.astype(np.int32), inside, f64(tau), f64(t_c),
                               np.int32(fc_item))
    info = {"t_end": float(out["t"]) - t_c, "first_contact": t_c, "compile_time": ct + ct2,
            "wall_time": wall + w2}
    return np.asarray(vals), np.asarray(ders), info


def warm(model, n_params: int, n_samples: int, *, accel=(), force=(), integrator: str = "Dopri8",
         rtol: float = 1e-10, atol=None, t_end=None, max_steps: int = 2048,
         max_events: int = 256) -> None:
    """Start compiling, in background threads (:meth:`~.compiled.Compiled.warm`), what a first
    :func:`sampled_jacobian` of ``model``'s structure with ``n_params`` tangents and ``n_samples``
    samples runs (its solve, and its derivatives for up to 64 steps and events) and the dense
    output of a Result of up to 64 steps (:func:`~.single.solve`): XLA compiles each program on
    one core, so the three compile side by side where cores are free."""
    check_settings(integrator, rtol, atol, max_steps, max_events)
    core = segment_loop(model, integrator, max_steps, max_events,
                        min(RECORD_NODES, 4 * int(max_steps)))
    args = record_args(model, rtol, atol, t_end)
    core.single.warm(*args)
    p, n, N, B = args[0], model.n_state, model.N, 64
    L = sum(int(np.prod(leaf.shape)) for leaf in jax.tree_util.tree_leaves(core.disc_like))
    zeros = np.zeros
    items = {"kind": zeros(B, np.int32), "ev": zeros(B, np.int32), "t0": zeros(B), "t1": zeros(B),
             "ts": zeros(B), "y0": zeros((B, n)), "row": zeros((B, L)), "row1": zeros((B, L)),
             "frame": zeros((B, N + 1))}
    T = jax.tree_util.tree_map(lambda a: zeros((n_params,) + np.shape(a)), p)
    _function(core, accel, force).warm(p, T, items, zeros(n_samples, np.int32),
                                       zeros(n_samples, bool), zeros(n_samples), f64(0.0),
                                       np.int32(0))
    core.sampler.warm(p, args[1], zeros(n), zeros((int(max_events) + 1, L)), zeros(B), zeros(B),
                      zeros((B, n)), zeros(B, np.int32), zeros((B, N + 1)), zeros(B))
