"""Exact piecewise backend: two vehicles, IF-D hysteresis with piecewise-linear branches.

Inside a segment (frozen discrete state) the contact force is affine in the deformation,
``F = fa + s (D - da)`` (:class:`~lsc.contact.HysteresisLaw`), so with ``μ = m1 m2/(m1+m2)``
the relative motion obeys ``μ D'' = -(fa + s (D - da)) + μ c`` while the centre of mass moves
with constant acceleration ``A`` (``c = b1/m1 - b2/m2``, ``A = (b1+b2)/M`` for constant extra
forces ``b1, b2`` per vehicle [force]: sliding friction ``-μ_i m_i g dir_i`` of a braked vehicle,
zero otherwise). A vehicle its brakes hold (stuck) does not move at all: the relative motion is
then the other vehicle's alone against a fixed one (its own mass for ``μ``; both held: nothing
moves). With ``κ = s/μ``
[1/s²], ``D0, W0`` the deformation [length] and closing rate [velocity] and ``A0 = D''(0)``
[acceleration] at the segment start, for every sign of ``κ``

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

Braking adds two events per braked vehicle. Break-away (the net contact force ``∓F`` through the
static limit ``μ_s m g``) is a level of ``F``, hence of ``D``: a quadratic like the others. A
sliding vehicle's stop (its velocity through zero) is not, while it is in contact with a moving
vehicle (the reference point decelerates uniformly beside the oscillation): its acceleration has
closed-form zeros, between which the velocity is monotone, and a safeguarded Newton iteration
finds the zero in the first bracket to the last bit (:func:`_stop_time`). Against a held vehicle
the velocity is the closing rate itself, and its zero is the quadratic's again. At a stop the
velocity is set to zero exactly; a held vehicle stays exactly where it is.

A post-failure curve (bumper failure) needs nothing of its own: the law follows the spliced
loading curve, whose failure point is a breakpoint where the next piece starts at its own force
(a step), and every segment starts from its own piece's ``fa + s (D0 - da)``.

The transitions between segments are the law's own ``on_event``, never re-derived here: on
Python scalars for :func:`solve` (through :func:`~lsc.solvers.segments.run_segments`) and on
NumPy arrays of many scenes at once in :func:`solve_batch` (which has no braking: braked
scenes are solved one by one). The brakes' transitions are the model's
(:class:`~lsc.effects.BrakeEffect`). The kernels are written once against a small array
namespace (NumPy, or :data:`_PY` on Python floats) and shared by both paths.
"""

from __future__ import annotations

import bisect
import itertools
import math
import time
from dataclasses import dataclass

import numpy as np

from ..contact import BIG, MODE_OPEN, STATUS, HysteresisLaw
from ..curves import Curve
from ..errors import SceneError
from ..scene import Hysteresis, Restitution, UnloadingStiffness, UnloadingTable
from .base import Backend
from .segments import Step, build_result, run_segments

__all__ = ["BACKEND", "applies", "why_not", "solve", "solve_batch", "batch_params", "BATCH_STATUS"]

#: Status codes of :func:`solve_batch`: the law's :data:`~lsc.contact.STATUS` and two of its own.
BATCH_STATUS = {
    **STATUS,
    10: "event limit reached before the crash was over (raise max_events)",
    11: ("no further event although the crash is not over (the contact never separates), "
         "or the solution became non-finite"),
}
EVENT_LIMIT, NO_EVENT = 10, 11

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


# ============================================================================ braking (one scene)
# A sliding vehicle's velocity in a segment, v_i(τ) = v_i(0) + Acm τ + share ΔW(τ), is not a
# polynomial in any one substitution (the uniform deceleration of the reference point beside the
# oscillation), so its zero is found numerically, to the last bit: its acceleration
# Acm + share D''(τ) is a constant plus a sinusoid (or two exponentials), whose zeros are in closed
# form, so v_i is monotone between them; the first interval where d v_i (d: the direction of
# sliding) falls from positive to non-positive brackets the stop, which a safeguarded Newton
# iteration then finds.

def _vehicle_share(g: _Seg, i: int):
    """``(v_i(0), share)``: vehicle ``i`` moves by ``share ΔD`` beside the reference point."""
    return (g.v1, g.r2) if i == 0 else (g.v2, -g.r1)


def _ddot(g: _Seg, tau: float) -> float:
    """``D''(τ)`` [acceleration] (``D' = W0 + A0 S - κ W0 C``)."""
    k = g.kappa
    if k > 0:
        w = math.sqrt(k)
        return g.A0 * math.cos(w * tau) - g.W0 * w * math.sin(w * tau)
    if k < 0:
        w = math.sqrt(-k)
        return g.A0 * math.cosh(w * tau) + g.W0 * w * math.sinh(w * tau)
    return g.A0


def _turns(g: _Seg, share: float, tau_max: float):
    """Times in ``(0, τ_max)``, increasing, where vehicle's acceleration ``Acm + share D''(τ)``
    changes sign (its velocity is monotone between them)."""
    k, Acm = g.kappa, g.Acm
    if k > 0:
        # Acm + P cos θ - Q sin θ = Acm + R cos(θ + φ), θ = ωτ
        w = math.sqrt(k)
        P, Q = share * g.A0, share * g.W0 * w
        R = math.hypot(P, Q)
        if not R > abs(Acm):
            return
        beta, phi = math.acos(-Acm / R), math.atan2(Q, P)
        first = sorted((b - phi) % (2.0 * math.pi) for b in (beta, -beta))
        th_max = w * tau_max
        n = 0
        while True:
            for r in first:
                th = r + 2.0 * math.pi * n
                if not th < th_max:
                    return
                if th > 0:
                    yield th / w
            n += 1
    elif k < 0:
        # Acm + P u + Q/u with u = exp(λτ) > 1: the roots of P u² + Acm u + Q
        w = math.sqrt(-k)
        P, Q = share * 0.5 * (g.A0 + g.W0 * w), share * 0.5 * (g.A0 - g.W0 * w)
        roots = []
        if P == 0:
            if Acm != 0:
                roots = [-Q / Acm]
        else:
            disc = Acm * Acm - 4.0 * P * Q
            if disc > 0:
                q = -0.5 * (Acm + math.copysign(math.sqrt(disc), Acm))
                roots = [q / P] + ([Q / q] if q != 0 else [])
        for t in sorted(math.log(u) / w for u in roots if u > 1):
            if t < tau_max:
                yield t


def _root_down(f, df, a: float, b: float, fa: float, fb: float) -> float:
    """The zero of ``f``, decreasing on ``[a, b]`` with ``f(a) > 0 >= f(b)``, to the last bit:
    Newton's method kept inside the bracket (``rtsafe``), bisection where it would leave it or
    converges too slowly. Returns the iterate with the smallest ``|f|``."""
    if fb == 0:
        return b
    x = a + (b - a) * fa / (fa - fb)       # a secant start inside the bracket
    if not a < x < b:
        x = 0.5 * (a + b)
    fx, dfx = f(x), df(x)
    best = (abs(fx), x)
    dx_old = dx = b - a
    for _ in range(200):
        if fx > 0:
            a = x
        elif fx < 0:
            b = x
        else:
            return x
        if (((x - b) * dfx - fx) * ((x - a) * dfx - fx) > 0) or abs(2.0 * fx) > abs(dx_old * dfx):
            dx_old, dx = dx, 0.5 * (b - a)
            x_new = a + dx
        else:
            dx_old, dx = dx, fx / dfx
            x_new = x - dx
        if x_new == x or not a <= x_new <= b or abs(dx) <= 2.0 * math.ulp(x_new):
            if a <= x_new <= b and x_new != x:
                fn = f(x_new)
                best = min(best, (abs(fn), x_new))
            return best[1]
        x = x_new
        fx, dfx = f(x), df(x)
        best = min(best, (abs(fx), x))
    return best[1]


def _stop_time(g: _Seg, i: int, d: float, tau_max: float) -> float:
    """Time from the segment start until vehicle ``i``, sliding in direction ``d`` (±1), stops:
    ``d v_i`` falls through zero (``inf``: not before ``τ_max``). At once when it starts at or
    below zero and falls (a contact event at the same instant came first); not when it starts at
    zero and rises (just broken away, or reversed)."""
    v0, share = _vehicle_share(g, i)
    k, A0, W0, Acm = g.kappa, g.A0, g.W0, g.Acm

    def f(t):
        S, C = _basis(_PY, t, k)
        return d * (v0 + Acm * t + share * (A0 * S - k * W0 * C))

    def df(t):
        return d * (Acm + share * _ddot(g, t))

    f0, a0 = d * v0, df(0.0)
    if f0 <= 0 and a0 < -1e-12 * (abs(Acm) + abs(share * A0)):
        return 0.0
    if not tau_max > 0:
        return math.inf
    if Acm == 0 and abs(share) == 1 and v0 == W0 * share:
        # against a held vehicle (at rest, exactly): the velocity is ±W, whose zero is in closed
        # form, the same as the common velocity's (so a tie with it is exact, and goes to it)
        s = d * share
        w = math.sqrt(abs(k))
        ws = w if w > 0 else 1.0
        key, y, x, u = _crossing(_PY, -0.25 * k * W0 * s, A0 * s, W0 * s, k, ws, False)
        tau = _to_time(_PY, k, ws, key, y, x, u)
        return tau if tau <= tau_max else math.inf
    a, fa = 0.0, f0
    for b in itertools.chain(_turns(g, share, tau_max), (tau_max,)):  # lazily: stops early
        fb = f(b)
        if fa > 0 and fb <= 0:
            return _root_down(f, df, a, b, fa, fb)
        a, fa = b, fb
    return math.inf


def _turning_deformations(g: _Seg, tau: float) -> list:
    """Deformations where the closing rate ``W`` passes zero inside ``(0, τ)`` (at most one
    maximum and one minimum: later ones repeat them): with a constant friction force the
    deformation, and with it the force, need not be monotone along a segment."""
    k, W0, A0 = g.kappa, g.W0, g.A0
    ts = []
    if k > 0:
        # W = W0 cos ωτ + (A0/ω) sin ωτ = R cos(ωτ - ψ): zero at ωτ = ψ + π/2 + nπ
        w = math.sqrt(k)
        th = (math.atan2(A0 / w, W0) + 0.5 * math.pi) % math.pi
        th = th if th > 0 else math.pi
        while th < w * tau and len(ts) < 2:
            ts.append(th / w)
            th += math.pi
    elif k < 0:
        w = math.sqrt(-k)
        if A0 != 0:
            x = -W0 * w / A0     # tanh(λτ) = x
            if -1 < x < 1:
                ts.append(math.atanh(x) / w)
    elif A0 != 0:
        ts.append(-W0 / A0)
    out = []
    for t in ts:
        if 0 < t < tau:
            S, C = _basis(_PY, t, k)
            out.append(g.D0 + (W0 * S + A0 * C))
    return out


# ============================================================================ applicability
#: The exact backend's declaration: two vehicles with the IF-D law (any loading and unloading
#: curve, gaps, braking, failure); its batch path has no braking and no post-failure curve.
BACKEND = Backend(
    name="exact", module=__name__, options=("t_end", "n_samples", "max_events"), exact=True,
    cost=1.0, vehicles=(2, 2),
    solves=frozenset({"law:ifd", "loading:linear", "loading:table", "unloading:restitution",
                   "unloading:stiffness", "unloading:table", "effect:brake", "effect:failure",
                      "effect:post-failure", "gap:open"}),
    batch=frozenset({"law:ifd", "loading:linear", "loading:table", "unloading:restitution",
                   "unloading:stiffness", "unloading:table", "effect:failure", "gap:open"}),
    batch_options=("max_events",),
    summary="exact piecewise solution of two vehicles with piecewise-linear IF-D curves")


def why_not(scene) -> str | None:
    """Why the exact backend does not apply to ``scene`` (``None`` if it does)."""
    from ..model import HybridModel

    return BACKEND.why_not(HybridModel(scene))


def applies(scene) -> bool:
    """True when the exact backend solves ``scene``."""
    return why_not(scene) is None


# ============================================================================ one scene
class _ScalarTransitions:
    """The model as :func:`run_segments` sees it, with the law's transitions (its own
    ``on_event``) evaluated on Python floats and lists (namespace :data:`_PY`), about 10x cheaper
    than NumPy on 0-d values. Everything else is the model's own."""

    def __init__(self, model):
        self._model = model
        self._pp = [{k: (v.tolist() if np.ndim(v) else float(v)) for k, v in law.params.items()}
                    for law in model.laws]
        for pp in self._pp:   # relative to the anchor, any rebound width is resolved
            pp["wres"] = 0.0

    def __getattr__(self, name):
        return getattr(self._model, name)

    def apply_event(self, i, t, y, disc, p, xp=None):
        """As ``HybridModel.apply_event``, on Python scalars for the contact laws."""
        k, w = self._model.events[i]
        if k >= self._model.K:  # an effect (brake, bumper failure): the model's own, on NumPy
            return self._model.apply_event(i, t, y, disc, p)
        D, Dd = self._model.deformation(np.asarray(y, float), p)
        new = list(disc)
        new[k] = self._model.laws[k].on_event(w, float(D[k]), float(Dd[k]), disc[k],
                                              self._pp[k], _PY)
        return new


def solve(model, *, t_end=None, n_samples: int = 1000, max_events: int = 10_000):
    """Solve a two-vehicle hysteresis ``model`` exactly, segment by segment, as a Result.

    ``t_end`` [time]: simulate until then (must not cut the crash); ``n_samples``: points in the
    sampled series (every event is a sample); ``max_events``: limit on discrete events.

    Braked vehicles slide (constant friction force) or stick (held, ``a = 0``) as their
    :class:`~lsc.effects.BrakeEffect` says; the run ends when the model says the crash is over
    (a braked vehicle still sliding after the last separation produces its stop event), and
    ``v_final`` is taken at the last separation. Peaks are exact: with friction the force need
    not be monotone along a segment, so its turning points count as well.
    """
    BACKEND.check(model)
    p = model.params
    m1, m2 = (float(m) for m in p["m"])
    gap = float(p["gap"][0])
    ev_index = [model.events.index((0, w)) for w in range(3)]
    vtol = 1e-12 * model.v_scale

    law = model.laws[0]
    peak = [0.0]
    # a declared bumper failure (of contact 0): its part, event and force
    failure = [(model.parts.index(f), model.events.index((model.parts.index(f), 0)),
                float(f.params["force"])) for f in getattr(model, "failures", [])]
    ev_index += [ev for _, ev, _ in failure]
    # declared brakes: part, vehicle, sliding friction force per direction [force], static
    # limit [force], and the events (stop, break-away: forward for the target, whose net contact
    # force F pushes it forward; backward for the bullet, pushed back by F)
    brakes = []
    for b in getattr(model, "brakes", []):
        j, m = model.parts.index(b), (m1, m2)[b.i]
        gg = float(b.params["g"])
        brakes.append((j, b.i, float(b.params["mu"]) * m * gg, float(b.params["mus"]) * m * gg,
                       model.events.index((j, 0)), model.events.index((j, 1 if b.i else 2))))
    mass = (m1, m2)
    peak_a = [0.0, 0.0]

    def advance(t0, y0, disc, horizon):
        st = disc[0]
        x1, x2, v1, v2 = (float(v) for v in y0[:4])
        hold, push = [False, False], [0.0, 0.0]
        for j, i, slide, _, _, _ in brakes:
            if disc[j]["slide"]:
                push[i] = -slide * disc[j]["dir"]
            else:
                hold[i] = True
        g = _setup(x1, x2, v1, v2, m1, m2, gap, st["fa"], st["s"], st["da"], push[0], push[1],
                   hold[0], hold[1])
        armed = [ff for j, _, ff in failure if not disc[j]["failed"]]
        fail = (st["fa"], st["s"], st["da"], armed[0]) if armed else None
        tau, which, sep = _next_event(_PY, g, st["da"], st["lo"], st["wl"], st["hi"], st["vm"],
                                      vtol, fail)
        event = ev_index[which] if tau < math.inf else None
        stopped = None
        for j, i, _, limit, ev_stop, ev_break in brakes:
            if disc[j]["slide"]:
                cand = _stop_time(g, i, disc[j]["dir"], min(tau, horizon - t0))
                ev = ev_stop
            else:
                cand = _force_rise_time(_PY, g, st["fa"], st["s"], st["da"], limit, vtol)
                ev = ev_break
            if cand < tau or (cand == tau and event is not None and ev < event):
                tau, event, stopped = cand, ev, (i if ev == ev_stop else None)
        if not t0 + tau <= horizon:
            tau, event, stopped = horizon - t0, None, None
        sep = bool(sep)
        end = list(_state(_PY, tau, g, sep))
        if stopped is not None:
            end[2 + stopped] = 0.0   # the stop, exactly (held at zero while stuck)
        if not brakes:
            peak[0] = max(peak[0], g.F0, _end_force(_PY, law, end[0] - end[1] - gap, st))
        else:
            # the force over the segment: at its ends and where D turns inside it
            Ds = [g.D0, end[0] - end[1] - gap, *_turning_deformations(g, tau)]
            Fs = [_end_force(_PY, law, D, st) for D in Ds]
            lo_f, hi_f = min(Fs), max(Fs)
            peak[0] = max(peak[0], hi_f)
            for i, sign in ((0, -1.0), (1, 1.0)):
                if hold[i]:
                    continue
                for F in (hi_f, lo_f):
                    a = (sign * F + push[i]) / mass[i]
                    if abs(a) > abs(peak_a[i]):
                        peak_a[i] = a

        def dense(tt, g=g, t0=t0, t1=t0 + tau, stopped=stopped, sep=sep):
            tt = np.asarray(tt, float)
            with np.errstate(all="ignore"):
                out = np.array(_state(np, tt - t0, g, sep))
            if stopped is not None:  # at rest from the stop on, as the state is
                out[2 + stopped] = np.where(tt >= t1, 0.0, out[2 + stopped])
            return out

        return Step(t0 + tau, np.array(end), event, dense, 1, 0)

    start = time.perf_counter()
    segments, events, y, disc, totals = run_segments(_ScalarTransitions(model), advance,
                                                     t_end=t_end, max_events=max_events)
    wall = time.perf_counter() - start
    stats = {"steps": totals["steps"], "rhs_evaluations": 0, "segments": len(segments),
             "wall_time": wall}
    r = build_result(model, segments, events, y, disc, method="exact", tolerances={},
                     stats=stats, n_samples=n_samples, y_post=totals["y_post"])
    # The exact peaks (at event points and turning points, see _end_force) rather than the
    # largest samples.
    r.peak_force = np.array([peak[0]])
    r.peak_acceleration = (np.array(peak_a) if brakes else
                           np.array([-peak[0] / m1, peak[0] / m2]))
    r.peak_acceleration_g = r.peak_acceleration / model.scene.g
    return r


def _end_force(xp, law, D, st):
    """Contact force at the end of a segment, ``D`` [length] clamped to the segment's range
    ``[lo, hi]`` (an overshoot at rounding level times a very stiff unloading slope is not a
    force). With no braking the force is monotone along each segment (``D`` is monotone while
    ``F >= 0``), so its peak is the larger of the forces at the two ends (with braking, see
    :func:`_turning_deformations`)."""
    return law.force(xp.minimum(xp.maximum(D, st["lo"]), st["hi"]), 0.0, st)


# ============================================================================ many scenes
class _Rows:
    """A per-member table standing in for one of the law's 1-D parameter arrays.

    Held column-major, ``c[j, i]`` = entry ``j`` of member ``i`` (shape ``(n, B)``), possibly
    restricted to members ``s0:s1``. ``rows[j]`` with an integer gives entry ``j`` of every member;
    with an index array each member's own entry; a slice keeps a table. ``np.searchsorted(rows,
    v)`` (NumPy forwards it to :meth:`searchsorted`) searches each member's own row for its own
    ``v``. This lets the law's transition code, written for one scene's 1-D tables, run unchanged
    on a batch.
    """

    __slots__ = ("c", "s0", "s1")

    def __init__(self, c, s0=0, s1=None):
        self.c, self.s0, self.s1 = c, s0, c.shape[1] if s1 is None else s1

    def __getitem__(self, idx):
        if isinstance(idx, slice):
            return _Rows(np.ascontiguousarray(self.c[idx]), self.s0, self.s1)
        idx = np.asarray(idx)
        if idx.ndim == 0:
            return self.c[int(idx), self.s0:self.s1]
        flat = idx.astype(np.intp) * self.c.shape[1] + np.arange(self.s0, self.s1)
        return self.c.reshape(-1)[flat]

    def searchsorted(self, v, side="left", sorter=None):
        cmp = np.less_equal if side == "right" else np.less
        count = np.zeros(self.s1 - self.s0, dtype=np.intp)
        for row in self.c[:, self.s0:self.s1]:
            count += cmp(row, v)
        return count

    def members(self, s0, s1):
        """The same table for members ``s0:s1`` of this one (a view)."""
        return _Rows(self.c, self.s0 + s0, self.s0 + s1)

    def take(self, keep):
        return _Rows(np.take(self.c[:, self.s0:self.s1], keep, axis=1))


class _NumpyRuns:
    """``numpy`` for the batch: ``masked`` evaluates a function only where a mask holds (each
    segment kind its own functions), and ``where`` hands back a branch as it is when its condition
    is the same for every member, instead of copying element by element: most of the law's branch
    selections, on a run of members in one mode and after one event. Same results as ``numpy``.
    """

    def __getattr__(self, name):
        return getattr(np, name)

    @staticmethod
    def masked(name, mask, *args):
        """``np.<name>(*args)`` evaluated only where ``mask`` (0 elsewhere)."""
        out = np.zeros(np.broadcast_shapes(np.shape(mask), *(np.shape(a) for a in args)))
        getattr(np, name)(*args, out=out, where=mask)
        return out

    @staticmethod
    def where(cond, a, b):
        if isinstance(cond, np.ndarray) and cond.ndim == 1 and cond.size > 64:
            if cond.all():
                return a
            if not cond.any():
                return b
        return np.where(cond, a, b)


_NPR = _NumpyRuns()


def _cols(a) -> _Rows:
    """A :class:`_Rows` from a ``(B, n)`` array."""
    return _Rows(np.ascontiguousarray(np.asarray(a, float).T))


def _as_rows(x, B, name, n_min=1):
    a = np.asarray(x, float)
    if a.ndim == 1:
        a = np.broadcast_to(a, (B, a.size))
    if a.ndim != 2 or a.shape[0] != B or a.shape[1] < n_min:
        raise ValueError(f"{name} must be an array (B, n) with n >= {n_min} (B = {B}), "
                         f"got shape {np.shape(x)}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite")
    return np.ascontiguousarray(a)


def _batch_inputs(params: dict) -> dict:
    """Validated, broadcast float arrays from the :func:`solve_batch` parameters."""
    known = {"m1", "m2", "v1", "v2", "gap", "stiffness", "load_d", "load_f", "load_end_slope",
             "e", "unload_stiffness", "unload_d", "unload_f", "g", "failure_force"}
    braking = {k for k in params if "mu" in k or "brake" in k}
    if braking:
        raise ValueError(f"braking ({', '.join(sorted(braking))}) is not batched: solve_batch has "
                         "no friction forces; solve braked scenes one by one with exact.solve")
    unknown = set(params) - known
    if unknown:
        raise ValueError(f"unknown batch parameter(s) {sorted(unknown)}; accepted: {sorted(known)}")
    for k in ("m1", "m2", "v1", "v2"):
        if k not in params:
            raise ValueError(f"batch parameter {k!r} is required")
    base = [np.asarray(params[k], float) for k in ("m1", "m2", "v1", "v2")]
    base.append(np.asarray(params.get("gap", 0.0), float))
    m1, m2, v1, v2, gap = (np.ascontiguousarray(a, float) for a in np.broadcast_arrays(*base))
    if m1.ndim != 1:
        raise ValueError("m1, m2, v1, v2, gap must be scalars or 1-D arrays")
    B = m1.size
    if not (np.all(m1 > 0) and np.all(m2 > 0) and np.all(np.isfinite(m1 + m2))):
        raise ValueError("masses must be positive and finite")
    if not (np.all(np.isfinite(v1 - v2)) and np.all(gap >= 0) and np.all(np.isfinite(gap))):
        raise ValueError("speeds must be finite and gaps finite and >= 0")
    out = {"m1": m1, "m2": m2, "v1": v1, "v2": v2, "gap": gap, "B": B}
    # loading
    if "stiffness" in params:
        if "load_d" in params or "load_f" in params:
            raise ValueError("give either stiffness or load_d/load_f, not both")
        k = np.broadcast_to(np.asarray(params["stiffness"], float), (B,))
        if not np.all((k > 0) & np.isfinite(k)):
            raise ValueError("stiffness must be positive and finite")
        out.update(load_d=np.zeros((B, 1)), load_f=np.zeros((B, 1)), end=k.copy())
    else:
        if "load_d" not in params or "load_f" not in params:
            raise ValueError("the loading is stiffness (B,) or load_d, load_f (B, n)")
        end = params.get("load_end_slope")
        d = _as_rows(params["load_d"], B, "load_d", 1 if end is not None else 2)
        f = _as_rows(params["load_f"], B, "load_f", d.shape[1])
        if f.shape != d.shape:
            raise ValueError("load_d and load_f must have the same shape")
        if not (np.all(d[:, 0] == 0) and np.all(np.diff(d, axis=1) > 0) and np.all(f >= 0)):
            raise ValueError("each loading table starts at D = 0 with strictly increasing "
                             "deformations and forces >= 0")
        if end is not None:
            end = np.broadcast_to(np.asarray(end, float), (B,)).copy()
            if not np.all(np.isfinite(end)):
                raise ValueError("load_end_slope must be finite (give None for tables that end)")
        out.update(load_d=d, load_f=f, end=end)
    # unloading
    kinds = [k for k in ("e", "unload_stiffness", "unload_d") if k in params]
    if len(kinds) != 1:
        raise ValueError("give exactly one unloading rule: e (B,), unload_stiffness (B,) or "
                         "unload_d, unload_f (B, n) in time order")
    if kinds[0] == "e":
        e = np.broadcast_to(np.asarray(params["e"], float), (B,)).copy()
        if not np.all((e >= 0) & (e <= 1)):
            raise ValueError("restitution e must be in [0, 1]")
        out["e"] = e
    elif kinds[0] == "unload_stiffness":
        su = np.broadcast_to(np.asarray(params["unload_stiffness"], float), (B,)).copy()
        if not np.all((su > 0) & np.isfinite(su)):
            raise ValueError("unload_stiffness must be positive and finite")
        out["su"] = su
    else:
        ud = _as_rows(params["unload_d"], B, "unload_d", 2)
        uf = _as_rows(params.get("unload_f"), B, "unload_f", 2)
        if uf.shape != ud.shape:
            raise ValueError("unload_d and unload_f must have the same shape")
        if not (np.all(np.diff(ud, axis=1) < 0) and np.all(uf[:, 0] > 0) and np.all(uf[:, -1] == 0)
                and np.all(uf >= 0)):
            raise ValueError("each unloading table runs in time order from (D0, F0 > 0) to zero "
                             "force with strictly decreasing deformations")
        out.update(unload_d=ud, unload_f=uf)
    g = params.get("g")
    out["g"] = None if g is None else np.broadcast_to(np.asarray(g, float), (B,))
    ff = params.get("failure_force")
    if ff is not None:
        ff = np.broadcast_to(np.asarray(ff, float), (B,)).copy()
        if np.any(ff <= 0):
            raise ValueError("failure_force must be positive (inf or nan: none)")
        ff[np.isnan(ff)] = np.inf
    out["failure_force"] = ff
    return out


def _batch_law(P: dict):
    """One :class:`HysteresisLaw` (its code and its shape constants: table lengths, unloading
    kind) and the batched parameter dict ``p`` for it, built for every member with the same
    arithmetic as ``HysteresisLaw.__init__`` for one scene (the tests compare them), tables as
    :class:`_Rows`. Returns ``(law, p, per_member)``, the keys of ``p`` that vary by member."""
    d, f, end = P["load_d"], P["load_f"], P["end"]
    B, n = d.shape
    dT, fT = np.ascontiguousarray(d.T), np.ascontiguousarray(f.T)   # (n, B): entry, member
    ld, lf, ls, le = (np.empty((n + 1, B)) for _ in range(4))
    ld[:n], ld[n] = dT, BIG
    lf[:n], lf[n] = fT, fT[n - 1]
    dd = dT[1:] - dT[:-1]
    with np.errstate(all="ignore"):
        ls[:n - 1] = (fT[1:] - fT[:-1]) / dd
    ls[n - 1] = 0.0 if end is None else end
    ls[n] = 0.0
    le[0] = 0.0
    np.cumsum(0.5 * (fT[1:] + fT[:-1]) * dd, axis=0, out=le[1:n])
    le[n] = le[n - 1]
    p = {"ld": _Rows(ld), "lf": _Rows(lf), "ls": _Rows(ls), "le": _Rows(le), "wres": 0.0}
    curve = Curve(d[0], f[0], None if end is None else end[0])
    if "e" in P:
        rule = Restitution(float(P["e"][0]))
    elif "su" in P:
        rule = UnloadingStiffness(float(P["su"][0]))
    else:
        rule = UnloadingTable(P["unload_d"][0], P["unload_f"][0])
    law = HysteresisLaw(Hysteresis(curve, rule))
    if "e" in P:
        p.update(e=P["e"], ud=law.params["ud"], uf=law.params["uf"], ue=law.params["ue"])
    elif "su" in P:
        p.update(su=P["su"], ud=law.params["ud"], uf=law.params["uf"], ue=law.params["ue"])
    else:
        ud, uf = P["unload_d"][:, ::-1], P["unload_f"][:, ::-1]
        ud = ud - ud[:, -1:]
        p.update(ud=_cols(ud), uf=_cols(uf),
                 ue=np.sum(0.5 * (uf[:, 1:] + uf[:, :-1]) * np.diff(ud, axis=1), axis=1))
    per_member = [k for k, v in p.items() if isinstance(v, _Rows)]
    per_member += [k for k in ("e", "su") if k in p]
    if "unload_d" in P:
        per_member.append("ue")
    return law, p, per_member


def solve_batch(params: dict, *, max_events: int = 10_000) -> dict:
    """Exact metrics of many two-vehicle hysteresis scenes at once (vectorised over scenes).

    Parameters (arrays over ``B`` scenes, scene units; scalars broadcast)
    ----------------------------------------------------------------------
    m1, m2 : (B,) masses [mass]; v1, v2 : (B,) initial speeds [velocity]; gap : (B,) [length]
    stiffness : (B,) linear loading [force/length], or load_d, load_f : (B, n) loading tables
        (``D = 0`` first, equal length ``n``) with optional load_end_slope : (B,) (all extend or
        none) [force/length]
    e : (B,) restitution, or unload_stiffness : (B,) [force/length], or unload_d, unload_f :
        (B, nu) measured rebound curves in time order (mapped onto ``(D_max, F_max)``)
    g : optional (B,) gravity [acceleration], for ``peak_acceleration_g``
    failure_force : optional (B,) bumper failure force [force] (inf or nan: none), for
        ``failure_time``

    No braking: the batch has no friction forces (:func:`batch_params` rejects braked scenes,
    and brake parameters here are an error); solve braked scenes one by one with :func:`solve`.

    Every member advances its own segment each iteration (finished members leave the batch);
    the transitions are the law's ``on_event`` on arrays (:class:`_Rows` gives per-member table
    lookups). Returns a dict of the Result metrics: ``delta_v, v_final, peak_acceleration``
    (B, 2) [velocity, acceleration], ``duration, peak_force, max_deformation,
    permanent_deformation, restitution`` (velocity definition), ``restitution_energy,
    energy_absorbed, energy_returned, contact_time, separation_time, failure_time`` (B,; the
    failure time is NaN where the force never exceeds the failure force), ``events`` (B,) and
    ``status`` (B,): 0 ok, else a code of :data:`BATCH_STATUS` (the metrics are then ``nan``).
    """
    P = _batch_inputs(params)
    law, p, per_member = _batch_law(P)
    B = P["B"]
    out = {k: np.full(B, np.nan) for k in ("v1", "v2", "dmax", "fmax", "dperm", "ec", "er",
                                            "fpk", "tc", "ts", "tf")}
    out_status = np.zeros(B, dtype=int)
    out_events = np.zeros(B, dtype=int)
    v1, v2 = P["v1"], P["v2"]
    # the working set: one entry per member still in the batch (ix: its index in the input)
    w = {"ix": np.arange(B), "m1": P["m1"], "m2": P["m2"], "gap": P["gap"],
         "x1": np.zeros(B), "x2": np.zeros(B), "v1": v1.copy(), "v2": v2.copy(), "t": np.zeros(B),
         "fpk": np.zeros(B), "ts": np.full(B, np.nan), "tf": np.full(B, np.nan),
         "ff": np.full(B, np.inf) if P["failure_force"] is None else P["failure_force"],
         "vscale": np.maximum(np.maximum(np.abs(v1), np.abs(v2)),
                              np.maximum(np.abs(v1 - v2), 1e-300))}
    with np.errstate(all="ignore"):
        st = law.init(w["x1"] - w["x2"] - w["gap"], v1 - v2, p, np)
        st = {k: np.array(np.broadcast_to(v, (B,))) for k, v in st.items()}
        touching = st["mode"] != MODE_OPEN
        w["nev"] = touching.astype(int)
        w["tc"] = np.where(touching, 0.0, np.nan)
        w["status"] = st["status"].astype(int)
        _fail_on_entry(law, w["x1"] - w["x2"] - w["gap"], st, w)
        while True:
            # members whose crash is over (or cannot go on) leave the batch with their record
            over = (st["mode"] == MODE_OPEN) & (w["v1"] - w["v2"] <= 1e-12 * w["vscale"])
            code = np.where(w["status"] != 0, w["status"],
                            np.where(over, 0, np.where(w["nev"] >= max_events, EVENT_LIMIT, -1)))
            fin = code >= 0
            if fin.any():
                j = w["ix"][fin]
                for key in ("v1", "v2", "fpk", "tc", "ts", "tf"):
                    out[key][j] = w[key][fin]
                for key in ("dmax", "fmax", "dperm", "ec", "er"):
                    out[key][j] = st[key][fin]
                out_status[j] = code[fin]
                out_events[j] = w["nev"][fin]
                if fin.all():
                    break
            # one segment for every member: the earliest armed event and the state there
            n_live = w["ix"].size
            g = _setup(w["x1"], w["x2"], w["v1"], w["v2"], w["m1"], w["m2"], w["gap"],
                       st["fa"], st["s"], st["da"])
            fail = None
            if P["failure_force"] is not None:  # armed until it has fired (then inf)
                fail = (st["fa"], st["s"], st["da"], w["ff"])
            tau, which, sep = _next_event(_NPR, g, st["da"], st["lo"], st["wl"], st["hi"],
                                          st["vm"], 1e-12 * w["vscale"], fail)
            tau, which = np.broadcast_to(tau, (n_live,)), np.broadcast_to(which, (n_live,))
            bad = ~np.isfinite(tau)
            tau = np.where(bad, 0.0, tau)
            w["x1"], w["x2"], w["v1"], w["v2"] = _state(_NPR, tau, g,
                                                        np.broadcast_to(sep, (n_live,)))
            w["t"] = w["t"] + tau
            bad |= ~np.isfinite(w["x1"] + w["x2"] + w["v1"] + w["v2"])
            D, W = w["x1"] - w["x2"] - w["gap"], w["v1"] - w["v2"]
            w["fpk"] = np.maximum(w["fpk"], np.maximum(g.F0, _end_force(np, law, D, st)))
            # keep the members still running, grouped by (mode, event): the law's branch
            # selections (where) then see long runs of equal conditions, several times faster
            live = np.flatnonzero(~fin)
            key = (st["mode"] * 4 + which)[live].astype(np.int8)
            order = np.argsort(key, kind="stable")
            perm, key = live[order], key[order]
            w = {k: np.take(v, perm) for k, v in w.items()}
            st = {k: np.take(v, perm) for k, v in st.items()}
            p = {k: ((v.take(perm) if isinstance(v, _Rows) else np.take(v, perm))
                     if k in per_member else v) for k, v in p.items()}
            which, bad, D, W = (np.take(a, perm) for a in (which, bad, D, W))
            # the law's transition, on each run of members with the same (mode, event)
            b = perm.size
            cuts = [0, *(np.flatnonzero(np.diff(key)) + 1), b]
            parts = []
            for s0, s1 in zip(cuts[:-1], cuts[1:]):
                pg = {k: (v.members(s0, s1) if isinstance(v, _Rows) else v[s0:s1])
                      if k in per_member else v for k, v in p.items()}
                sg = {k: v[s0:s1] for k, v in st.items()}
                ng = law.on_event(which[s0:s1], D[s0:s1], W[s0:s1], sg, pg, _NPR)
                parts.append({k: np.broadcast_to(v, (s1 - s0,)) for k, v in ng.items()})
            new = {k: np.concatenate([pt[k] for pt in parts]) for k in st}
            for k in ("mode", "seg", "status"):
                new[k] = new[k].astype(int, copy=False)
            keep = bad | (which == 3)  # (a bumper failure changes no contact state)
            if keep.any():
                new = {k: np.where(keep, st[k], v) for k, v in new.items()}
                failed = (which == 3) & ~bad
                w["tf"] = np.where(failed, w["t"], w["tf"])
                w["ff"] = np.where(failed, np.inf, w["ff"])
            opened = (new["mode"] == MODE_OPEN) & (st["mode"] != MODE_OPEN)
            closed = (new["mode"] != MODE_OPEN) & (st["mode"] == MODE_OPEN)
            w["tc"] = np.where(closed & np.isnan(w["tc"]), w["t"], w["tc"])
            w["ts"] = np.where(opened, w["t"], w["ts"])
            w["nev"] = w["nev"] + ~bad
            w["status"] = np.where(bad, NO_EVENT, new["status"]).astype(int)
            st = new
            _fail_on_entry(law, D, st, w)
    return _batch_metrics(P, out, out_status, out_events)


def _fail_on_entry(law, D, st, w) -> None:
    """Bumper failure at a force *step*: where a segment starts above the failure force (a
    preloaded table's force at first touch, or at t = 0), the bumper failed at that instant,
    as a single solve reports it; the crossing event (:func:`_force_rises`) sees only a force
    that rises through the level inside a segment. Updates ``w["tf"]``, ``w["ff"]``."""
    failed = (law.force(D, 0.0, st) > w["ff"]) & np.isnan(w["tf"]) & (st["mode"] != MODE_OPEN)
    if failed.any():
        w["tf"] = np.where(failed, w["t"], w["tf"])
        w["ff"] = np.where(failed, np.inf, w["ff"])


def _batch_metrics(P, out, status, events) -> dict:
    """The Result metrics from each member's final velocities and hysteresis record."""
    ok = status == 0
    nan = np.where(ok, 1.0, np.nan)
    v0 = np.stack([P["v1"], P["v2"]], axis=1)
    vf = np.stack([out["v1"], out["v2"]], axis=1) * nan[:, None]
    fpk = out["fpk"] * nan
    with np.errstate(all="ignore"):
        res = {
            "delta_v": vf - v0,
            "v_final": vf,
            "peak_acceleration": np.stack([-fpk / P["m1"], fpk / P["m2"]], axis=1),
            "duration": (out["ts"] - out["tc"]) * nan,
            "peak_force": fpk,
            "max_deformation": out["dmax"] * nan,
            "permanent_deformation": out["dperm"] * nan,
            "restitution": (vf[:, 1] - vf[:, 0]) / (P["v1"] - P["v2"]),
            "restitution_energy": np.sqrt(out["er"] / out["ec"]) * nan,
            "energy_absorbed": out["ec"] * nan,
            "energy_returned": out["er"] * nan,
            "contact_time": out["tc"] * nan,
            "separation_time": out["ts"] * nan,
            "failure_time": out["tf"] * nan,
        }
        if P["g"] is not None:
            res["peak_acceleration_g"] = res["peak_acceleration"] / P["g"][:, None]
    res["events"] = events
    res["status"] = status
    return res


def batch_params(scenes) -> dict:
    """:func:`solve_batch` parameters from scenes the exact backend applies to, whose loading
    curves have equal numbers of points (all extending or none) and whose unloading rules are of
    one kind (tables of equal length)."""
    scenes = list(scenes)
    if not scenes:
        raise ValueError("no scenes")
    for i, sc in enumerate(scenes):
        reason = why_not(sc)
        if reason:
            raise ValueError(f"scene {i}: the exact backend does not apply: {reason}")
        if any(v.brake is not None for v in sc.vehicles):
            raise ValueError(f"scene {i}: braked scenes are not batched (solve_batch has no "
                             "friction forces): solve each with exact.solve")
        fail = sc.contacts[0].failure
        if fail is not None and fail.post_failure is not None:
            raise ValueError(f"scene {i}: scenes with a post-failure curve are not batched "
                             "(solve_batch has no failure point): solve each with exact.solve")
    laws = [sc.contacts[0].law for sc in scenes]
    curves = [law.loading for law in laws]
    if len({c.d.size for c in curves}) != 1 or len({c.extends for c in curves}) != 1:
        raise ValueError("the loading curves must have equal numbers of points, all extending "
                         "or none")
    kinds = {type(law.unloading) for law in laws}
    if len(kinds) != 1:
        raise ValueError("the unloading rules must all be of one kind")
    out = {"m1": [sc.masses[0] for sc in scenes], "m2": [sc.masses[1] for sc in scenes],
           "v1": [sc.speeds[0] for sc in scenes], "v2": [sc.speeds[1] for sc in scenes],
           "gap": [sc.contacts[0].gap for sc in scenes], "g": [sc.g for sc in scenes],
           "load_d": np.stack([c.d for c in curves]), "load_f": np.stack([c.f for c in curves])}
    if curves[0].extends:
        out["load_end_slope"] = [c.end_slope for c in curves]
    fails = [sc.contacts[0].failure for sc in scenes]
    if any(f is not None for f in fails):
        out["failure_force"] = [np.inf if f is None else f.force for f in fails]
    kind = kinds.pop()
    if kind is Restitution:
        out["e"] = [law.unloading.e for law in laws]
    elif kind is UnloadingStiffness:
        out["unload_stiffness"] = [law.unloading.stiffness for law in laws]
    else:
        if len({law.unloading.d.size for law in laws}) != 1:
            raise ValueError("the unloading tables must have equal numbers of points")
        out["unload_d"] = np.stack([np.asarray(law.unloading.d, float) for law in laws])
        out["unload_f"] = np.stack([np.asarray(law.unloading.f, float) for law in laws])
    return {k: np.asarray(v, float) for k, v in out.items()}
