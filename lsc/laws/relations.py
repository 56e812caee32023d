"""The restitution relations of the spring–dashpot laws, solved exactly: Kelvin's damping ratio,
Hunt–Crossley's ``a = α v0`` and Brach's restoring coefficient, from a target restitution."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SimulationError

__all__ = ["MIN_RESTITUTION", "kelvin_restitution", "kelvin_dlne_dzeta", "kelvin_zeta",
           "hunt_crossley_a", "brach_restitution", "brach_c2", "finite_slope"]

#: The smallest target restitution the spring–dashpot relations convert: the smallest normal
#: float64 (2.2250738585072014e-308). Below it Hunt–Crossley's root ``a ≈ 1/e`` overflows and
#: Kelvin's ``ζ ≈ 1/(2√e)`` is past where ``ζ²`` overflows; ``e`` itself, subnormal, has
#: lost its relative precision.
MIN_RESTITUTION = float(np.finfo(float).tiny)


def _check_target(e: float, law: str) -> None:
    if not 0 < e <= 1:
        raise ValueError(f"the {law} target restitution must be in (0, 1], got {e!r}")
    if e < MIN_RESTITUTION:
        raise ValueError(f"the {law} target restitution must be at least MIN_RESTITUTION = "
                         f"{MIN_RESTITUTION!r} (its damping overflows below it), got {e!r}")


def kelvin_restitution(zeta):
    """Restitution of the Kelvin law ``k D + c Ḋ`` with force-zero separation, for damping ratio
    ``ζ = c / (2√(kμ)) >= 0``: ``e = exp(-2ζ arccos ζ / √(1-ζ²))`` (arccosh form for ζ > 1)."""
    z = np.asarray(zeta, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        zu, zo = np.clip(z, 0.0, 1.0), np.maximum(z, 1.0)
        under = np.exp(-2 * zu * np.arccos(zu) / np.sqrt((1 - zu) * (1 + zu)))
        over = np.exp(-2 * zo * np.arccosh(zo) / np.sqrt((zo - 1) * (zo + 1)))
    return np.where(z < 1, under, np.where(z > 1, over, np.exp(-2.0)))


def kelvin_dlne_dzeta(z: float) -> float:
    """``d ln e / dζ`` of the Kelvin restitution ``ln e = -2ζ arccos ζ / √(1-ζ²)`` (arccosh form
    for ζ > 1)."""
    if abs(z - 1.0) < 1e-6:  # the two branches meet smoothly at ζ = 1: difference across it
        h = 1e-4
        return float((np.log(kelvin_restitution(z + h)) - np.log(kelvin_restitution(z - h)))
                     / (2 * h))
    if z < 1:
        s2 = 1.0 - z * z
        return -2.0 * (math.acos(z) / s2 ** 1.5 - z / s2)
    s2 = z * z - 1.0   # finite for every ζ of a restitution >= MIN_RESTITUTION (ζ <= 3.4e153)
    return -2.0 * (z / s2 - math.acosh(z) / s2 / math.sqrt(s2))   # (s2 ** 1.5 overflows)


def kelvin_zeta(e: float) -> float:
    """The damping ratio ζ whose Kelvin restitution is ``e``
    (``MIN_RESTITUTION <= e <= 1``)."""
    from scipy.optimize import brentq

    _check_target(e, "Kelvin")
    if e == 1:
        return 0.0
    hi = 1.0
    while float(kelvin_restitution(hi)) > e:
        hi *= 2.0
    return float(brentq(lambda z: float(kelvin_restitution(z)) - e, 0.0, hi,
                        xtol=1e-15, rtol=1e-15))


def hunt_crossley_a(e: float) -> float:
    """``a = α v0`` of the Hunt–Crossley law for restitution ``e``
    (``MIN_RESTITUTION <= e <= 1``, any exponent): the positive root of
    ``a (1 + e) = ln[(1 + a) / (1 - a e)]``, to a few ulps.

    The relation is solved in the form that resolves it: for a small root (``e`` near 1,
    ``a <= 1/2``) as the series :func:`_hc_series` of ``[ln(1 + a) - ln(1 - a e) - a (1 + e)] / a²``
    (its leading terms cancel exactly); otherwise for ``L = -ln(1 - a e)``
    (``a = -expm1(-L)/e``), in which the relation reads ``L = a (1 + e) - ln(1 + a)``: as
    ``e → 0`` the root ``a`` tends to ``1/e`` with ``1 - a e ≈ e^{-1/e}`` (below 1e-300 at
    ``e = 1e-3``), which ``a`` itself cannot resolve and ``L`` does; that root lies in
    ``(0, (1 + e)/e]``."""
    from scipy.optimize import brentq

    _check_target(e, "Hunt-Crossley")
    if e == 1:
        return 0.0
    tol = dict(xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)
    if _hc_series(0.5, e) > 0:   # (it is -(1 - e²)/2 < 0 at a = 0)
        return float(brentq(_hc_series, 0.0, 0.5, args=(e,), **tol))

    def residual(L):   # > 0 below the root, < 0 above it
        a = -np.expm1(-L) / e
        return a * (1 + e) - np.log1p(a) - L

    hi = (1 + e) / e
    return float(-np.expm1(-brentq(residual, 0.25, hi, **tol)) / e)


def _hc_series(a, e):
    """``[ln(1 + a) - ln(1 - a e) - a (1 + e)] / a² = Σ_{n>=2} a^(n-2) [(-1)^(n+1) + e^n] / n``
    for ``0 <= a <= 1/2`` (the even coefficients ``e^n - 1`` from ``expm1``, without
    cancellation)."""
    n = np.arange(2, 60)
    with np.errstate(divide="ignore"):   # e below eps: log1p(-1) = -inf, expm1(-inf) = -1
        coef = np.where(n % 2 == 1, 1.0 + e ** n, np.expm1(n * np.log1p(-(1.0 - e))))
    return float(np.sum(a ** (n - 2) * coef / n))


def brach_restitution(k, c1, c2, v0, mu):
    """Restitution of Brach's law ``D (k + c Ḋ)`` (``c1`` compressing, ``c2`` restoring) for an
    impact at closing speed ``v0`` of a pair of reduced mass ``mu``, from its energy integral:
    ``G_c2(-e v0) = G_c1(v0)`` with ``G_c(v) = (μ k / c²)(c v/k - ln(1 + c v/k))``."""
    from scipy.optimize import brentq

    def G(c, v):
        u = c * v / k
        return mu * v * v / k * np.where(np.abs(u) < 1e-6, 0.5 - u / 3 + u * u / 4,
                                         (u - np.log1p(u)) / np.where(u == 0, 1, u * u))
    target = G(c1, v0)
    f = lambda e: G(c2, -e * v0) - target  # noqa: E731
    hi = min(1.0, k / (c2 * v0) * (1 - 1e-15)) if c2 > 0 else 1.0
    return float(brentq(f, 0.0, hi, xtol=1e-15, rtol=1e-15))


def brach_c2(k, c1, e, v0, mu, xp):
    """The restoring coefficient ``c2`` that gives Brach's law restitution ``e`` at closing speed
    ``v0`` (array code: a fixed bisection on ``x = c2 e v0 / k`` in [0, 1)), and whether it
    exists: some ``c2 >= 0`` gives ``e`` (``c1`` not too large) and it is a finite float."""
    u1 = c1 * v0 / k
    r1 = xp.where(xp.abs(u1) < 1e-6, 0.5 - u1 / 3 + u1 * u1 / 4,
                  (u1 - xp.log1p(u1)) / xp.where(u1 == 0, 1.0, u1 * u1))
    with np.errstate(divide="ignore", over="ignore"):   # a tiny e: R = inf, c2 = inf (refused)
        R = r1 / (e * e)
        c2 = _brach_x(R, xp) * k / (e * v0)
    # a c2 past the float range is no restoring coefficient
    return c2, (R >= 0.5 - 1e-15) & (c2 < np.finfo(float).max)


def _brach_x(R, xp):
    """``x`` in [0, 1) with ``(-x - ln(1 - x)) / x² = R`` (a fixed bisection; 1 once ``R`` is past
    what float64 ``x`` resolves)."""

    def h(x):
        return xp.where(x < 1e-6, 0.5 + x / 3 + x * x / 4,
                        (-x - xp.log1p(-x)) / xp.where(x == 0, 1.0, x * x))

    lo, hi = xp.asarray(0.0), xp.asarray(1.0)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        up = h(mid) < R
        lo, hi = xp.where(up, mid, lo), xp.where(up, hi, mid)
    return 0.5 * (lo + hi)


def finite_slope(slope: float, what: str, law: str, e: float) -> float:
    """``slope`` (a conversion's ``d/de``, for autodiff), or the SimulationError that says it is
    past the float range (``law``: its asymptote, as text)."""
    if not math.isfinite(slope):
        raise SimulationError(f"the derivative of {what} with respect to the target restitution "
                              f"(about {law}) is past the float64 range at e = {e!r}, so "
                              "forward-mode autodiff through it has no derivative (nor do "
                              "differences resolve one): give a larger restitution")
    return slope
