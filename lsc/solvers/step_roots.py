"""Every root of an event function inside one integrator step, not only a sign change between
the step's ends.

An integrator's dense output on a step is a polynomial of known degree ``p`` in time. An event
function linear in the state (an IF-D contact's deformation bounds and closing rate, a brake's
velocity, a force on an affine piece) is then a polynomial of degree ``p`` along it: its values
at the ``p + 1`` Chebyshev–Lobatto points of the step give it exactly (to rounding), as a
Chebyshev series, and its extrema (the roots of its derivative) split the step into pieces on
which it is monotone. The first piece on which it goes from ``>= 0`` to ``< 0`` holds its
earliest crossing, whatever happens at the step's end: a contact that reloads past its max
deformation and comes back, or whose closing rate dips below zero and back, inside one step is
seen. An event function that is not linear in the state is interpolated at
:data:`NONLINEAR_POINTS` points instead, and the interpolant's own error bound (the size of its
last coefficients) is taken off its values, so a dip that the interpolant does not resolve is
still reported.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import chebyshev as cheb

__all__ = ["lobatto", "fit", "first_crossing", "NONLINEAR_POINTS"]

#: Points at which an event function that is not linear in the state is interpolated on a step.
NONLINEAR_POINTS = 33

_FITS: dict = {}


def lobatto(n: int) -> np.ndarray:
    """The ``n + 1`` Chebyshev–Lobatto points of ``[-1, 1]``, ascending."""
    return -np.cos(np.pi * np.arange(n + 1) / n) if n > 0 else np.zeros(1)


def fit(values: np.ndarray) -> np.ndarray:
    """Chebyshev coefficients ``(m, n + 1)`` of the polynomials of degree ``n`` through
    ``values`` ``(m, n + 1)`` at :func:`lobatto` ``(n)`` (one matrix product: the inverse of the
    Chebyshev–Vandermonde matrix of those points is computed once per degree)."""
    n = values.shape[-1] - 1
    inv = _FITS.get(n)
    if inv is None:
        inv = _FITS[n] = np.linalg.inv(cheb.chebvander(lobatto(n), n))
    return values @ inv.T


def _probes(coef: np.ndarray) -> np.ndarray:
    """The ends of ``[-1, 1]`` and the real parts of the roots of the series' derivative that
    lie in it, ascending: between two consecutive probes the series is monotone (a root of the
    derivative with a rounding-size imaginary part is probed too; an extra probe costs
    nothing)."""
    d = cheb.chebder(coef)
    while d.size > 1 and d[-1] == 0:
        d = d[:-1]
    crit = cheb.chebroots(d).real if d.size > 1 and np.any(d != 0) else np.zeros(0)
    crit = crit[(crit > -1) & (crit < 1)]
    return np.concatenate([[-1.0], np.sort(crit), [1.0]])


def first_crossing(coef: np.ndarray, depth: float, end_below: bool, slack: float = 0.0):
    """The first stretch of ``[-1, 1]`` on which the Chebyshev series ``coef`` (an event
    function on a step, ``>= 0`` at its start) crosses zero downward: ``(a, b)`` with the series
    ``>= 0`` at ``a``, ``< 0`` at ``b`` and monotone between, or None.

    A crossing counts when the dip it starts goes below ``-depth`` (a shallower one only
    touches the surface: a max deformation exactly at a breakpoint) or lasts to the step's end
    where the solver's own state is past the surface (``end_below``). ``slack``: a bound on
    the series' own error (0 for a polynomial reproduced exactly); the values are taken that
    much lower, so that a dip the series misses by its error is still reported.

    A cheap bound first: ``|T_k| <= 1``, so the series is at least
    ``c_0 - sum |c_k|``; where that is above ``slack`` no root is sought."""
    if coef[0] - np.sum(np.abs(coef[1:])) > slack and not end_below:
        return None
    x = _probes(coef)
    v = cheb.chebval(x, coef) - slack
    below = np.flatnonzero(v < -depth)
    stop = below[0] if below.size else (x.size - 1 if end_below else None)
    if stop is None:
        return None
    # the last probe before it still on the positive side (the series starts there: v[0] >= 0)
    up = np.flatnonzero(v[: stop + 1] >= 0)
    k = up[-1] if up.size else 0
    if k == stop:
        return None
    return float(x[k]), float(x[k + 1])


def tail_bound(coef: np.ndarray, tail: int = 4) -> float:
    """A bound on the error of a Chebyshev interpolant of a smooth function: twice the sum of
    its last ``tail`` coefficients' sizes (they bound what the series has not converged to)."""
    return 2.0 * float(np.sum(np.abs(coef[-tail:])))
