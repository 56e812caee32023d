"""Closed-form segment kernels of the exact backend: the two-body motion inside one segment and
its events, written once against a small array namespace (NumPy, or :data:`_PY` on Python
floats) and shared by the one-scene solve and the batch.

Inside a segment (frozen discrete state) the contact force is affine in the deformation,
``F = fa + s (D - da)`` (:class:`~lsc.contact.HysteresisLaw`), so with ``μ = m1 m2/(m1+m2)``
the relative motion obeys ``μ D'' = -(fa + s (D - da)) + μ c`` while the centre of mass moves
with constant acceleration ``A`` (``c = b1/m1 - b2/m2``, ``A = (b1+b2)/M`` for constant extra
forces ``b1, b2`` per vehicle [force]: sliding friction ``-μ_i m_i g dir_i`` of a braked vehicle,
zero otherwise). A vehicle its brakes hold (stuck) does not move at all: the relative motion is
then the other vehicle's alone against a fixed one (its own mass for ``μ``; both held: nothing
moves). With ``κ = s/μ`` [1/s²], ``D0, W0`` the deformation [length] and closing rate
[velocity] and ``A0 = D''(0)`` [acceleration] at the segment start, for every sign of ``κ``

    D(τ) = D0 + W0 S(τ) + A0 C(τ),      D'(τ) = W0 + A0 S(τ) - κ W0 C(τ),

with ``S = sin(ωτ)/ω, C = (1 - cos ωτ)/ω²`` (harmonic, ``κ = ω² > 0``),
``S = τ, C = τ²/2`` (parabolic: plateaus, and free flight when open) and ``sinh, cosh``
(hyperbolic, ``κ = -λ²``: falling tables), evaluated from half angles without cancellation.

Events, analytically: the substitution ``z = (2/ω) tan(ωτ/2)`` (``τ``; ``(2/λ) tanh(λτ/2)``)
makes ``S = z/(1 + κz²/4)``, ``C = (z²/2)/(1 + κz²/4)`` and
``S' = (1 - κz²/4)/(1 + κz²/4)`` rational with a positive denominator, so each event
function (the law's ``D - lo``, ``hi - D``, ``D'`` while loading, and a declared bumper
failure force minus ``F``, all crossing zero downward) has the sign of a quadratic in ``z``. A
quadratic has at most one downward crossing; its root, from the cancellation-free formula as a
ratio ``num/den`` (``den = 0`` is the root at infinity, ``ωτ = π``), maps back to time by one
``atan2`` (harmonic), ``atanh`` (hyperbolic, as ``log1p``) or directly (parabolic), only for
the earliest event: the events of one segment are ordered by a monotone key (a pseudo-angle)
first. No iteration: results agree with 40-digit arithmetic to about 1e-15 relative. A
segment starting on the surface it just crossed does not fire it again unless it stays on it or
moves back into it (the restart trap, see :func:`_level_now`); a discriminant within rounding of
zero is a touch (:data:`_TOUCH`).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

_ARMED = 1e299        # bounds beyond this are disarmed (as in HybridModel.active_events)
_EPS = 2.220446049250313e-16   # float64 machine epsilon
# A discriminant within this fraction of its terms is a double root: a touch, not a crossing
# (the excursion past the surface, disc/(4|a|), is below 1e-12 of the motion's length scale).
# Rounding makes exact tangencies look like shallow crossings: with a friction force and a
# straight unloading line the motion is conservative, and a contact that closes again returns to
# (D_max, W = 0) exactly; after a few segments the computed discriminant is ~1e-14 of its terms.
_TOUCH = 1e-12



# ============================================================================ namespaces
class _PyMath:
    """The few ``numpy`` functions the kernels and the law's transitions use, on Python scalars.

    ``where`` picks a branch (both are evaluated, as with arrays), so every kernel keeps its
    unused branches finite: no division by zero, no ``sqrt``/``atanh`` outside their domain.
    """

    inf = math.inf
    sqrt, sin, cos = staticmethod(math.sqrt), staticmethod(math.sin), staticmethod(math.cos)
    sinh, cosh = staticmethod(math.sinh), staticmethod(math.cosh)
    arctan2, log1p, log = staticmethod(math.atan2), staticmethod(math.log1p), staticmethod(math.log)
    exp = staticmethod(math.exp)
    copysign, abs = staticmethod(math.copysign), staticmethod(abs)
    maximum, minimum = staticmethod(max), staticmethod(min)

    @staticmethod
    def searchsorted(a, v, side="left"):
        return (bisect.bisect_right if side == "right" else bisect.bisect_left)(a, v)

    @staticmethod
    def where(cond, a, b):
        return a if cond else b

    @staticmethod
    def asarray(x, dtype=None):
        return x

    @classmethod
    def masked(cls, name, mask, *args):
        """``name(*args)`` where ``mask``, else 0."""
        return getattr(cls, name)(*args) if mask else 0.0

    @staticmethod
    def clip(x, lo, hi):
        return min(max(x, lo), hi)


_PY = _PyMath()


# ============================================================================ kernels
@dataclass
class _Seg:
    """One frozen-mode segment of the two-body motion (scalars or arrays of members).

    ``x1, x2, v1, v2`` the state at its start [length, velocity]; ``r1, r2`` mass fractions
    ``m1/M, m2/M``; ``V0, Acm`` centre-of-mass velocity [velocity] and acceleration
    [acceleration]; ``D0, W0, A0`` deformation, closing rate and relative acceleration at the
    start; ``kappa = s/μ`` [1/s²]; ``F0`` contact force at the start [force].
    """

    x1: object
    x2: object
    v1: object
    v2: object
    r1: object
    r2: object
    V0: object
    Acm: object
    D0: object
    W0: object
    A0: object
    kappa: object
    F0: object


def _setup(x1, x2, v1, v2, m1, m2, gap, fa, s, da, b1=0.0, b2=0.0, hold1=False,
           hold2=False) -> _Seg:
    """A segment from the state at its start, the active affine piece ``F = fa + s (D - da)``
    and constant extra forces ``b1, b2`` on the vehicles [force] (sliding friction).

    ``hold1``, ``hold2`` (Python scalars only): the vehicle is held by its brakes (stuck,
    ``a = 0``). Then the relative motion is the other vehicle's alone against a fixed one (mass
    ``m1`` or ``m2`` in place of ``μ``, all of ``ΔD`` to the moving vehicle, the reference point
    moving with the held one); with both held nothing accelerates (``κ = A0 = 0``)."""
    if hold1 or hold2:
        D0 = x1 - x2 - gap
        F0 = fa + s * (D0 - da)
        W0 = v1 - v2
        if hold1 and hold2:
            return _Seg(x1=x1, x2=x2, v1=v1, v2=v2, r1=0.5, r2=0.5, V0=0.5 * (v1 + v2), Acm=0.0,
                        D0=D0, W0=W0, A0=0.0, kappa=0.0, F0=F0)
        if hold2:   # vehicle 1 moves: m1 D'' = b1 - F
            return _Seg(x1=x1, x2=x2, v1=v1, v2=v2, r1=0.0, r2=1.0, V0=v2, Acm=0.0, D0=D0, W0=W0,
                        A0=(b1 - F0) / m1, kappa=s / m1, F0=F0)
        # vehicle 2 moves: m2 D'' = -m2 a2 = -(F + b2)
        return _Seg(x1=x1, x2=x2, v1=v1, v2=v2, r1=1.0, r2=0.0, V0=v1, Acm=0.0, D0=D0, W0=W0,
                    A0=-(b2 + F0) / m2, kappa=s / m2, F0=F0)
    M = m1 + m2
    r1, r2 = m1 / M, m2 / M
    mu = m1 * m2 / M
    D0 = x1 - x2 - gap
    F0 = fa + s * (D0 - da)
    return _Seg(x1=x1, x2=x2, v1=v1, v2=v2, r1=r1, r2=r2, V0=r1 * v1 + r2 * v2,
                Acm=(b1 + b2) / M, D0=D0, W0=v1 - v2, A0=(b1 / m1 - b2 / m2) - F0 / mu,
                kappa=s / mu, F0=F0)


def _basis(xp, tau, kappa):
    """``S(τ), C(τ)`` for ``D'' = -κ D + const`` (``D = D0 + W0 S + A0 C``): harmonic
    (``κ = ω² > 0``: ``S = sin(ωτ)/ω = 2 sin h cos h/ω``,
    ``C = (1 - cos ωτ)/ω² = 2 (sin h/ω)²``, ``h = ωτ/2``), hyperbolic (``κ = -λ²``:
    ``sinh, cosh``) or parabolic (``S = τ, C = τ²/2``)."""
    if isinstance(kappa, float):  # one segment (a Python float): its own branch only
        if kappa == 0:
            return tau, 0.5 * tau * tau
        w = math.sqrt(abs(kappa))
        h = 0.5 * w * tau
        try:
            s, c = (xp.sin(h), xp.cos(h)) if kappa > 0 else (xp.sinh(h), xp.cosh(h))
        except OverflowError:   # (exponential growth past float64: non-finite, and reported)
            return math.inf, math.inf
        return 2.0 * s * c / w, 2.0 * (s / w) * (s / w)
    # members (arrays): each function only where its branch applies
    pos, neg = kappa > 0, kappa < 0
    w = xp.sqrt(xp.abs(kappa))
    ws = xp.where(w > 0, w, 1.0)
    h = 0.5 * ws * tau
    s = xp.masked("sin", pos, h) + xp.masked("sinh", neg, h)
    c = xp.masked("cos", pos, h) + xp.masked("cosh", neg, h)
    sw = s / ws
    curved = pos | neg
    return xp.where(curved, 2.0 * s * c / ws, tau), xp.where(curved, 2.0 * sw * sw, 0.5 * tau * tau)


def _sep_increments(xp, tau, g: _Seg):
    """``ΔD, ΔW`` a time ``τ`` into a separatrix segment (κ = -λ² < 0, see :func:`_next_event`):
    ``D - D_eq = β e^{-λτ}`` with ``β = D0 - D_eq = A0/λ²`` and the growing mode taken as the
    zero it is to rounding (the growing basis, ``sinh λτ`` times a rounding error, is evaluated
    nowhere: at ``λτ = 35`` it would be off by ``D`` itself)."""
    lam2 = xp.where(g.kappa < 0, -g.kappa, 1.0)
    lam = xp.sqrt(lam2)
    beta = g.A0 / lam2
    decay = xp.exp(-lam * tau)
    return beta * (decay - 1.0), -lam * beta * decay - g.W0


def _state(xp, tau, g: _Seg, sep=False):
    """Vehicle positions and velocities ``(x1, x2, v1, v2)`` a time ``tau`` into segment ``g``,
    as increments on its start (exact at ``tau = 0``): the centre of mass moves uniformly
    (accelerated by ``Acm``), the deformation by ``ΔD = W0 S + A0 C`` and the closing rate by
    ``ΔW = A0 S - κ W0 C`` (``S' - 1 = -κ C``), shared in the ratio of the masses."""
    if sep is True:
        dD, dW = _sep_increments(xp, tau, g)
    else:
        S, C = _basis(xp, tau, g.kappa)
        dD = g.W0 * S + g.A0 * C
        dW = g.A0 * S - g.kappa * g.W0 * C
        if sep is not False:   # members (arrays): the separatrix ones in the stable form
            sD, sW = _sep_increments(xp, xp.where(sep, tau, 0.0), g)
            dD, dW = xp.where(sep, sD, dD), xp.where(sep, sW, dW)
    dX = g.V0 * tau + 0.5 * g.Acm * tau * tau
    dV = g.Acm * tau
    return (g.x1 + dX + g.r2 * dD, g.x2 + dX - g.r1 * dD,
            g.v1 + dV + g.r2 * dW, g.v2 + dV - g.r1 * dW)


def _crossing(xp, a, b, c, kappa, ws, now, A0=0.0):
    """The first downward zero crossing at ``τ > 0`` of an event function ``g`` whose sign is
    that of ``h(z) = a z² + b z + c`` at ``z(τ)`` (``c = g(0)``), or ``τ = 0`` where ``now``.

    ``h`` has at most one downward root: ``q/a`` if ``b >= 0``, else ``c/q``, with
    ``q = -(b + sign(b) √(b² - 4ac))/2`` (no cancellation; ``a = 0`` puts it at infinity, which
    is ``ωτ = π`` in the harmonic case); a double root is a touch, not a crossing, and so is a
    discriminant within rounding of zero (:data:`_TOUCH`; ``A0`` [acceleration], the relative
    acceleration in ``a``, for its rounding scale). A root at
    ``τ = 0`` that is not ``now`` (a start on the surface, leaving it) counts as the next one, a
    period later (harmonic) or never. Returns ``(key, y, x, u)``: ``key`` orders the crossings of
    one segment in time (``inf``: none); ``τ = 2 atan2(y, x)/ω`` (harmonic), ``2 atanh(u)/λ``
    (hyperbolic) or ``2u`` (parabolic).
    """
    disc = b * b - 4.0 * a * c
    sq = xp.sqrt(xp.maximum(disc, 0.0))
    sb = xp.copysign(1.0, b)
    q = -0.5 * (b + sb * sq)
    num = xp.where(sb > 0, q, c)
    den = xp.where(sb > 0, a, q)
    zero = num == 0
    # harmonic, z = (2/ω) tan(ωτ/2): ωτ/2 = atan2(y, x) in [0, π] with y = ω num/2 >= 0,
    # ordered by the pseudo-angle 1 - x/(|x| + y) in [0, 2]
    flip = num < 0
    y = xp.where(zero | now, 0.0, 0.5 * ws * xp.where(flip, -num, num))
    x = xp.where(now, 1.0, xp.where(zero, -1.0, xp.where(flip, -den, den)))
    ax = xp.abs(x)
    pseudo = 1.0 - x / xp.where(ax + y > 0, ax + y, 1.0)
    # parabolic (u = z/2 > 0) and hyperbolic (u = λz/2 = tanh(λτ/2) in (0, 1))
    u = xp.where(den != 0, 0.5 * ws * num / xp.where(den != 0, den, 1.0), xp.inf)
    u = xp.where(now, 0.0, xp.where(zero, xp.inf, u))
    ok = ((u > 0) | now) & ((kappa >= 0) | (u < 1))
    key = xp.where(kappa > 0, pseudo, xp.where(ok, u, xp.inf))
    # (rounding scale of the discriminant: a = κc/4 ± A0/2 of the level events may cancel)
    a_mag = xp.abs(a) + 0.25 * xp.abs(kappa * c) + 0.5 * xp.abs(A0)
    crosses = disc > _TOUCH * (b * b + 4.0 * a_mag * xp.abs(c))
    return xp.where(crosses | now, key, xp.inf), y, x, u


def _level_now(a, b, c, vtol):
    """A level event fires at once when the segment starts on its surface (``c = 0``) and does
    not leave it: ``h = z (a z + b)`` is not positive just after the start, for good (``a <= 0``,
    ``b <= 0``: this includes resting on it, ``h = 0``, as on a zero-width unloading segment) or
    by more than a rounding-level excursion (``b < -vtol``, a closing rate [velocity])."""
    return (c == 0) & (b <= 0) & ((a <= 0) | (b < -vtol))


def _next_event(xp, g: _Seg, da, lo, wl, hi, vm, vtol, fail=None):
    """Time ``τ`` from the segment start to the earliest armed event and which: 0, ``D`` falls
    to ``lo``, which lies ``wl`` below the affine piece's anchor ``da`` (its level is taken
    relative to the anchor, ``(D0 - da) + wl``: a near-plastic rebound is narrower than the
    rounding of ``lo`` itself); 1, ``D`` rises to ``hi``; 2, the closing rate falls through 0 while ``vm`` (the
    law's three); 3, the force ``F = fa + s (D - da)`` rises through ``fail = (fa, s, da, F_f)``,
    the failure force [force] (``None``: not armed). ``τ = inf`` if none; ties go to the lower
    index. ``vtol`` [velocity]: closing rates below it are rounding (``1e-12`` of the scene's
    speed scale, as ``HybridModel.is_over``)."""
    D0, W0, A0, kappa = g.D0, g.W0, g.A0, g.kappa
    w = xp.sqrt(xp.abs(kappa))
    ws = xp.where(w > 0, w, 1.0)
    dl = (D0 - da) + wl
    a = 0.25 * kappa * dl + 0.5 * A0
    k0, y0, x0, u0 = _crossing(xp, a, W0, dl, kappa, ws, _level_now(a, W0, dl, vtol), A0)
    dh = hi - D0
    a = 0.25 * kappa * dh - 0.5 * A0
    k1, y1, x1, u1 = _crossing(xp, a, -W0, dh, kappa, ws, _level_now(a, -W0, dh, vtol), A0)
    # the common velocity: at once if the closing rate is not positive and falls (or stays:
    # at rest with no force, on an equilibrium)
    k2, y2, x2, u2 = _crossing(xp, -0.25 * kappa * W0, A0, W0, kappa, ws, (W0 <= 0) & (A0 <= 0))
    k0 = xp.where(lo > -_ARMED, k0, xp.inf)
    k1 = xp.where(hi < _ARMED, k1, xp.inf)
    k2 = xp.where(vm != 0, k2, xp.inf)
    first0, first1 = (k0 <= k1) & (k0 <= k2), k1 <= k2
    which = xp.where(first0, 0, xp.where(first1, 1, 2))
    key = xp.minimum(xp.minimum(k0, k1), k2)
    y = xp.where(first0, y0, xp.where(first1, y1, y2))
    x = xp.where(first0, x0, xp.where(first1, x1, x2))
    u = xp.where(first0, u0, xp.where(first1, u1, u2))
    if fail is not None:
        fa, s, da, ff = fail
        k3, y3, x3, u3 = _force_rises(xp, g, fa, s, da, ff, ws, vtol)
        first3 = k3 < key
        which = xp.where(first3, 3, which)
        key = xp.where(first3, k3, key)
        y, x, u = xp.where(first3, y3, y), xp.where(first3, x3, x), xp.where(first3, u3, u)
    tau = _to_time(xp, kappa, ws, key, y, x, u)
    # The separatrix. Loading on a falling piece (κ = -λ² < 0) with no event at all is the
    # motion creeping up to the equilibrium (the force falls to the level where the relative
    # acceleration vanishes: zero, on a table falling to zero force, at the kinetic energy that
    # brings the vehicles exactly there): D - D_eq = α e^{λτ} + β e^{-λτ} with α = 0 (to
    # rounding), W → 0, reached only as τ → ∞. The common velocity is taken where the rest
    # β e^{-λτ} is below the rounding of D, τ* = ln(|β|/δ)/λ (tens of 1/λ), not never.
    sep = (tau == xp.inf) & (vm != 0) & (kappa < 0)
    lam2 = xp.where(kappa < 0, -kappa, 1.0)
    beta = 0.5 * (A0 / lam2 - W0 / ws)
    delta = 4.0 * _EPS * (xp.abs(D0) + xp.abs(A0) / lam2) + 1e-300
    t_sep = xp.log(xp.maximum(xp.abs(beta) / delta, 1.0)) / ws
    return xp.where(sep, t_sep, tau), xp.where(sep, 2, which), sep


def _force_rises(xp, g: _Seg, fa, s, da, level, ws, vtol):
    """The crossing (as :func:`_crossing`) where the force ``F = fa + s (D - da)`` rises through
    ``level`` [force]: ``D`` reaches ``L = da + (level - fa)/s`` going up if ``s > 0``, going
    down if ``s < 0`` (a falling table); a flat or open segment never crosses it."""
    up, down = s > 0, s < 0
    L = da + (level - fa) / xp.where(up | down, s, 1.0)
    sign = xp.where(up, 1.0, -1.0)
    c = sign * (L - g.D0)
    a = 0.25 * g.kappa * c - 0.5 * sign * g.A0
    key, y, x, u = _crossing(xp, a, -sign * g.W0, c, g.kappa, ws,
                             _level_now(a, -sign * g.W0, c, vtol), g.A0)
    return xp.where(up | down, key, xp.inf), y, x, u


def _to_time(xp, kappa, ws, key, y, x, u):
    """The time ``τ`` of a crossing found by :func:`_crossing` (``inf`` where ``key`` is)."""
    pos, neg = kappa > 0, kappa < 0
    us = xp.where((u > 0) & (u < 1), u, 0.5)
    tau = xp.where(pos, 2.0 * xp.masked("arctan2", pos, y, x) / ws,
                   xp.where(neg, xp.masked("log1p", neg, 2.0 * us / (1.0 - us)) / ws, 2.0 * u))
    return xp.where(key < xp.inf, tau, xp.inf)


def _force_rise_time(xp, g: _Seg, fa, s, da, level, vtol):
    """Time from the segment start until the contact force rises through ``level`` [force]
    (``inf``: never in this segment): a stuck braked vehicle's break-away."""
    w = xp.sqrt(xp.abs(g.kappa))
    ws = xp.where(w > 0, w, 1.0)
    key, y, x, u = _force_rises(xp, g, fa, s, da, level, ws, vtol)
    return _to_time(xp, g.kappa, ws, key, y, x, u)


def _end_force(xp, law, D, st):
    """Contact force at the end of a segment, ``D`` [length] clamped to the segment's range
    ``[lo, hi]`` (an overshoot at rounding level times a very stiff unloading slope is not a
    force). With no braking the force is monotone along each segment (``D`` is monotone while
    ``F >= 0``), so its peak is the larger of the forces at the two ends (with braking, see
    :func:`_turning_deformations`)."""
    return law.force(xp.minimum(xp.maximum(D, st["lo"]), st["hi"]), 0.0, st)

