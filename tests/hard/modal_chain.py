"""An independent solution of a chain of vehicles on linear IF-D contacts with a restitution,
written here from the physics and sharing no code with lsc: the reference the event tests hold
the integrators to.

Between events every contact is open (no force), loading (``F = k D``) or on its unloading line
(``F = k M + (k / e²)(D - M)``, ``M`` its max deformation), so the motion is linear,
``m x'' = -K x + b``, and is solved exactly in its normal modes (each a sinusoid, or a free
motion). The events are, each as a function crossing zero downward: an open contact reaching
its permanent set (``D_perm - D``), a loading one's closing rate through zero (``Ḋ``), an
unloading one's force reaching zero (``D - D_perm``) or its deformation passing ``M`` again
(``M - D``). Each is a sum of sinusoids and a quadratic in time with a known bound ``B`` on its
second derivative, so between two samples ``Δ`` apart where it is positive it stays above
``min - B Δ² / 8``: an interval where that bound is not positive is bisected until the bound is
or a sample is negative. No crossing can hide, however short.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

OPEN, LOADING, UNLOADING = 0, 1, 2
#: Samples per radian of the fastest mode (the bound does the rest).
PER_RADIAN = 4.0
#: Where a function that starts a segment on its surface and leaves it is moved, relative to
#: its scale (a segment starts on the surface of the event that ended the last one).
START_TOL = 1e-13


class _Series:
    """``h(τ) = c + p1 τ + p2 τ² + Σ_j u_j cos(ω_j τ) + w_j sin(ω_j τ)`` (vectorised over τ)."""

    def __init__(self, c, p1, p2, u, w, omega):
        self.c, self.p1, self.p2, self.u, self.w, self.omega = c, p1, p2, u, w, omega

    def __call__(self, tau):
        tau = np.asarray(tau, float)
        ph = np.multiply.outer(tau, self.omega)
        return self.c + self.p1 * tau + self.p2 * tau ** 2 + np.cos(ph) @ self.u + \
            np.sin(ph) @ self.w

    def derivative(self):
        om = self.omega.reshape((-1,) + (1,) * (np.ndim(self.u) - 1))
        return _Series(self.p1, 2 * self.p2, 0.0, self.w * om, -self.u * om, self.omega)

    def curvature_bound(self) -> float:
        """A bound on ``|h''|`` for all τ."""
        return float(2 * abs(self.p2) + np.sum(np.hypot(self.u, self.w) * self.omega ** 2))


class ModalChain:
    """A chain (masses ``m`` (N,), speeds ``v`` (N,), per contact ``k``, ``e``, ``gap``), rear to
    front, solved segment by segment; :meth:`run` returns the final speeds and the events."""

    def __init__(self, m, v, k, e, gap):
        self.m, self.k, self.e = (np.asarray(a, float) for a in (m, k, e))
        self.gap = np.asarray(gap, float)
        self.N, self.K = len(self.m), len(self.k)
        self.C = np.zeros((self.K, self.N))
        self.C[np.arange(self.K), np.arange(self.K)] = 1.0
        self.C[np.arange(self.K), np.arange(self.K) + 1] = -1.0
        self.x, self.v = np.zeros(self.N), np.asarray(v, float).copy()
        closing = self.C @ self.v
        self.mode = np.where((self.gap == 0) & (closing > 0), LOADING, OPEN)
        self.M = np.zeros(self.K)        # max deformation
        self.perm = np.zeros(self.K)     # permanent set
        self.scale = float(np.max(np.abs(closing)))

    # -- one segment's motion
    def _pieces(self):
        """Slope and offset of each contact's force, ``F = a + s D``, in the current modes."""
        s = np.where(self.mode == LOADING, self.k, 0.0)
        a = np.zeros(self.K)
        unl = self.mode == UNLOADING
        s[unl] = self.k[unl] / self.e[unl] ** 2
        a[unl] = self.k[unl] * self.M[unl] - s[unl] * self.M[unl]
        return a, s

    def _modes(self):
        """The segment's motion: ``x(τ) = X(τ)``, ``v(τ) = V(τ)`` as _Series per vehicle."""
        a, s = self._pieces()
        Kmat = self.C.T @ (s[:, None] * self.C)
        b = -self.C.T @ (a - s * self.gap)
        r = 1.0 / np.sqrt(self.m)
        lam, Q = np.linalg.eigh(r[:, None] * Kmat * r[None, :])
        T = r[:, None] * Q                      # x = T q
        q0 = Q.T @ (np.sqrt(self.m) * self.x)
        qd0 = Q.T @ (np.sqrt(self.m) * self.v)
        beta = Q.T @ (r * b)
        rigid = lam <= 1e-10 * max(float(np.max(lam)), 1e-300)
        omega = np.sqrt(np.where(rigid, 0.0, lam))
        centre = np.where(rigid, 0.0, beta / np.where(rigid, 1.0, lam))
        amp_c = np.where(rigid, 0.0, q0 - centre)
        amp_s = np.where(rigid, 0.0, qd0 / np.where(rigid, 1.0, omega))
        # x_i = Σ_j T_ij q_j: constant, linear and quadratic parts from the rigid modes
        const = T @ np.where(rigid, q0, centre)
        p1 = T @ np.where(rigid, qd0, 0.0)
        p2 = T @ np.where(rigid, 0.5 * beta, 0.0)
        return const, p1, p2, T * amp_c, T * amp_s, omega

    def _state(self, modes, tau):
        const, p1, p2, U, W, om = modes
        x = _Series(const, p1, p2, U.T, W.T, om)
        return x(tau), x.derivative()(tau)

    def _events(self, modes):
        """The armed event functions ``[(contact, kind, series, scale)]``."""
        const, p1, p2, U, W, om = modes
        D = _Series(self.C @ const - self.gap, self.C @ p1, self.C @ p2, (self.C @ U).T,
                    (self.C @ W).T, om)
        out = []
        for j in range(self.K):
            Dj = _Series(D.c[j], D.p1[j], D.p2[j], D.u[:, j], D.w[:, j], om)
            neg = _Series(-Dj.c, -Dj.p1, -Dj.p2, -Dj.u, -Dj.w, om)
            if self.mode[j] == OPEN:
                out.append((j, "contact", _shift(neg, self.perm[j]), "length"))
            elif self.mode[j] == LOADING:
                out.append((j, "max", Dj.derivative(), "speed"))
            else:
                out.append((j, "separation", _shift(Dj, -self.perm[j]), "length"))
                out.append((j, "reload", _shift(neg, self.M[j]), "length"))
        return out

    def _first(self, h, horizon, omega_max):
        """The first τ > 0 where ``h`` crosses zero downward (inf if none before ``horizon``)."""
        h0, dh0 = float(h(0.0)), float(h.derivative()(0.0))
        if h0 <= 0 and dh0 < 0:
            return 0.0
        if omega_max == 0:   # free flight: linear (a closing rate below rounding never closes)
            if -h.p1 <= 1e-12 * self.scale:
                return np.inf
            roots = np.roots([h.p2, h.p1, h0]) if (h.p2 or h.p1) else []
            roots = [float(t.real) for t in np.atleast_1d(roots) if t.imag == 0 and t.real > 0]
            return min(roots, default=np.inf)
        B = h.curvature_bound()
        dt = 1.0 / (PER_RADIAN * omega_max)
        tt = np.arange(int(np.ceil(horizon / dt)) + 1) * dt
        g = h(tt)
        g[0] = max(g[0], 0.0)
        # the intervals the curvature bound cannot clear, in order, up to the first sample past
        # the surface
        unclear = np.minimum(g[:-1], g[1:]) - B * dt ** 2 / 8 <= 0
        past = np.flatnonzero(g[1:] <= 0)
        if past.size:
            unclear[past[0] + 1:] = False
        for i in np.flatnonzero(unclear):
            found = _hunt(h, tt[i], tt[i + 1], g[i], g[i + 1], B)
            if found is not None:
                return found
        return np.inf

    def run(self, max_events=200):
        """Final speeds (N,) and the list of ``(time, contact, kind)`` events."""
        t, events, fired = 0.0, [], None
        while True:
            modes = self._modes()
            om = modes[5]
            # two periods of the slowest mode (or free flight, solved as a quadratic)
            slow = float(np.min(om[om > 0])) if np.any(om > 0) else 0.0
            horizon = 4 * np.pi / slow if slow else np.inf
            best = (np.inf, None)
            for j, kind, h, unit in self._events(modes):
                size = START_TOL * self.scale * (1.0 if unit == "speed" else self._time())
                h0 = float(h(0.0))
                # the restart: a function that starts on its surface (the contact's own, just
                # left) and does not go on into it is moved off it
                if abs(h0) <= size and (j == fired or float(h.derivative()(0.0)) >= 0):
                    h = _shift(h, size - h0)
                tau = self._first(h, horizon, float(np.max(om)))
                if tau < best[0]:
                    best = (tau, (j, kind))
            if best[1] is None:
                if np.all(self.mode == OPEN) and np.all(self.C @ self.v <= 1e-12 * self.scale):
                    return self.v, events
                raise RuntimeError("no event within two periods of a loaded chain")
            tau, (fired, kind) = best
            self.x, self.v = self._state(modes, tau)
            t += tau
            events.append((t, fired, kind))
            self._apply(fired, kind)
            if len(events) > max_events:
                raise RuntimeError("too many events")

    def _time(self) -> float:
        """A contact time scale [s] (for the restart tolerance of lengths)."""
        mu = np.min(self.m[:-1] * self.m[1:] / (self.m[:-1] + self.m[1:]))
        return float(np.sqrt(mu / np.max(self.k)))

    def _apply(self, j, kind):
        D = float(self.C[j] @ self.x - self.gap[j])
        if kind == "contact":
            fresh = self.M[j] <= 0 or self.e[j] == 0
            self.mode[j] = LOADING if fresh else UNLOADING
        elif kind == "max":
            self.M[j] = D
            if self.e[j] == 0:
                self.mode[j], self.perm[j] = OPEN, D
            else:
                self.mode[j], self.perm[j] = UNLOADING, D * (1 - self.e[j] ** 2)
        elif kind == "separation":
            self.mode[j] = OPEN
        else:   # reload past the max deformation
            self.mode[j] = LOADING


def _shift(h, c):
    return _Series(h.c + c, h.p1, h.p2, h.u, h.w, h.omega)


def _hunt(h, a, b, ga, gb, B, depth=0):
    """The first downward crossing of ``h`` in ``[a, b]`` (``h(a) = ga >= 0``), or None where the
    curvature bound ``B`` shows none (bisecting where it cannot tell)."""
    if gb <= 0:
        return brentq(h, a, b, xtol=1e-18, rtol=8.9e-16, maxiter=200) if ga > 0 else a
    if min(ga, gb) - B * (b - a) ** 2 / 8 > 0 or depth > 60:
        return None
    mid = 0.5 * (a + b)
    gm = float(h(mid))
    left = _hunt(h, a, mid, ga, gm, B, depth + 1)
    return left if left is not None else _hunt(h, mid, b, gm, gb, B, depth + 1)
