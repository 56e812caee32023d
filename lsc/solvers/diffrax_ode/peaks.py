"""Force and acceleration peaks inside a step (metrics solves): the extrema of a step's dense
output, located by the Illinois method on their time derivative (:class:`PeakSearch`).

Force and acceleration peaks are taken at the events and, where they can lie between events
(damping laws, braking, chains), at the extrema inside every step of the dense output.
"""

from __future__ import annotations

from . import compiled  # noqa: F401  (float64 and the compilation cache, before diffrax)

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
from jax import lax  # noqa: E402

from .wrappers import fold_peaks  # noqa: E402

__all__ = ["PeakSearch", "PEAK_ITERS"]

#: Illinois iterations locating a force or acceleration peak inside a step (metrics solve).
PEAK_ITERS = 12


class PeakSearch:
    """The peak search of a segment loop (mixed into :class:`~.core.SegmentLoop`, whose ``model``,
    ``solver`` (the stepping solver) and ``term`` (the ODE term) it uses)."""

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
        F, a = fold_peaks((q_hi[:K], q_hi[K:]), q_ext[:K], q_ext[K:])
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
