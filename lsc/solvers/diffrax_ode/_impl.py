"""diffrax backend: the whole hybrid solve as one compiled JAX function.

The segment loop is a ``jax.lax.while_loop``; each segment (frozen discrete state) is one
``diffrax.diffeqsolve`` that stops at the first event. The physics is the shared array code run on
``jax.numpy``: :meth:`HybridModel.rhs`, :meth:`HybridModel.event_values` and
:meth:`HybridModel.apply_event` (the contact laws' and effects' ``on_event`` transitions, chosen by
the traced event index); nothing is re-derived here. The loop ends when every contact is open and
none is closing and no braked vehicle slides (:meth:`HybridModel.is_over`, written in ``jnp``),
at ``t_end``, or on a failure status (the law's :data:`~lsc.contact.STATUS` codes raise the same
:class:`~lsc.errors.SimulationError` as the NumPy backends).

Steps. diffrax's PID controller picks the steps; none is longer than ``MAX_ANGLE / ω`` for the
highest natural frequency ``ω`` of the loaded contacts (as in the SciPy backend: a step over half
an oscillation can cross an event surface and come back unseen). The explicit tableaus (Tsit5,
Dopri5, Dopri8) are stepped by :class:`_Unrolled`, their stages unrolled at trace time (diffrax's
stage loop is ~10 times slower under ``vmap``); Kvaerno5 is diffrax's own.

Events. diffrax's :class:`~diffrax.Event` watches the minimum over all events of ``g_i / s_i``
(``s_i``: the scene's length, speed or force scale, by the kind of event) and stops the solve at
the end of the step in which the first one crosses zero downward; taking the minimum makes it the
*earliest* event even when several cross in one step (with a pytree of event functions diffrax
would report the first one in tree order). :meth:`_Core._locate` then finds every crossing on that
step's dense interpolant (bracketed Newton, to 1e-12 of the step), keeps the earliest (an event
that crossed and crossed back inside the step is past its surface there: the search is repeated
up to that root), and
polishes it on the integrator's own solution: it re-takes the step from its start to the root and
makes one Newton step on the event function there. Event times and states are thus as accurate as
the integrator's steps, not only as its interpolant (diffrax's Dopri8 interpolant is ~1000 times
less accurate than its steps).

Frame. Each segment is integrated in its own frame, as in the SciPy backend: positions from
where the vehicles are at its start, less the motion of the centre of mass (velocities less its
velocity; not with brakes), each contact's gap set to minus its deformation there
(:meth:`_Core._frame`). A deformation is then resolved to its own ulps, not to those of the
positions: after a metre of travel a near-plastic rebound (``e = 1e-6``, ``1e-12`` of the
deformation wide) lost most of its width to the rounding of the positions, accumulated over
the steps of the rebound.

Restart trap. diffrax fires a downward event when the value goes from ``> 0`` to ``<= 0``. An
event that starts a segment on (or a hair past) its surface, ``g_i / s_i <= 0``, is shifted to
start at exactly ``1e-12``: it fires only once the state moves ``1e-12`` (relative) further *into*
it (a contact that must close at once: a chain touching at rest), never because of round-off at the
restart on the surface just left (``D_max - D`` after the common velocity). An event that starts
ahead of its surface, however close, is left as it is: it fires when it is crossed (a rebound of
restitution 1e-6 is ``1e-12`` of the deformation wide).

float64 is switched on (``jax_enable_x64``) when this module is first imported, i.e. on first use
of ``method="diffrax"``, never at ``import lsc``.

Compilation. One compiled solver per scene *structure* (vehicle and contact counts, contact laws
and effects, table lengths), integrator, ``max_steps`` and ``max_events``; every number (masses,
speeds, curves, restitution, ``rtol``, ``atol``, ``t_end``) is a traced argument, so a scene whose
structure was compiled before runs without retracing. ``stats["compile_time"]`` [s] is the
compile time spent in that call (0 when cached), ``stats["wall_time"]`` [s] the run time of the
compiled solve (a solve of more than :data:`RECORD_NODES` steps in all runs again, with a
record of ``4 x max_steps`` nodes: both runs are counted). The sampled series of the :class:`~lsc.result.Result` come from the recorded steps:
a second, small compiled function re-takes each step once for its dense interpolant (compiled
once per power-of-two bucket of steps and samples).

Batches. :func:`solve_batch` vmaps the same loop (without the records) over a batch of parameters
and returns the Result metrics per member, with the Result's definitions (:mod:`lsc.impacts`):
the headline metrics over each vehicle's and contact's first impact, tracked in the loop's carry
(first touch and separation, the speeds then, the peaks folded only while that impact is
ongoing). Force and acceleration peaks are taken at the events and, where they can lie between
events (damping laws, braking, chains), at the extrema inside every step of the dense output.
(The scale of the pushed-shut test, :data:`lsc.impacts.PUSHED`, is the largest speed at t = 0
and at the events, where the Result takes it over its samples: they differ only for a scene
whose speeds peak between events, and then only for a closing speed at touch within a hair of
1e-6 of that scale.)
"""

from __future__ import annotations

import time

import numpy as np

import jax
from .. import jax_setup  # noqa: E402, F401  (the persistent compilation cache, before any compile)

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import optimistix as optx  # noqa: E402
from jax import lax  # noqa: E402

from ...contact import STATUS  # noqa: E402
from ...errors import SceneError, SimulationError  # noqa: E402
from ...impacts import PUSHED  # noqa: E402
from ...result import Event  # noqa: E402
from ..segments import Segment, build_result  # noqa: E402

__all__ = ["solve", "solve_batch", "INTEGRATORS", "BATCH_METRICS", "STATUS_CODES", "TRACES"]

INTEGRATORS = ("Tsit5", "Dopri5", "Dopri8", "Kvaerno5")

#: Where an event that starts a segment on or past its surface is moved (dimensionless: event
#: value over its scale).
EVENT_TOL = 1e-12
#: Most bracketed Newton iterations locating an event on a step's interpolant (they stop when the
#: root moves by less than ROOT_TOL of the step, or 4 ulps of the time: the polish, one Newton step
#: on the integrator's own solution, then squares that error away).
MAX_ROOT_ITERS = 64
ROOT_TOL = 1e-12
#: ... or when the event value (over its scale) is within this of zero.
ROOT_GTOL = 1e-14
#: Illinois iterations locating a force or acceleration peak inside a step (metrics solve).
PEAK_ITERS = 12
#: Chebyshev–Lobatto points of a step (as a fraction of it) at which its interpolant is sampled,
#: and their barycentric weights: exact for polynomials of degree < 10 (diffrax's interpolants of
#: these integrators have degree <= 7).
_THETA = 0.5 - 0.5 * np.cos(np.pi * np.arange(10) / 9)
_BARY = (-1.0) ** np.arange(10) * np.where((np.arange(10) == 0) | (np.arange(10) == 9), 0.5, 1.0)
#: The Chebyshev series (degree 9, on the step as [-1, 1]) through values at the _THETA points,
#: and the points where a step's event functions are evaluated from it to find a crossing
#: inside the step.
_CHEB_FIT = np.linalg.inv(np.polynomial.chebyshev.chebvander(2 * _THETA - 1, 9))
_DIP_POINTS = 129
_CHEB_DIP = np.polynomial.chebyshev.chebvander(np.linspace(-1.0, 1.0, _DIP_POINTS), 9)
#: ... and the series' derivative there (d/ds of the series on [-1, 1])
_CHEB_DIP_SLOPE = _CHEB_DIP[:, :9] @ np.polynomial.chebyshev.chebder(np.eye(10))
#: A bound on a series' second derivative on [-1, 1] per unit |coefficient|: |T_j''| <= j²(j²-1)/3
_CHEB_CURVATURE = np.arange(10.0) ** 2 * (np.arange(10.0) ** 2 - 1.0) / 3.0
#: The spacing of the dip points on [-1, 1]
_DIP_SPACING = 2.0 / (_DIP_POINTS - 1)


def dip_floor(coef, xp=np):
    """A lower bound, on [-1, 1], of each Chebyshev series (degree 9) of ``coef`` (10, n): its
    values at :data:`_DIP_POINTS` points, less nothing between two points where the slope
    shows it monotone (``|q'| > M h`` at both, of one sign), else ``M h²/8``, with
    ``M = Σ |c_j| j²(j²-1)/3`` a bound on ``|q''|`` and ``h`` the spacing (n,)."""
    q, dq = xp.asarray(_CHEB_DIP) @ coef, xp.asarray(_CHEB_DIP_SLOPE) @ coef
    curvature = xp.asarray(_CHEB_CURVATURE) @ xp.abs(coef)
    monotone = (dq[:-1] * dq[1:] > 0) & \
        (xp.minimum(xp.abs(dq[:-1]), xp.abs(dq[1:])) > curvature * _DIP_SPACING)
    lowest = xp.minimum(q[:-1], q[1:]) - xp.where(monotone, 0.0,
                                                  curvature * _DIP_SPACING ** 2 / 8)
    return xp.min(lowest, axis=0)


#: Longest step, in radians of the fastest natural oscillation of the frozen contacts (the SciPy
#: backend's ``MAX_ANGLE``): diffrax sees an event only at the ends of a step, so a step longer
#: than half an oscillation can cross an event surface and come back unseen (a rebound of
#: e = 1e-6 lasts 1e-6 of the compression), and an embedded error estimate over longer steps of
#: an oscillation is unreliable.
MAX_ANGLE = 0.5

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

#: Nodes of the dense record of a single solve at first (then ``4 x max_steps`` if it fills).
RECORD_NODES = 512

#: Trace counters, ``core`` and ``sampler`` (a Python side effect runs only while JAX traces).
TRACES = {"core": 0, "sampler": 0}

_SOLVERS = {"Tsit5": diffrax.Tsit5, "Dopri5": diffrax.Dopri5, "Dopri8": diffrax.Dopri8,
            "Kvaerno5": diffrax.Kvaerno5}

# The unit of each kind of event value (for its scale); any other kind: a length.
_EVENT_UNITS = {"vmax": "velocity", "turn": "velocity", "recompress": "velocity",
                "stop": "velocity", "break_forward": "force", "break_backward": "force",
                "failure": "force"}


def _event_unit(part, kind: str) -> str:
    if kind == "separate" and getattr(part, "name", "") == "kelvin":
        return "force"  # k D + c Ḋ
    return _EVENT_UNITS.get(kind, "length")


# ---------------------------------------------------------------------------- helpers
def _structure(model) -> tuple:
    """Hashable structure of a model: what the traced code branches on (no numbers)."""
    parts = []
    for part in model.parts:
        attrs = tuple(sorted((k, v) for k, v in vars(part).items()
                             if isinstance(v, (bool, int, str, np.integer, np.bool_))))
        parts.append((type(part).__name__, attrs))
    leaves, tree = jax.tree_util.tree_flatten(model.params)
    return (model.N, model.K, model.n_state, tuple(parts), str(tree),
            tuple(np.shape(a) for a in leaves))


def _canon(disc):
    """The discrete state with fixed dtypes (int32 / float64, never weak), for loop carries."""
    def one(a):
        a = jnp.asarray(a)
        dt = jnp.int32 if jnp.issubdtype(a.dtype, jnp.integer) else (
            jnp.bool_ if a.dtype == jnp.bool_ else jnp.float64)
        return lax.convert_element_type(a, dt)
    return jax.tree_util.tree_map(one, disc)


def _flat(disc):
    """A discrete state as one float64 vector (its integer codes are exact in float64)."""
    return jnp.concatenate([jnp.ravel(a).astype(jnp.float64)
                            for a in jax.tree_util.tree_leaves(disc)])


def _unflat(rows, like):
    """The discrete states in the rows ``(n, L)`` of ``rows``, structured and typed as ``like``."""
    leaves, tree = jax.tree_util.tree_flatten(like)
    return jax.tree_util.tree_unflatten(
        tree, [rows[..., i].astype(a.dtype) for i, a in enumerate(leaves)])


def _time_scale(p, keys):
    """``HybridModel.time_scale`` in jnp: the lightest pair on the stiffest of the contacts'
    slopes named by ``keys`` [s]."""
    m = p["m"]
    mu = jnp.min(m[:-1] * m[1:] / (m[:-1] + m[1:]))
    slopes = [jnp.abs(jnp.reshape(c[key], (-1,))) for c in p["contacts"]
              for key in keys if key in c]
    k = jnp.max(jnp.concatenate([jnp.where(jnp.isfinite(s), s, 0.0) for s in slopes])) \
        if slopes else jnp.asarray(0.0)
    return jnp.sqrt(mu / jnp.where(k > 0, k, 1.0))


def _scales(p):
    """Speed [velocity], contact time [s] and force [force] scales (the first two as
    HybridModel.v_scale and time_scale; the force one ``μ v / t``, the linear F_max), and the
    contact time of the loading slopes alone [s] (``time_scale(loading=True)``)."""
    v = p["v0"]
    v_scale = jnp.maximum(jnp.maximum(jnp.max(jnp.abs(v)), jnp.max(jnp.abs(jnp.diff(v)))), 1e-300)
    m = p["m"]
    mu = jnp.min(m[:-1] * m[1:] / (m[:-1] + m[1:]))
    t_scale = _time_scale(p, ("ls", "su", "k"))
    return v_scale, t_scale, mu * v_scale / t_scale, _time_scale(p, ("ls", "k"))


def _law_status(disc):
    """First nonzero law status code over the contacts' states (0 if none), and that contact."""
    st = jnp.stack([d["status"] for d in disc])
    k = jnp.argmax(st != 0)
    return st[k].astype(jnp.int32), k.astype(jnp.int32)


def _bucket(n: int, least: int) -> int:
    """Next power of two >= max(n, least): few array shapes, few sampler compiles."""
    n = max(int(n), int(least), 1)
    return 1 << (n - 1).bit_length()


def _f64(x):
    return np.asarray(x, dtype=np.float64)


def _numpy(tree):
    return jax.tree_util.tree_map(np.asarray, tree)


def _with_tols(solver, rtol, atol):
    """An implicit solver with the tolerances diffeqsolve would give its root finder."""
    if isinstance(solver, diffrax.AbstractImplicitSolver):
        solver = eqx.tree_at(lambda s: (s.root_finder.rtol, s.root_finder.atol, s.root_finder.norm),
                             solver, (rtol, atol, optx.rms_norm))
    return solver


def _fold(peaks, F, a):
    """Running peaks: the largest force (K,) and the signed largest acceleration (N,)."""
    pF, pa = peaks
    return jnp.maximum(pF, F), jnp.where(jnp.abs(a) > jnp.abs(pa), a, pa)


class _Wrapping(diffrax.AbstractAdaptiveSolver):
    """A solver that takes its terms, interpolant and orders from the solver it wraps."""

    solver: diffrax.AbstractSolver

    @property
    def term_structure(self):
        return self.solver.term_structure

    @property
    def interpolation_cls(self):  # pyright: ignore
        return self.solver.interpolation_cls

    @property
    def term_compatible_contr_kwargs(self):
        return self.solver.term_compatible_contr_kwargs

    def order(self, terms):
        return self.solver.order(terms)

    def error_order(self, terms):
        return self.solver.error_order(terms)

    def func(self, terms, t0, y0, args):
        return self.solver.func(terms, t0, y0, args)


class _Unrolled(_Wrapping):
    """An explicit Runge–Kutta step of a diffrax solver's own Butcher tableau, interpolant, order
    and error estimate, with its stages unrolled at trace time.

    diffrax runs the stages of a step in a loop over a stage buffer (the stage count varies
    with FSAL on the first step); under ``vmap`` that loop's predicate is batched and every stage
    copies the whole buffer of every member: a vmapped Dopri8 step cost ~10 times more than the
    same arithmetic unrolled (measured: 3.2 vs 0.34 µs per member and step on 4096 members).
    Zero tableau coefficients are skipped; FSAL (the last stage is ``f(t1, y1)``) is kept in the
    solver state as diffrax does. The result is diffrax's step up to rounding."""

    solver: diffrax.AbstractERK

    def init(self, terms, t0, t1, y0, args):
        return terms.vf(t0, y0, args) if self.solver.tableau.fsal else None

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        tab = self.solver.tableau
        dt = terms.contr(t0, t1)
        f = solver_state if tab.fsal else terms.vf(t0, y0, args)
        ks = [terms.prod(f, dt)]
        z = y0
        for c, row in zip(tab.c, tab.a_lower):
            z = y0
            for a, k in zip(row, ks):
                if a != 0:
                    z = z + float(a) * k
            f = terms.vf(t0 + float(c) * dt, z, args)
            ks.append(terms.prod(f, dt))
        if tab.ssal:
            y1 = z
        else:
            y1 = y0
            for b, k in zip(tab.b_sol, ks):
                if b != 0:
                    y1 = y1 + float(b) * k
        err = sum(float(b) * k for b, k in zip(tab.b_error, ks) if b != 0)
        dense = dict(y0=y0, y1=y1, k=jnp.stack(ks))
        return y1, err, dense, (f if tab.fsal else None), diffrax.RESULTS.successful

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)


class _Stash(_Wrapping):
    """A solver that keeps its last accepted step ``(t0, t1, y0, dense info)`` in its state
    (diffrax keeps the old state on a rejected step): what :meth:`_Core._locate` works on.

    With ``peaks`` (a function ``(t0, t1, lo, hi, dense, args) -> (F, a)``, the peaks on
    ``[lo, hi]`` of a step's interpolant) it also folds the peaks of every accepted step but the
    last into its state (the last one may run past the event). With ``hidden`` (a function
    ``(t0, t1, y1, dense, args) -> bool``: an armed event crosses zero and back inside the step,
    :meth:`_Core._hidden`) it rejects such a step (infinite error: the controller retries it
    shorter), so that no step is accepted across a crossing its ends do not show."""

    solver: diffrax.AbstractSolver
    peaks: object = eqx.field(static=True, default=None)
    point: object = eqx.field(static=True, default=None)
    hidden: object = eqx.field(static=True, default=None)

    def init(self, terms, t0, t1, y0, args):
        inner = self.solver.init(terms, t0, t1, y0, args)
        _, _, dense, _, _ = eqx.filter_eval_shape(self.solver.step, terms, t0, t1, y0, args,
                                                  inner, False)
        dense = jax.tree_util.tree_map(lambda a: jnp.zeros(a.shape, a.dtype), dense)
        t0 = jnp.asarray(t0)
        peaks = None if self.peaks is None else self.point(y0, args)
        return inner, t0, t0, y0, dense, peaks

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        inner, tp, tb, _, dp, peaks = solver_state
        y1, err, dense, inner, result = self.solver.step(terms, t0, t1, y0, args, inner,
                                                         made_jump)
        if self.hidden is not None:
            # an event that crosses and crosses back inside the step: reject it (the
            # controller shortens it, until a step ends past the event's surface)
            err = jnp.where(self.hidden(t0, t1, y1, dense, args), jnp.inf, err)
        if self.peaks is not None:  # the previous step is not the last: fold it in
            F, a = self.peaks(tp, tb, tp, tb, dp, args)
            folded = _fold(peaks, F, a)
            peaks = jax.tree_util.tree_map(lambda u, v: jnp.where(tb > tp, u, v), folded, peaks)
        dt = tp.dtype
        return y1, err, dense, (inner, jnp.asarray(t0, dt), jnp.asarray(t1, dt), y0, dense,
                                peaks), result


class _Compiled:
    """A jitted function and its ahead-of-time compiled executables, keyed by argument shapes
    (so that compile time is measured apart from run time)."""

    def __init__(self, fn):
        self.fn = jax.jit(fn)
        self.exe = {}

    def __call__(self, *args):
        leaves, tree = jax.tree_util.tree_flatten(args)
        key = (tree, tuple((np.shape(a), np.asarray(a).dtype.str) for a in leaves))
        compile_time = 0.0
        if key not in self.exe:
            t0 = time.perf_counter()
            self.exe[key] = self.fn.lower(*args).compile()
            compile_time = time.perf_counter() - t0
        # run through the jitted function: its C++ dispatch is several times cheaper than an
        # AOT executable's, and it finds the executable just compiled (no retrace, no compile)
        t0 = time.perf_counter()
        out = jax.block_until_ready(self.fn(*args))
        return out, compile_time, time.perf_counter() - t0


def _frame_of(t0, x0, V, p):
    """A segment's frame from its start time ``t0``, the positions ``x0`` (N,) there and ``V``:
    the segment's parameters, ``to_abs(t, u)`` and ``to_frame(t, y)`` (states (..., n) at times
    (...)); see :meth:`_Core._frame`."""
    N = x0.shape[0]
    pf = dict(p, gap=-(x0[:-1] - x0[1:] - p["gap"]))

    def shift(t):
        return x0 + V * (jnp.asarray(t)[..., None] - t0)

    def to_abs(t, u):
        return u.at[..., :N].add(shift(t)).at[..., N:2 * N].add(V)

    def to_frame(t, y):
        return y.at[..., :N].add(-shift(t)).at[..., N:2 * N].add(-V)
    return pf, to_abs, to_frame


# ---------------------------------------------------------------------------- the solver
class _Core:
    """The compiled segment loop for one scene structure and one set of static options."""

    def __init__(self, model, integrator: str, max_steps: int, max_events: int,
                 capacity: int | None = None):
        self.model = model  # any model of this structure: only its structure is used in traces
        self.integrator = integrator
        base = _SOLVERS[integrator]()
        # explicit tableaus: unrolled stages (diffrax's own loop is slow under vmap)
        self.solver = _Unrolled(base) if isinstance(base, diffrax.AbstractERK) else base
        self.max_steps = int(max_steps)
        self.max_events = int(max_events)
        # nodes of the dense record, over the whole solve
        self.capacity = 4 * self.max_steps if capacity is None else int(capacity)
        self.term = diffrax.ODETerm(self._vf)
        # stops at the end of the step where the first event crosses; _locate finds the root
        self.event = diffrax.Event(self._cond, None, direction=False)
        units = [_event_unit(model.parts[j], model.parts[j].event_kinds[w])
                 for j, w in model.events]
        self.ev_unit = np.array([{"length": 0, "velocity": 1, "force": 2}[u] for u in units])
        self.fail_contacts = [f.k for f in model.failures]
        # contacts whose law follows a post-failure curve and reports the failure itself
        self.fail_laws = [k for k, law in enumerate(model.laws) if getattr(law, "fails", False)]
        # forces and accelerations can peak between events (damping laws, braking, chains): the
        # metrics solve then searches every step for them; two-car IF-D peaks are at events
        self.interior = (model.N > 2 or bool(model.brakes)
                         or any(type(law).__name__ != "HysteresisLaw" for law in model.laws))
        self.branches = [self._branch(i) for i in range(len(model.events))]
        self.disc_like = jax.eval_shape(lambda p: _canon(model.initial(p, jnp)[1]), model.params)
        self.single = _Compiled(lambda p, rtol, atol, t_end, horizon:
                                self._run(p, rtol, atol, t_end, horizon, True))
        self.sampler = _Compiled(self._sample)
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
        def transition(t, y, disc, p):
            return _canon(self.model.apply_event(i, t, y, disc, p, jnp))
        return transition

    def _frame(self, t0, y, p):
        """The coordinates a segment starting at ``(t0, y)`` is integrated in (as the SciPy
        backend's ``_Frame``): positions from where the vehicles are at ``t0``, less the motion of
        the centre of mass ``V (t - t0)`` (``V = 0`` with brakes, which need each vehicle's own
        velocity), velocities less ``V``; contact ``k``'s gap becomes ``-D0_k`` so that its
        deformation is ``D0_k + (u_k - u_{k+1})``, resolved to its own ulps, not the positions'.
        Returns the frame state, the segment's parameters, ``to_abs(t, u)`` (``u``: (n,) or
        (B, n) at times (B,)) and ``V``."""
        N = self.model.N
        V = jnp.asarray(0.0) if self.model.brakes else jnp.sum(p["m"] * y[N:2 * N]) / jnp.sum(p["m"])
        pf, to_abs, _ = _frame_of(t0, y[:N], V, p)
        return y.at[:N].set(0.0).at[N:2 * N].add(-V), pf, to_abs, V

    def _apart(self, t, y, disc, p, v_scale, horizon):
        """HybridModel.contacts_apart in jnp: every contact open, none closing again before
        ``horizon`` [s] (the crash horizon)."""
        return self.model.contacts_apart(y, disc, t, horizon, p, jnp, v_scale)

    def _dtmax(self, disc, p):
        """Longest step [s] in discrete state ``disc``: ``MAX_ANGLE / ω`` for the Gershgorin bound
        ``ω`` of :meth:`HybridModel.natural_frequency` (``inf`` when no contact is loaded)."""
        w = self.model.natural_frequency(disc, p, jnp)
        return jnp.where(w > 0, MAX_ANGLE / jnp.where(w > 0, w, 1.0), jnp.inf)

    def _point(self, y, args):
        """Contact forces (K,) and accelerations (N,) at state ``y``."""
        F, _, a = self.model.accelerations(y, args[0], args[1], jnp)
        return F, a

    def _peaks(self, t0, t1, lo, hi, dense, args):
        """The peaks of force (K,) and acceleration (N,) on ``[lo, hi]`` of the interpolant of the
        step ``[t0, t1]``: at ``hi`` and at the interior extrema, where ``dq/dt`` changes sign
        (located by the Illinois method on ``dq/dt``)."""
        K = self.model.K
        h = jnp.where(t1 > t0, t1 - t0, 1.0)
        interp = self.solver.interpolation_cls(t0=t0, t1=t0 + h, **dense)

        def q(t):
            F, a = self._point(interp.evaluate(t), args)
            return jnp.concatenate([F, a])

        def qd(t):
            return jax.jvp(q, (t,), (jnp.ones_like(t),))

        q_hi, d_hi = qd(hi)
        _, d_lo = qd(lo)
        nq = q_hi.size
        inside = d_lo * d_hi < 0
        idx = jnp.arange(nq)

        def illinois(_, c):
            a, b, fa, fb = c
            tm = jnp.clip(jnp.where(fb != fa, (a * fb - b * fa) / jnp.where(fb != fa, fb - fa, 1.0),
                                    0.5 * (a + b)), jnp.minimum(a, b), jnp.maximum(a, b))
            fm = jax.vmap(lambda t, i: qd(t)[1][i])(tm, idx)
            same = fm * fb > 0  # the root lies between a and tm
            a, fa = jnp.where(same, a, b), jnp.where(same, 0.5 * fa, fb)
            return a, tm, fa, fm

        init = (jnp.full(nq, lo), jnp.full(nq, hi), d_lo, d_hi)
        _, t_ext, _, _ = lax.fori_loop(0, PEAK_ITERS, illinois, init)
        q_ext = jax.vmap(lambda t, i: q(t)[i])(jnp.where(inside, t_ext, hi), idx)
        F, a = _fold((q_hi[:K], q_hi[K:]), q_ext[:K], q_ext[K:])
        return F, a

    def _last_peaks(self, tp, te, yp, args):
        """The peaks on the last step of a segment, ``[tp, te]`` (``te``: the located event;
        start state ``yp``): the step is re-taken from ``tp`` to ``te`` for an interpolant that
        ends on the integrator's own state there. (The interpolant of the whole step is less
        accurate than the located event state, by ~1e-10 relative with Dopri8 at rtol 1e-12: a
        peak reached at the event, a common velocity, read off it was off by that much, and its
        derivative by up to ~1e-6 relative.)"""
        a2 = args[:2]
        dense = self.solver.step(self.term, tp, te, yp, a2,
                                 self.solver.init(self.term, tp, te, yp, a2), False)[2]
        return self._peaks(tp, te, tp, te, dense, args)

    def _over(self, t, y, disc, p, v_scale, horizon):
        """HybridModel.is_over in jnp: contacts apart and no braked vehicle sliding."""
        m = self.model
        apart = self._apart(t, y, disc, p, v_scale, horizon)
        for st in disc[m.K: m.K + len(m.brakes)]:
            apart = apart & (st["mode"] == 0)
        return apart

    def _hidden(self, t0, t1, y1, dense, args):
        """Whether an armed event crosses zero and back inside the step ``[t0, t1]`` unseen at its
        ends: its value over its scale is positive at the end (on the integrator's state ``y1``)
        and may be below ``-depth`` inside. Along the step's interpolant (a polynomial of degree
        < 10) an event function linear in the state is a polynomial ``q`` of that degree: its
        Chebyshev series is fitted exactly at the :data:`_THETA` points and evaluated, with its
        slope, at :data:`_DIP_POINTS` points across the step. Between two neighbouring points
        (``h`` apart on [-1, 1]) ``|q''| <= M = Σ |c_j| j²(j²-1)/3``, so ``q`` is monotone there
        where ``|q'| > M h`` at a point (its least value is then a sampled one), and otherwise
        at least the lower sampled value less ``M h²/8``: a dip below ``-depth`` cannot hide
        between the points. A step where one may be inside is rejected (retried shorter);
        the bound tightens as the square of the step. An event that is not linear in the state
        (a brake or failure watching a Hunt–Crossley or Brach force) is a smooth function, not
        a polynomial, along the step: its values are lowered by the fit's error bound (twice its
        last four coefficients, as the SciPy backend's ``tail_bound``)."""
        disc, p, off, sc, armed, depth = args
        h = jnp.where(t1 > t0, t1 - t0, 1.0)
        interp = self.solver.interpolation_cls(t0=t0, t1=t0 + h, **dense)
        ys = jax.vmap(interp.evaluate)(t0 + jnp.asarray(_THETA) * h)
        g = jax.vmap(lambda y: self.model.event_values(t0, y, disc, p, jnp))(ys) / sc + off
        coef = jnp.asarray(_CHEB_FIT) @ g                       # (10, events)
        low = dip_floor(coef, jnp)
        nonlinear = ~np.asarray(self.model.event_linear, bool)
        if nonlinear.any():
            low = low - jnp.where(nonlinear, 2.0 * jnp.sum(jnp.abs(coef[-4:]), axis=0), 0.0)
        g_end = self.model.event_values(t1, y1, disc, p, jnp) / sc + off
        return jnp.any((g_end > 0) & (low < -depth)) & armed & (t1 > t0)

    def _locate(self, solver, tp, tb, yp, dense, args):
        """The earliest event in the last step ``[tp, tb]`` (start state ``yp``): ``(t*, y*, i)``.

        On the step's dense interpolant each event that crossed (``g_i(tb) <= 0``; all are
        ``> 0`` at ``tp``) is located by Newton's method kept inside its bracket (regula falsi
        start, bisection when Newton leaves the bracket); the earliest root wins, unless another
        event is already past its surface there (it crossed and came back within the step): then
        the search is repeated up to that root. Polish: re-take
        the step from ``tp`` to it, then one Newton step ``δ = -g/ġ`` (``ġ = ∇g·f``) with
        ``y* = y + δ f + δ²/2 f'``: the interpolant's error moves the root by a tiny ``δ``, so
        the remainder is below round-off.
        """
        m, term = self.model, self.term
        disc, p, off, sc = args[:4]
        interp = solver.interpolation_cls(t0=tp, t1=tb, **dense)
        n = len(m.events)

        def g_all(t):
            return m.event_values(t, interp.evaluate(t), disc, p, jnp) / sc + off

        def g_dg(t, i):
            return jax.jvp(lambda s: g_all(s)[i], (t,), (jnp.ones_like(t),))

        ga = g_all(tp)

        def roots_before(tc):
            """The root of every event that crossed by ``tc`` (``g_i(tc) <= 0``), else inf."""
            gb = g_all(tc)
            crossed = gb <= 0
            t_start = jnp.clip(tp + (tc - tp) * ga / jnp.where(crossed, ga - gb, 1.0), tp, tc)
            tol = jnp.maximum(ROOT_TOL * (tc - tp), 8.9e-16 * jnp.abs(tc))

            def newton(carry):
                a, b, t, _, k = carry
                g, dg = jax.vmap(g_dg)(t, jnp.arange(n))
                a = jnp.where(g > 0, t, a)
                b = jnp.where(g > 0, b, t)
                newton_t = t - g / jnp.where(dg != 0, dg, 1.0)
                inside = (dg != 0) & (newton_t > a) & (newton_t < b)
                # done: on the surface to ROOT_GTOL (a crossing that grazes it has a time that
                # is ill-conditioned, but a state that is not), or a Newton step below tol
                done = ~crossed | (jnp.abs(g) <= ROOT_GTOL) | (jnp.abs(g) <= tol * jnp.abs(dg))
                # Newton inside the bracket, else bisection (unless done: then stay)
                tn = jnp.where(inside, newton_t, jnp.where(done, t, 0.5 * (a + b)))
                tn = jnp.where((g == 0) | ~crossed, t, tn)
                return a, b, tn, jnp.any(~done), k + 1

            def going(carry):
                return carry[3] & (carry[4] < MAX_ROOT_ITERS)

            init = (jnp.full(n, tp), jnp.full(n, tc), t_start, jnp.asarray(True), 0)
            roots = lax.while_loop(going, newton, init)[2]
            return jnp.where(crossed, roots, jnp.inf)

        # An event can cross and cross back inside the step (a table breakpoint just below the
        # max deformation, crossed on the way up and down in the step that holds the common
        # velocity: its sign at the step's end says nothing). Each is past its surface at the
        # earliest root found (D_max is past the breakpoint): search again up to that root, until
        # the earliest root stays put.
        def past(roots):
            """Whether an event other than the earliest found is past its surface there."""
            te = jnp.min(roots)
            g = g_all(jnp.where(jnp.isfinite(te), te, tb))
            return jnp.any((g <= 0) & (jnp.arange(n) != jnp.argmin(roots))) & jnp.isfinite(te)

        def again(c):
            roots, _, k = c
            new = roots_before(jnp.min(roots))
            earlier = jnp.min(new) < jnp.min(roots)
            new = jnp.where(earlier, new, roots)
            return new, earlier & past(new), k + 1

        roots = roots_before(tb)
        roots = lax.while_loop(lambda c: c[1] & (c[2] <= n), again, (roots, past(roots), 0))[0]
        i = jnp.argmin(roots).astype(jnp.int32)
        te = jnp.clip(roots[i], tp, tb)
        # polish on the integrator's own step
        a2 = (disc, p)
        y1 = solver.step(term, tp, te, yp, a2, solver.init(term, tp, te, yp, a2), False)[0]
        f = lambda t, y: m.rhs(t, y, disc, p, jnp)  # noqa: E731
        f1, f2 = jax.jvp(f, (te, y1), (jnp.ones_like(te), f(te, y1)))
        def gi(y):
            return m.event_values(te, y, disc, p, jnp)[i] / sc[i] + off[i]
        g, gdot = jax.jvp(gi, (y1,), (f1,))
        gddot = jax.jvp(gi, (y1,), (f2,))[1]
        delta = jnp.clip(jnp.where(gdot != 0, -g / jnp.where(gdot != 0, gdot, 1.0), 0.0),
                         tp - te, tb - te)
        # only where the crossing is transversal on the scale of the step (the quadratic term
        # below the linear one): at a grazing root (a breakpoint that D_max touches exactly,
        # g' = 5e-13) -g/g' is a jump across the root (0.6 ms past the common velocity)
        delta = jnp.where(jnp.abs(delta * gddot) <= jnp.abs(gdot), delta, 0.0)
        return te + delta, y1 + delta * f1 + 0.5 * delta * delta * f2, i

    # -- the solve
    def _run(self, p, rtol, atol, t_end, horizon, record: bool):
        """The whole hybrid solve. ``t_end``, ``horizon`` [s]: NaN when not given (the horizon:
        when a contact that has not separated is an error; default ``1e6`` contact times).
        ``record``: keep events, segments and step nodes for a Result (single solves); else only
        the metrics (batches)."""
        TRACES["core"] += 1
        m = self.model
        N, K, E, S, C, n = m.N, m.K, self.max_events, self.max_steps, self.capacity, m.n_state
        v_scale, t_scale, f_scale, t_load = _scales(p)
        sc = jnp.stack([v_scale * t_scale, v_scale, f_scale])[jnp.asarray(self.ev_unit)]
        rv = rtol * v_scale  # default atol: positions, velocities, work integrals (as SciPy)
        own_atol = ~jnp.isnan(atol)
        atol = jnp.where(own_atol, atol, jnp.concatenate([
            jnp.full(N, rv * t_load), jnp.full(N, rv),
            jnp.full(n - 2 * N, rv * v_scale * jnp.min(p["m"]))]))
        atol = jnp.broadcast_to(atol, (n,))

        def segment_atol(disc):
            """Positions to ``rtol`` of the active pieces' own scale (HybridModel.position_time:
            a near-plastic rebound line's width), unless the atol was given."""
            x_tol = rv * m.position_time(disc, t_load, p, jnp)
            return jnp.where(own_atol, atol, atol.at[:N].set(x_tol))

        # a dip inside a step less deep than this (over each event's scale) only touches the
        # surface (as the SciPy backend's: 100 rtol, the global error of a deformation)
        depth = jnp.maximum(EVENT_TOL, 100 * rtol)
        has_t_end = ~jnp.isnan(t_end)
        crash = jnp.where(jnp.isnan(horizon), 1e6 * t_scale + 1.0, horizon)
        horizon = jnp.where(has_t_end, t_end, crash)
        # a contact that would close again only after this has no crash left in it
        over_by = jnp.where(has_t_end, jnp.maximum(crash, t_end), crash)
        inner = _with_tols(self.solver, rtol, atol)
        track = (not record) and self.interior
        stepper = _Stash(inner, self._peaks if track else None, self._point if track else None,
                         self._hidden)
        y0, disc0 = m.initial(p, jnp)
        disc0 = _canon(disc0)

        def contact_modes(disc):
            return jnp.stack([d["mode"] for d in disc[:K]])

        law0, lawk0 = _law_status(disc0[:K])
        c = {"t": jnp.asarray(0.0), "y": y0, "disc": disc0, "status": law0,
             "status_contact": lawk0, "n_ev": jnp.int32(0), "n_seg": jnp.int32(0),
             "finished": self._over(0.0, y0, disc0, p, v_scale, over_by) & ~has_t_end,
             "steps": jnp.int32(0), "rejected": jnp.int32(0)}
        if record:
            c.update({
                # per event: time, event index, state (n), discrete state after it (flat)
                "rec": jnp.zeros((E, 2 + n + _flat(disc0).size)),
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
            c.update(_first_impacts_init(closed0, y0[N:2 * N], F0, a0))
            c.update({"y_post": y0, "separated": False,
                      "separation_time": jnp.full(K, jnp.nan), "failure_time": fail_t})

        def body(c):
            t, disc = c["t"], c["disc"]
            y, pf, to_abs, v_frame = self._frame(t, c["y"], p)   # the segment's frame
            # (then free flight to t_end, events disarmed)
            over = self._over(t, y, disc, pf, v_scale, over_by)
            g0 = m.event_values(t, y, disc, pf, jnp) / sc
            off = jnp.where(g0 <= 0, EVENT_TOL - g0, 0.0)  # the restart trap
            args = (disc, pf, off, sc, ~over, depth)
            controller = diffrax.PIDController(rtol=rtol, atol=segment_atol(disc),
                                               dtmax=self._dtmax(disc, p))
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
            new = lax.switch(i, self.branches, tn, to_abs(tn, yn), disc, p)
            new = jax.tree_util.tree_map(lambda a, b: jnp.where(fired, a, b), new, disc)
            law, lawk = _law_status(new[:K])
            n_ev = c["n_ev"] + fired.astype(jnp.int32)
            at_end = has_t_end & (tn >= t_end)
            # reaching t_end with only braked vehicles still sliding is no failure (as SciPy)
            finished = (self._over(tn, yn, new, pf, v_scale, over_by)
                        & (~has_t_end | at_end)) | \
                (at_end & ~fired & self._apart(tn, yn, new, pf, v_scale, over_by))
            finite = jnp.all(jnp.isfinite(yn)) & jnp.isfinite(tn)
            status = jnp.select(
                [~ok, ~finite, law != 0, ~fired & ~over & ~finished, ~finished & (n_ev >= E)],
                [SOLVER_FAILED, NON_FINITE, law, jnp.where(has_t_end, T_END_EARLY, NO_EVENT),
                 MAX_EVENTS], 0).astype(jnp.int32)
            out = dict(c)
            yf, yn = yn, to_abs(tn, yn)   # (the frame's state, and the absolute one)
            out.update({
                "t": tn, "y": yn, "disc": new, "status": status,
                "status_contact": jnp.where(law != 0, lawk, c["status_contact"]),
                "finished": finished, "n_ev": n_ev, "n_seg": c["n_seg"] + 1,
                "steps": c["steps"] + nacc,
                "rejected": c["rejected"] + sol.stats["num_rejected_steps"].astype(jnp.int32)})
            if record:
                j, n0, e = c["n_seg"], c["n_nodes"], c["n_ev"]
                ts = jnp.where(jnp.isfinite(sol.ts), sol.ts, t)   # (unused rows: inf)
                saved = jnp.concatenate([sol.ts[:, None], to_abs(ts, sol.ys)], axis=1)
                saved = saved.at[last].set(jnp.where(nacc > 0, jnp.concatenate([tn[None], yn]),
                                                     saved[last]))
                block = jnp.concatenate([jnp.concatenate([t[None], c["y"]])[None], saved])
                row = jnp.concatenate([tn[None], i.astype(jnp.float64)[None], yn, _flat(new)])
                out.update({
                    "status": jnp.where((status == 0) & (n0 + 1 + nacc > C), RECORD_FULL, status),
                    "nodes": lax.dynamic_update_slice(c["nodes"], block, (n0, jnp.int32(0))),
                    "n_nodes": n0 + 1 + nacc,
                    "seg": lax.dynamic_update_slice(c["seg"], jnp.stack([n0, n0 + nacc, e])[None],
                                                    (j, jnp.int32(0))),
                    "frame": c["frame"].at[j].set(jnp.concatenate([c["y"][:N], v_frame[None]])),
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
                first = {key: c[key] for key in _FIRST_KEYS}
                ongoing = _ongoing(first)   # in this segment, up to the event (before it)
                first = _fold_first(first, Fb, ab, ongoing)
                if track:  # between the events: all steps, and the last one up to the event
                    first = _fold_first(first, *step_peaks, ongoing)
                    first = _fold_first(first, *self._last_peaks(tp, tn, yp, args), ongoing)
                first = _first_event(first, tn, yn[N:2 * N], closes, opens)
                first = _fold_first(first, Fa, aa, _ongoing(first))   # after the event
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
            out["disc0"] = _flat(disc0)
            out.update({k: c[k] for k in ("rec", "seg", "nodes", "n_nodes", "frame")})
        else:
            out.update(self._metrics(c, p))
        return out

    def _metrics(self, c, p):
        """The Result metrics from the final carry (as Result.build computes them): the headline
        metrics from each vehicle's and contact's first impact (:func:`_headline`), the records
        and ``v_final`` over the run."""
        m = self.model
        disc = c["disc"][: m.K]
        post = jnp.where(c["separated"], c["y_post"], c["y"])
        vf = post[m.N: 2 * m.N]
        rec = {key: jnp.stack([d[key] for d in disc]) for key in ("dmax", "dperm", "ec", "er")}
        out = _headline({key: c[key] for key in _FIRST_KEYS}, c["t"], c["y"][m.N: 2 * m.N])
        out.update({
            "v_final": vf,
            "max_deformation": rec["dmax"], "permanent_deformation": rec["dperm"],
            "restitution_energy": jnp.sqrt(rec["er"] / rec["ec"]),
            "energy_absorbed": rec["ec"], "energy_returned": rec["er"],
            "separation_time": c["separation_time"], "failure_time": c["failure_time"]})
        return out

    # -- the dense output of the recorded steps, for the sampled series
    def _sample(self, p, rtol, atol, discs, st0, st1, sy0, sdisc, sframe, sts):
        """The dense output of the steps ``[st0, st1]`` from ``sy0`` (B,), in discrete state
        ``discs[sdisc]``, at the :data:`_THETA` points of each step (B, len(_THETA), n): each step
        is re-taken once for its interpolant (a polynomial of degree < len(_THETA) in time), in
        its segment's frame (``sframe`` (B, N + 1): positions at the segment start ``sts`` (B,)
        and ``V``), as the solve took it."""
        TRACES["sampler"] += 1
        solver, term = _with_tols(self.solver, rtol, atol), self.term
        theta = jnp.asarray(_THETA)
        N = self.model.N

        def values(t0, t1, y0, d, fr, ts):
            pf, to_abs, to_frame = _frame_of(ts, fr[:N], fr[N], p)
            args = (_unflat(discs[d], self.disc_like), pf)
            u0 = to_frame(t0, y0)
            dense = solver.step(term, t0, t1, u0, args, solver.init(term, t0, t1, u0, args),
                                False)[2]
            h = jnp.where(t1 > t0, t1 - t0, 1.0)
            interp = solver.interpolation_cls(t0=t0, t1=t0 + h, **dense)
            tt = t0 + theta * h
            return to_abs(tt, jax.vmap(interp.evaluate)(tt))

        return jax.vmap(values)(st0, st1, sy0, sdisc, sframe, sts)

    def run_batched(self, axes, p, rtol, atol, t_end, horizon):
        """The metrics solve vmapped over the parameter leaves whose axis is 0 in ``axes``."""
        key = jax.tree_util.tree_flatten(axes, is_leaf=lambda x: x is None)
        key = (key[1], tuple(key[0]), np.ndim(horizon))
        fn = self.batched.get(key)
        if fn is None:
            fn = self.batched[key] = _Compiled(jax.vmap(
                lambda p, rtol, atol, t_end, horizon:
                self._run(p, rtol, atol, t_end, horizon, False),
                in_axes=(axes, None, None, None, 0 if np.ndim(horizon) else None)))
        return fn(p, rtol, atol, t_end, horizon)


# ---------------------------------------------------------------------------- first impacts
# The batch metrics follow lsc.impacts: an impact is one touch -> separation episode of one
# contact; the headline metrics are each contact's and each vehicle's FIRST impact. The carry
# holds, per contact k (vehicles k, k+1): its first touch ``contact_time`` and the velocities
# then ``v_touch`` (K, 2), its first separation ``first_end`` and the velocities then ``v_sep``
# (K, 2), the peak force ``peak_force`` (K,) and the signed peak accelerations ``peak_acc``
# (K, 2) over that impact; and ``v_max``, the largest speed at t = 0 and at the events (the
# scale of the pushed-shut test, lsc.impacts.PUSHED).
_FIRST_KEYS = ("contact_time", "v_touch", "first_end", "v_sep", "peak_force", "peak_acc",
               "v_max")


def _pairs(v):
    """(K, 2): the (rear, front) values of each contact's vehicles from per-vehicle ``v`` (N,)."""
    return jnp.stack([v[:-1], v[1:]], axis=1)


def _first_impacts_init(closed0, v0, F0, a0):
    """The first-impact carry at t = 0: contacts closed then (``closed0`` (K,)) touch at 0, at the
    initial speeds ``v0`` (N,), and their peaks start at the initial force and accelerations."""
    K = closed0.shape[0]
    return {"contact_time": jnp.where(closed0, 0.0, jnp.nan),
            "v_touch": jnp.where(closed0[:, None], _pairs(v0), jnp.nan),
            "first_end": jnp.full(K, jnp.nan), "v_sep": jnp.full((K, 2), jnp.nan),
            "peak_force": jnp.where(closed0, F0, 0.0),
            "peak_acc": jnp.where(closed0[:, None], _pairs(a0), 0.0),
            "v_max": jnp.max(jnp.abs(v0))}


def _ongoing(first):
    """(K,): whether each contact's first impact has begun and not ended."""
    return ~jnp.isnan(first["contact_time"]) & jnp.isnan(first["first_end"])


def _fold_first(first, F, a, ongoing):
    """Fold force (K,) and accelerations (N,) into the peaks of the first impacts ``ongoing``."""
    A = _pairs(a)
    return dict(first,
                peak_force=jnp.where(ongoing, jnp.maximum(first["peak_force"], F),
                                     first["peak_force"]),
                peak_acc=jnp.where(ongoing[:, None] & (jnp.abs(A) > jnp.abs(first["peak_acc"])),
                                   A, first["peak_acc"]))


def _first_event(first, t, v, closes, opens):
    """The first-impact carry after an event at time ``t`` with velocities ``v`` (N,), where the
    contacts ``closes`` (K,) touch and ``opens`` (K,) separate."""
    touch = closes & jnp.isnan(first["contact_time"])
    end = opens & _ongoing(first)
    V = _pairs(v)
    return dict(first,
                contact_time=jnp.where(touch, t, first["contact_time"]),
                v_touch=jnp.where(touch[:, None], V, first["v_touch"]),
                first_end=jnp.where(end, t, first["first_end"]),
                v_sep=jnp.where(end[:, None], V, first["v_sep"]),
                v_max=jnp.maximum(first["v_max"], jnp.max(jnp.abs(v))))


def _headline(first, t_last, v_last):
    """The headline metrics (as :meth:`lsc.Result._headline`) from the first-impact carry at the
    end of the run (time ``t_last``, velocities ``v_last`` (N,): the end of an impact still
    open). Per vehicle, its first impact is that of the adjacent contact that touched first
    (ties: the lower contact index); a vehicle in no impact has ``delta_v`` and
    ``peak_acceleration`` 0. ``duration``: the scene's first impact (0 if none)."""
    ct, t1 = first["contact_time"], first["first_end"]
    K = ct.shape[0]
    touched = ~jnp.isnan(ct)
    ended = ~jnp.isnan(t1)
    v_end = jnp.where(ended[:, None], first["v_sep"], _pairs(v_last))
    dv = jnp.where(touched[:, None], v_end - first["v_touch"], 0.0)
    closing = first["v_touch"][:, 0] - first["v_touch"][:, 1]
    struck = touched & (closing > PUSHED * first["v_max"])
    restitution = jnp.where(struck, (v_end[:, 1] - v_end[:, 0]) / jnp.where(struck, closing, 1.0),
                            jnp.nan)
    start = jnp.where(touched, ct, jnp.inf)
    # each vehicle: its rear contact (side 1) when that touched first, else its front (side 0)
    rear = jnp.concatenate([jnp.array([False]), start[:-1] <= start[1:], jnp.array([True])])
    k_rear, k_front = jnp.arange(K + 1) - 1, jnp.arange(K + 1)
    kv = jnp.clip(jnp.where(rear, k_rear, k_front), 0, K - 1)
    side = jnp.where(rear, 1, 0)
    hit = touched[kv]
    k1 = jnp.argmin(start)   # the scene's first impact (argmin: ties to the lower index)
    duration = jnp.where(touched[k1], jnp.where(ended[k1], t1[k1], t_last) - ct[k1], 0.0)
    return {"delta_v": jnp.where(hit, dv[kv, side], 0.0),
            "peak_acceleration": jnp.where(hit, first["peak_acc"][kv, side], 0.0),
            "peak_force": first["peak_force"], "restitution": restitution,
            "duration": duration, "contact_time": ct}


_CORES: dict = {}


def _core(model, integrator, max_steps, max_events, capacity=None) -> _Core:
    key = (_structure(model), integrator, int(max_steps), int(max_events), capacity)
    core = _CORES.get(key)
    if core is None:
        core = _CORES[key] = _Core(model, integrator, max_steps, max_events, capacity)
    return core


def _check(integrator, rtol, atol, max_steps, max_events):
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


# ---------------------------------------------------------------------------- single solves
class _Sampler:
    """The dense output of one solve: every recorded step's interpolant, sampled once (one
    compiled call) at the Chebyshev–Lobatto points :data:`_THETA` of the step, and evaluated in
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
        self.values = np.zeros((len(self.node_t), len(_THETA), self.node_y.shape[1]))
        if steps.size:
            B = _bucket(steps.size, 64)
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
        d = theta[:, None] - _THETA[None, :]
        hit = d == 0
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(hit, 0.0, _BARY / np.where(hit, 1.0, d))
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


def solve(model, *, integrator: str = "Dopri8", rtol: float = 1e-10, atol=None, t_end=None,
          max_steps: int = 2048, max_events: int = 256, n_samples: int = 1000):
    """Solve ``model`` with diffrax (``integrator``: Tsit5, Dopri5, Dopri8, Kvaerno5).

    ``rtol`` and ``atol`` as in the SciPy backend (``atol`` default: ``rtol`` times the speed
    scale, times the contact time scale [s] for positions and times the speed scale and the
    smallest mass for work integrals); ``t_end`` [s]: simulate until then; ``max_steps``: most
    steps in one segment; ``max_events``: most events in one solve.
    """
    _check(integrator, rtol, atol, max_steps, max_events)
    p = jax.tree_util.tree_map(_f64, model.params)
    horizon = float(model.horizon()) if hasattr(model, "horizon") else np.nan
    args = (p, _f64(rtol), _f64(np.nan if atol is None else atol),
            _f64(np.nan if t_end is None else t_end),
            _f64(horizon if np.isfinite(horizon) else np.nan))
    # a small dense record first (most solves take a few dozen steps; a record sized for
    # 4 x max_steps made the compiled solve ~25% slower); a solve that fills it runs again with
    # the full one
    compile_time = wall = 0.0
    for capacity in (min(RECORD_NODES, 4 * int(max_steps)), None):
        core = _core(model, integrator, max_steps, max_events, capacity)
        out, ct, w = core.single(*args)
        compile_time, wall = compile_time + ct, wall + w
        if capacity is None or int(out["status"]) != RECORD_FULL:
            break
    out = _numpy(out)
    status, t_stop, E, n = int(out["status"]), float(out["t"]), int(out["events"]), model.n_state
    rec = out["rec"]  # (max_events, ...): a fixed shape for the sampler
    discs = np.concatenate([out["disc0"][None], rec[:, 2 + n:]])
    states = [model.to_python(_unflat(row, core.disc_like)) for row in discs[:E + 1]]
    if status:
        if status in STATUS:
            model.check_status(states[-1], t_stop)
        raise SimulationError(f"diffrax {integrator}, t = {t_stop:.6g} s: {STATUS_CODES[status]}")
    events = [Event(0.0, "contact", k) for k, st in enumerate(states[0][: model.K]) if st["mode"]]
    y_post = None  # the state at the last separation (braked vehicles may slide on after it)
    for e in range(E):
        i = int(rec[e, 1])
        name = model.event_name(i, states[e], states[e + 1])
        events.append(Event(float(rec[e, 0]), name, model.event_index(i)))
        if "separation" in name:
            y_post = rec[e, 2:2 + n]
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
             "compile_time": compile_time + sampler.compile_time}
    return build_result(model, segments, events, out["y"], states[-1],
                        method=f"diffrax-{integrator}", tolerances={"rtol": rtol, "atol": atol},
                        stats=stats, n_samples=n_samples, y_post=y_post)


# ---------------------------------------------------------------------------- batches
#: The metrics :func:`solve_batch` returns (as on a Result; ``peak_acceleration_g`` uses ``g``).
BATCH_METRICS = ("delta_v", "v_final", "peak_acceleration", "peak_acceleration_g", "duration",
                 "max_deformation", "permanent_deformation", "peak_force", "restitution",
                 "restitution_energy", "energy_absorbed", "energy_returned", "contact_time",
                 "separation_time", "failure_time")


def solve_batch(model, params_batch, *, integrator: str = "Dopri8", rtol: float = 1e-10,
                atol=None, t_end=None, max_steps: int = 2048, max_events: int = 256, g=None,
                horizon=None):
    """Solve many scenes of ``model``'s structure in one vmapped compiled call.

    ``params_batch`` has the structure of ``model.params``; a leaf with one more leading axis than
    in ``model.params`` is batched (size B, the same for all), the others are shared (the initial
    state follows from ``v0``). Returns NumPy arrays with a leading axis B: the metrics of
    :data:`BATCH_METRICS` (as a Result defines them: the headline metrics over the first impacts;
    NaN for a failed member), ``status`` (0 = ok, see
    :data:`STATUS_CODES`), ``message`` (list of str), ``steps``, ``segments``; and ``stats``
    (``compile_time``, ``wall_time`` [s], ``size``). Peaks of force and acceleration are taken
    at the events and, where they can lie between events (damping laws, braking, chains), at the
    extrema inside every step's dense output. ``horizon`` [s] (scalar or (B,)): when a contact
    still closed is an error (default: a million contact times of each member).
    """
    _check(integrator, rtol, atol, max_steps, max_events)
    core = _core(model, integrator, max_steps, max_events)
    base, tree = jax.tree_util.tree_flatten(model.params)
    leaves = tree.flatten_up_to(params_batch)
    axes, sizes = [], set()
    for b, a in zip(base, leaves):
        a = np.asarray(a)
        if a.ndim == np.ndim(b) + 1:
            axes.append(0)
            sizes.add(a.shape[0])
        elif a.shape == np.shape(b):
            axes.append(None)
        else:
            raise ValueError(f"a batched parameter has shape {a.shape}; expected {np.shape(b)} "
                             "or (B,) + that")
    if len(sizes) != 1:
        raise ValueError("params_batch needs at least one batched leaf, all of one batch size "
                         f"(got sizes {sorted(sizes)})")
    p = jax.tree_util.tree_unflatten(tree, [_f64(a) for a in leaves])
    out, compile_time, wall = core.run_batched(
        jax.tree_util.tree_unflatten(tree, axes), p, _f64(rtol),
        _f64(np.nan if atol is None else atol), _f64(np.nan if t_end is None else t_end),
        _f64(np.nan if horizon is None else horizon))
    out = _numpy(out)
    status = out["status"].astype(int)
    res = {name: np.array(out[name], float) for name in BATCH_METRICS if name in out}
    g = model.scene.g if g is None else g
    res["peak_acceleration_g"] = res["peak_acceleration"] / np.reshape(np.asarray(g, float),
                                                                       (-1, 1))
    for name in BATCH_METRICS:
        res[name][status != 0] = np.nan
    res["status"] = status
    res["message"] = [
        "ok" if s == 0 else (f"contact {k} at t = {t:.6g} s: " if s in STATUS else
                             f"diffrax {integrator}, t = {t:.6g} s: ") + STATUS_CODES[s]
        for s, k, t in zip(status, out["status_contact"].tolist(), out["t"].tolist())]
    res["steps"], res["segments"] = out["steps"], out["segments"]
    res["stats"] = {"compile_time": compile_time, "wall_time": wall, "size": sizes.pop()}
    return res
