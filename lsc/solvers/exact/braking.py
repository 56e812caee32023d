"""Braking in the exact backend's one-scene solve: when a sliding vehicle stops, and where the
force turns inside a segment (with friction the deformation need not be monotone).

Braking adds two events per braked vehicle. Break-away (the net contact force ``∓F`` through the
static limit ``μ_s m g``) is a level of ``F``, hence of ``D``: a quadratic like the others. A
sliding vehicle's stop (its velocity through zero) is not, while it is in contact with a moving
vehicle (the reference point decelerates uniformly beside the oscillation): its acceleration has
closed-form zeros, between which the velocity is monotone, and a safeguarded Newton iteration
finds the zero in the first bracket to the last bit (:func:`_stop_time`). Against a held vehicle
the velocity is the closing rate itself, and its zero is the quadratic's again. At a stop the
velocity is set to zero exactly; a held vehicle stays exactly where it is.

A sliding vehicle's velocity in a segment, v_i(τ) = v_i(0) + Acm τ + share ΔW(τ), is not a
polynomial in any one substitution (the uniform deceleration of the reference point beside the
oscillation), so its zero is found numerically, to the last bit: its acceleration
Acm + share D''(τ) is a constant plus a sinusoid (or two exponentials), whose zeros are in closed
form, so v_i is monotone between them; the first interval where d v_i (d: the direction of
sliding) falls from positive to non-positive brackets the stop, which a safeguarded Newton
iteration then finds.
"""

from __future__ import annotations

import itertools
import math

from .kernels import _PY, _Seg, _basis, _crossing, _to_time


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

