"""The diffrax solvers the backend steps with, and the wrappers around them.

The explicit tableaus (Tsit5, Dopri5, Dopri8) are stepped by :class:`Unrolled`, their stages
unrolled at trace time (diffrax's stage loop is ~10 times slower under ``vmap``); Kvaerno5 is
diffrax's own. :class:`Stash` keeps the last accepted step for the event search, folds the
peaks of the steps (metrics solves) and rejects a step an event crosses unseen.
"""

from __future__ import annotations

from . import compiled  # noqa: F401  (float64 and the compilation cache, before diffrax)

import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import optimistix as optx  # noqa: E402

__all__ = ["INTEGRATORS", "SOLVERS", "with_tols", "fold_peaks", "Wrapping", "Unrolled",
           "Stash"]

INTEGRATORS = ("Tsit5", "Dopri5", "Dopri8", "Kvaerno5")
#: The diffrax solver class of each integrator name.
SOLVERS = {"Tsit5": diffrax.Tsit5, "Dopri5": diffrax.Dopri5, "Dopri8": diffrax.Dopri8,
           "Kvaerno5": diffrax.Kvaerno5}


def with_tols(solver, rtol, atol):
    """An implicit solver with the tolerances diffeqsolve would give its root finder."""
    if isinstance(solver, diffrax.AbstractImplicitSolver):
        solver = eqx.tree_at(lambda s: (s.root_finder.rtol, s.root_finder.atol, s.root_finder.norm),
                             solver, (rtol, atol, optx.rms_norm))
    return solver


def fold_peaks(peaks, F, a):
    """Running peaks: the largest force (K,) and the signed largest acceleration (N,)."""
    pF, pa = peaks
    return jnp.maximum(pF, F), jnp.where(jnp.abs(a) > jnp.abs(pa), a, pa)


class Wrapping(diffrax.AbstractAdaptiveSolver):
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


class Unrolled(Wrapping):
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


class Stash(Wrapping):
    """A solver that keeps its last accepted step ``(t0, t1, y0, dense info)`` in its state
    (diffrax keeps the old state on a rejected step): what
    :meth:`~.dips.EventSearch._locate` works on.

    With ``peaks`` (a function ``(t0, t1, lo, hi, dense, args) -> (F, a)``, the peaks on
    ``[lo, hi]`` of a step's interpolant) it also folds the peaks of every accepted step but the
    last into its state (the last one may run past the event). With ``hidden`` (a function
    ``(t0, t1, y1, dense, args) -> bool``: an armed event crosses zero and back inside the step,
    :meth:`~.dips.EventSearch._hidden`) it rejects such a step (infinite error: the controller
    retries it shorter), so that no step is accepted across a crossing its ends do not show."""

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
            folded = fold_peaks(peaks, F, a)
            peaks = jax.tree_util.tree_map(lambda u, v: jnp.where(tb > tp, u, v), folded, peaks)
        dt = tp.dtype
        return y1, err, dense, (inner, jnp.asarray(t0, dt), jnp.asarray(t1, dt), y0, dense,
                                peaks), result
