"""A single diffrax solve as a :class:`~lsc.result.Result`: the compiled segment loop with its
records (:mod:`.core`), then the sampled series from the recorded steps. A chain whose pairs may
lock is solved with its locks (:func:`lsc.locking.locking_model`, as SciPy's): its events name
the locks and releases (a release by another part's event too), and its Result the warning.

``stats["compile_time"]`` [s] is the compile time spent in that call (0 when cached),
``stats["wall_time"]`` [s] the run time of the compiled solve (a solve of more than
:data:`RECORD_NODES` steps in all runs again, with a record of ``4 x max_steps`` nodes: both runs
are counted). The sampled series of the Result come from the recorded steps: a second, small
compiled function re-takes each step once for its dense interpolant (compiled once per
power-of-two bucket of steps and samples).
"""

from __future__ import annotations

import numpy as np

from .compiled import bucket, f64, to_numpy, unflat

import jax  # noqa: E402

from ...errors import SimulationError  # noqa: E402
from ...locking import lock_warnings, locking_model  # noqa: E402
from ...result import Event  # noqa: E402
from ..segments import Segment, build_result  # noqa: E402
from .core import RECORD_FULL, check_settings, segment_loop, status_message  # noqa: E402
from .dips import BARY, THETA  # noqa: E402

__all__ = ["solve", "record", "record_args", "events_of", "RECORD_NODES"]

#: Nodes of the dense record of a single solve at first (then ``4 x max_steps`` if it fills).
RECORD_NODES = 512


class _Sampler:
    """The dense output of one solve: every recorded step's interpolant, sampled once (one
    compiled call) at the Chebyshev–Lobatto points :data:`THETA` of the step, and evaluated in
    NumPy by the barycentric formula (exact for the integrators' polynomial interpolants); exact
    recorded states at the nodes."""

    def __init__(self, core, p, out, discs, nseg):
        nodes = out["nodes"][: int(out["n_nodes"])]
        self.node_t, self.node_y = nodes[:, 0], nodes[:, 1:]
        seg = out["seg"][:nseg]
        self.n0, self.n1, self.sdisc = seg[:, 0], seg[:, 1], seg[:, 2]
        # the steps: node j to node j + 1 inside each segment
        steps = np.concatenate([np.arange(a, b) for a, b in zip(self.n0, self.n1)] or [[]])
        steps = steps.astype(int)
        self.compile_time = 0.0
        self.values = np.zeros((len(self.node_t), len(THETA), self.node_y.shape[1]))
        if steps.size:
            B = bucket(steps.size, 64)
            st = np.resize(steps, B)
            seg_of = np.searchsorted(self.n0, st, side="right") - 1
            vals, self.compile_time, _ = core.sampler(
                p, out["rtol"], out["atol"], discs, self.node_t[st], self.node_t[st + 1],
                self.node_y[st], self.sdisc[seg_of].astype(np.int32),
                out["frame"][:nseg][seg_of], self.node_t[self.n0[seg_of]])
            self.values[steps] = np.asarray(vals)[: steps.size]

    def evaluate(self, s: int, tt) -> np.ndarray:
        """States (n, len(tt)) of segment ``s`` at times ``tt``."""
        tt = np.atleast_1d(np.asarray(tt, float))
        a, b = int(self.n0[s]), int(self.n1[s])
        if b <= a:  # no step (a segment of zero length): its start state
            return np.repeat(self.node_y[a][:, None], tt.size, axis=1)
        j = np.clip(np.searchsorted(self.node_t[a:b + 1], tt, side="right") - 1, 0, b - a - 1) + a
        t0, t1 = self.node_t[j], self.node_t[j + 1]
        theta = (tt - t0) / np.where(t1 > t0, t1 - t0, 1.0)
        d = theta[:, None] - THETA[None, :]
        hit = d == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(hit, 0.0, BARY / np.where(hit, 1.0, d))
        V = self.values[j]  # (Q, M, n)
        y = np.einsum("qm,qmn->qn", r, V) / np.sum(r, axis=1)[:, None]
        on = hit.any(axis=1)
        y[on] = V[on, np.argmax(hit[on], axis=1)]
        y[tt == t0] = self.node_y[j[tt == t0]]
        y[tt == t1] = self.node_y[j[tt == t1] + 1]
        return y.T


class _Dense:
    """``Segment.dense`` of one segment."""

    def __init__(self, sampler, s):
        self.sampler, self.s = sampler, s

    def __call__(self, tt):
        return self.sampler.evaluate(self.s, tt)


def record_args(model, rtol, atol, t_end) -> tuple:
    """The arguments of the compiled single solve (:attr:`~.core.SegmentLoop.single`) of
    ``model``: its parameters (float64), ``rtol``, ``atol``, ``t_end`` and its horizon (NaN for
    those not given)."""
    p = jax.tree_util.tree_map(f64, model.params)
    horizon = float(model.horizon()) if hasattr(model, "horizon") else np.nan
    return (p, f64(rtol), f64(np.nan if atol is None else atol),
            f64(np.nan if t_end is None else t_end),
            f64(horizon if np.isfinite(horizon) else np.nan))


def record(model, *, integrator: str = "Dopri8", rtol: float = 1e-10, atol=None, t_end=None,
           max_steps: int = 2048, max_events: int = 256):
    """The compiled segment loop of ``model`` in record mode (options as :func:`solve`):
    ``(core, p, out, compile_time, wall_time)``, the :class:`~.core.SegmentLoop` that ran, the
    parameters (float64) and its record as NumPy arrays (events, segments, step nodes, frames).
    Raises :class:`~lsc.errors.SimulationError` where the solve fails."""
    check_settings(integrator, rtol, atol, max_steps, max_events)
    args = record_args(model, rtol, atol, t_end)
    p = args[0]
    # a small dense record first (most solves take a few dozen steps; a record sized for
    # 4 x max_steps made the compiled solve ~25% slower); a solve that fills it runs again with
    # the full one
    compile_time = wall = 0.0
    for capacity in (min(RECORD_NODES, 4 * int(max_steps)), None):
        core = segment_loop(model, integrator, max_steps, max_events, capacity)
        out, ct, w = core.single(*args)
        compile_time, wall = compile_time + ct, wall + w
        if capacity is None or int(out["status"]) != RECORD_FULL:
            break
    out = to_numpy(out)
    status = int(out["status"])
    if status:
        raise SimulationError(status_message(status, int(out["status_contact"]), float(out["t"]),
                                             integrator))
    return core, p, out, compile_time, wall


def events_of(model, core, out):
    """The discrete states and events of a record (:func:`record`): ``(discs, states, events,
    y_post)``, the flat discrete state of each segment (initial, then after each event; the
    record's fixed number of rows), the first ``events + 1`` of them as Python dicts, the
    :class:`~lsc.result.Event` list (contacts closed at the start at 0) and the state at the last
    separation (``None`` if none)."""
    E, n = int(out["events"]), model.n_state
    rec = out["rec"]  # (max_events, ...): a fixed shape for the sampler
    discs = np.concatenate([out["disc0"][None], rec[:, 2 + n:]])
    states = [model.to_python(unflat(row, core.disc_like)) for row in discs[:E + 1]]
    events = [Event(0.0, "contact", k) for k, st in enumerate(states[0][: model.K]) if st["mode"]]
    y_post = None  # the state at the last separation (braked vehicles may slide on after it)
    for e in range(E):
        i = int(rec[e, 1])
        name = model.event_name(i, states[e], states[e + 1])
        t = float(rec[e, 0])
        events.append(Event(t, name, model.event_index(i)))
        # (a locked pair released by another part's event: lsc.locking)
        side = model.side_events(i, states[e], states[e + 1])
        events += [Event(t, kind, k) for kind, k in side]
        if "separation" in name or any("separation" in kind for kind, _ in side):
            y_post = rec[e, 2:2 + n]
    return discs, states, events, y_post


def solve(model, *, integrator: str = "Dopri8", rtol: float = 1e-10, atol=None, t_end=None,
          max_steps: int = 2048, max_events: int = 256, n_samples: int = 1000):
    """Solve ``model`` with diffrax (``integrator``: Tsit5, Dopri5, Dopri8, Kvaerno5).

    ``rtol`` and ``atol`` as in the SciPy backend (``atol`` default: ``rtol`` times the speed
    scale, times the contact time scale [s] for positions and times the speed scale and the
    smallest mass for work integrals); ``t_end`` [s]: simulate until then; ``max_steps``: most
    steps in one segment; ``max_events``: most events in one solve.
    """
    model = locking_model(model)   # a chain's contacts pushed shut lock (lsc.locking)
    core, p, out, compile_time, wall = record(model, integrator=integrator, rtol=rtol, atol=atol,
                                              t_end=t_end, max_steps=max_steps,
                                              max_events=max_events)
    discs, states, events, y_post = events_of(model, core, out)
    nseg = int(out["segments"])
    sampler = _Sampler(core, p, out, discs, nseg)
    segments = [Segment(float(sampler.node_t[sampler.n0[s]]), float(sampler.node_t[sampler.n1[s]]),
                        states[int(sampler.sdisc[s])], _Dense(sampler, s)) for s in range(nseg)]
    steps, rejected = int(out["steps"]), int(out["rejected"])
    nfev = None  # derived: stages per step (FSAL counted once) + 3 per segment (start, first h)
    if core.evals_per_step is not None:
        nfev = (steps + rejected) * core.evals_per_step + 3 * nseg
    stats = {"steps": steps, "rejected_steps": rejected, "rhs_evaluations": nfev,
             "segments": nseg, "wall_time": wall,
             "compile_time": compile_time + sampler.compile_time,
             **lock_warnings(events)}   # (a lock left the plain IF-D law: say so)
    return build_result(model, segments, events, out["y"], states[-1],
                        method=f"diffrax-{integrator}", tolerances={"rtol": rtol, "atol": atol},
                        stats=stats, n_samples=n_samples, y_post=y_post)
