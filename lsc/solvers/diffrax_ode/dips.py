"""Events inside a step: the Chebyshev fit of a step's event values, the bound on a dip between
its sample points (:func:`dip_floor`), and the search for the earliest event of a step
(:class:`EventSearch`).

diffrax's :class:`~diffrax.Event` watches the minimum over all events of ``g_i / s_i`` (``s_i``:
the scene's length, speed or force scale, by the kind of event) and stops the solve at the end of
the step in which the first one crosses zero downward; taking the minimum makes it the
*earliest* event even when several cross in one step (with a pytree of event functions diffrax
would report the first one in tree order). :meth:`EventSearch._locate` then finds every crossing
on that step's dense interpolant (bracketed Newton, to 1e-12 of the step), keeps the earliest (an
event that crossed and crossed back inside the step is past its surface there: the search is
repeated up to that root), and polishes it on the integrator's own solution: it re-takes the
step from its start to the root and makes one Newton step on the event function there. Event
times and states are thus as accurate as the integrator's steps, not only as its interpolant
(diffrax's Dopri8 interpolant is ~1000 times less accurate than its steps).
"""

from __future__ import annotations

import numpy as np

from . import compiled  # noqa: F401  (float64 and the compilation cache, before diffrax)

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from jax import lax  # noqa: E402

from ...metrics import RESTART_SHIFT  # noqa: E402

__all__ = ["dip_floor", "EventSearch", "EVENT_TOL", "THETA", "BARY"]

#: Where an event that starts a segment on or past its surface is moved (dimensionless: event
#: value over its scale; the metrics' tie rule allows for the delay it gives a simultaneous event).
EVENT_TOL = RESTART_SHIFT
#: Most bracketed Newton iterations locating an event on a step's interpolant (they stop when the
#: root moves by less than ROOT_TOL of the step, or 4 ulps of the time: the polish, one Newton step
#: on the integrator's own solution, then squares that error away).
MAX_ROOT_ITERS = 64
ROOT_TOL = 1e-12
#: ... or when the event value (over its scale) is within this of zero.
ROOT_GTOL = 1e-14
#: Chebyshev–Lobatto points of a step (as a fraction of it) at which its interpolant is sampled,
#: and their barycentric weights: exact for polynomials of degree < 10 (diffrax's interpolants of
#: these integrators have degree <= 7).
THETA = 0.5 - 0.5 * np.cos(np.pi * np.arange(10) / 9)
BARY = (-1.0) ** np.arange(10) * np.where((np.arange(10) == 0) | (np.arange(10) == 9), 0.5, 1.0)
#: The Chebyshev series (degree 9, on the step as [-1, 1]) through values at the THETA points,
#: and the points where a step's event functions are evaluated from it to find a crossing
#: inside the step.
_CHEB_FIT = np.linalg.inv(np.polynomial.chebyshev.chebvander(2 * THETA - 1, 9))
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


class EventSearch:
    """The event search of a segment loop (mixed into :class:`~.core.SegmentLoop`, whose ``model``,
    ``solver`` (the stepping solver) and ``term`` (the ODE term) it uses)."""

    def _hidden(self, t0, t1, y1, dense, args):
        """Whether an armed event crosses zero and back inside the step ``[t0, t1]`` unseen at its
        ends: its value over its scale is positive at the end (on the integrator's state ``y1``)
        and may be below ``-depth`` inside. Along the step's interpolant (a polynomial of degree
        < 10) an event function linear in the state is a polynomial ``q`` of that degree: its
        Chebyshev series is fitted exactly at the :data:`THETA` points and evaluated, with its
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
        ys = jax.vmap(interp.evaluate)(t0 + jnp.asarray(THETA) * h)
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
        the search is repeated up to that root. A point above the surface and rising is never
        taken as the root, however close to zero (an event that starts the segment a rounding
        error ahead of its surface, moving away, and crosses it later in the step: the closing
        event of a contact just separated at its permanent set). Polish: re-take
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
                # is ill-conditioned, but a state that is not), or a Newton step below tol;
                # never where it is above the surface and rising: that is no crossing (a
                # contact that separated a rounding error above its permanent set, moving
                # apart: its closing event a hair ahead at the step's start is not a root)
                near = (jnp.abs(g) <= ROOT_GTOL) | (jnp.abs(g) <= tol * jnp.abs(dg))
                done = ~crossed | (near & ~((g > 0) & (dg > 0)))
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

