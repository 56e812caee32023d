"""Hunt–Crossley and Brach impacts of two vehicles from their energy relations: an independent
reference (it shares no code with lsc) that the integrators are held to.

Both laws are ``F = k D^n (1 + α Ḋ)`` with the coefficient of the phase: Hunt–Crossley
``α`` throughout; Brach's ``F = D (k + c Ḋ)`` is ``n = 1`` with ``α = c1/k`` compressing and
``α = c2/k`` restoring. With ``v = Ḋ`` the relative motion ``μ D'' = -F`` reads
``μ v dv/dD = -k D^n (1 + α v)``, which separates:

    μ v dv / (1 + α v) = -k D^n dD   →   G_α(v) + k D^{n+1}/(n+1) = const,

    G_α(v) = ∫_0^v μ u du/(1 + α u) = μ v² φ(α v),   φ(x) = (x - ln(1 + x))/x²  (φ(0) = 1/2),

the first integral of the motion (an elementary integral: computed in closed form here, and by
``scipy.integrate.quad`` in the tests as a check). From it, with ``v0`` the closing speed:

- max crush (``v = 0``): ``k D_max^{n+1}/(n+1) = G_α1(v0)``;
- rebound: restoring from ``D_max`` the force stays positive (``G_α2(v)`` grows without bound
  as ``α2 v → -1``, so ``1 + α2 v`` never reaches 0) and the contact separates at ``D = 0``
  with ``v = -e v0``, where ``G_α2(-e v0) = G_α1(v0)`` (a bracketed root in ``e``: the
  Hunt–Crossley relation ``a (1 + e) = ln[(1 + a)/(1 - a e)]``, ``a = α v0``, and Brach's
  energy integral are this one equation);
- ``ΔV_1 = -(1 + e) μ v0/m1``, ``ΔV_2 = (1 + e) μ v0/m2``; absorbed energy ``½ μ v0²``
  (all the relative kinetic energy is stored or lost at max crush), returned ``e²`` times it;
- peak force: restoring, ``F < k D^n <= k D_max^n``; compressing, along
  ``D(v)^{n+1} = (n+1)(G_α1(v0) - G_α1(v))/k``, ``dF/dD = 0`` where
  ``μ n v = α1 k D^{n+1}``, i.e. at the one root of ``μ n v = α1 (n+1)(G_α1(v0) - G_α1(v))``
  on ``(0, v0)`` (the left side rises from 0, the right falls to 0); ``F`` rises before it and
  falls after, so it is the peak (``α1 = 0``: the peak is ``k D_max^n`` at max crush);
- duration: ``dt = dD/v = -μ dv/F``, so each phase lasts ``∫ μ dv/(k D(v)^n (1 + α v))``
  over its speeds (``v0 → 0``, then ``0 → -e v0``), by ``scipy.integrate.quad`` with the
  algebraic weight ``|v - v_end|^{-n/(n+1)}`` of the end where ``D → 0`` (there
  ``D^{n+1}`` vanishes linearly in ``v``): the rest of the integrand is smooth, written with
  the divided difference of ``G`` (:func:`_slope`), which does not cancel.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

__all__ = ["phi", "energy", "Impact", "impact", "hunt_crossley", "brach"]

QUAD = dict(epsabs=0.0, epsrel=1e-13, limit=200)


def phi(x: float) -> float:
    """``(x - ln(1 + x))/x²`` for ``x > -1`` (a series near 0, where the difference cancels)."""
    if abs(x) < 1e-3:
        return sum((-x) ** (j - 2) / j for j in range(2, 9))
    return (x - math.log1p(x)) / (x * x)


def energy(mu: float, alpha: float, v: float) -> float:
    """``G_α(v) = ∫_0^v μ u du/(1 + α u) = μ v² φ(α v)`` [energy]."""
    return mu * v * v * phi(alpha * v)


def _slope(mu: float, alpha: float, a: float, b: float) -> float:
    """``(G_α(b) - G_α(a))/(b - a)`` without cancellation: with ``y = α(b - a)/(1 + α a)``,
    ``μ [a + (b - a) φ(y)/(1 + α a)]/(1 + α a)`` (``μ (a + b)/2`` when ``α = 0``)."""
    s = 1.0 + alpha * a
    return mu * (a + (b - a) * phi(alpha * (b - a) / s) / s) / s


class Impact(dict):
    """The impact's numbers: ``max_deformation, restitution, peak_force, duration,
    compression_time, delta_v (2,), energy_absorbed, energy_returned``."""


def impact(m1, m2, v0, k, n, alpha1, alpha2) -> Impact:
    """The impact of the law ``k D^n (1 + α Ḋ)`` (``α1`` compressing, ``α2`` restoring) between
    masses ``m1, m2`` closing at ``v0 > 0`` from ``D = 0``."""
    mu = m1 * m2 / (m1 + m2)
    g1 = energy(mu, alpha1, v0)
    d_max = ((n + 1) * g1 / k) ** (1 / (n + 1))
    e = _rebound(mu, v0, alpha2, g1)
    impulse = (1 + e) * mu * v0
    return Impact(max_deformation=d_max, restitution=e,
                  peak_force=_peak_force(mu, v0, k, n, alpha1, g1, d_max),
                  compression_time=_compression_time(mu, v0, k, n, alpha1, g1),
                  duration=(_compression_time(mu, v0, k, n, alpha1, g1)
                            + _restitution_time(mu, e * v0, k, n, alpha2, g1)),
                  delta_v=np.array([-impulse / m1, impulse / m2]),
                  energy_absorbed=0.5 * mu * v0 * v0,
                  energy_returned=0.5 * mu * (e * v0) ** 2)


def _rebound(mu, v0, alpha2, g1) -> float:
    """The ``e`` with ``G_α2(-e v0) = G_α1(v0) = g1``."""
    if alpha2 == 0:
        return math.sqrt(g1 / (0.5 * mu)) / v0
    hi = min(1.0, (1 - 1e-15) / (alpha2 * v0))   # (G_α2(-e v0) grows without bound there)
    if energy(mu, alpha2, -hi * v0) < g1:
        raise ValueError(f"α2 v0 = {alpha2 * v0:g}: the rebound speed is within 1e-15 of "
                         "1/α2, beyond what this reference resolves")
    return brentq(lambda e: energy(mu, alpha2, -e * v0) - g1, 0.0, hi, xtol=1e-300,
                  rtol=4 * np.finfo(float).eps, maxiter=500)


def _peak_force(mu, v0, k, n, alpha1, g1, d_max) -> float:
    """The largest force (over compression; restoring it stays below ``k D_max^n``)."""
    if alpha1 == 0 or n == 0:   # at max crush; n = 0: at touch, k (1 + α1 v0)
        return k * d_max ** n if n > 0 else k * (1 + alpha1 * v0)

    def condition(v):  # μ n v - α1 k D^{n+1}
        return mu * n * v - alpha1 * (n + 1) * (g1 - energy(mu, alpha1, v))

    v = brentq(condition, 0.0, v0, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)
    d = ((n + 1) * (v0 - v) * _slope(mu, alpha1, v, v0) / k) ** (1 / (n + 1))
    return k * d ** n * (1 + alpha1 * v)


def _compression_time(mu, v0, k, n, alpha1, g1) -> float:
    """``∫_0^{v0} μ dv/(k D^n (1 + α1 v))``, ``D^{n+1} = (n+1)(v0 - v) slope(v, v0)/k``."""
    p = n / (n + 1)

    def smooth(v):   # the integrand times (v0 - v)^p
        return mu / (k * ((n + 1) * _slope(mu, alpha1, v, v0) / k) ** p * (1 + alpha1 * v))

    return quad(smooth, 0.0, v0, weight="alg", wvar=(0.0, -p), **QUAD)[0]


def _restitution_time(mu, w, k, n, alpha2, g1) -> float:
    """``∫_{-w}^0 μ dv/(k D^n (1 + α2 v))`` with ``w = e v0`` the separation speed,
    ``D^{n+1} = (n+1)(G_α2(-w) - G_α2(v))/k`` (``G_α2(-w) = g1``)."""
    p = n / (n + 1)

    def smooth(v):   # the integrand times (v + w)^p
        return mu / (k * ((n + 1) * -_slope(mu, alpha2, -w, v) / k) ** p * (1 + alpha2 * v))

    return quad(smooth, -w, 0.0, weight="alg", wvar=(-p, 0.0), **QUAD)[0]


def hunt_crossley(m1, m2, v0, k, n, alpha) -> Impact:
    """Hunt–Crossley ``F = k D^n (1 + α Ḋ)`` [force; ``k`` in force/length^n, ``α`` in
    time/length]."""
    return impact(m1, m2, v0, k, n, alpha, alpha)


def brach(m1, m2, v0, k, c1, c2) -> Impact:
    """Brach ``F = k D + c D Ḋ``, ``c = c1`` compressing, ``c2`` restoring [force·time/length²]."""
    return impact(m1, m2, v0, k, 1.0, c1 / k, c2 / k)
