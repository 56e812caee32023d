"""An independent solution of a chain of vehicles on IF-D contacts (linear or piecewise-linear
loading, a straight unloading line set by a restitution, reloading along it) with optional
constant braking (stick and slip), written here from the physics and sharing no code with lsc:
the reference the exact backend and the integrators are held to.

Between events every contact is open (no force), loading on one piece of its loading curve
(``F = f_i + s_i (D - d_i)``) or on its unloading line (from ``(M, F_M)``, ``M`` its max
deformation, down to its permanent set ``P = M - 2 e² E / F_M``, ``E`` the loading work up to
``M``), and every braked vehicle slides (a constant force ``-μ m g`` against its motion) or is
stuck (held: removed from the moving system), so the motion is linear, ``m x'' = -K x + b``, and
is solved exactly in the normal modes of the moving vehicles (each a sinusoid, or a free motion
with a constant acceleration). The events are, each as a function crossing zero downward: an open
contact reaching its permanent set (``P - D``), a loading one's closing rate through zero
(``Ḋ``) or its deformation reaching the next breakpoint (``d_{i+1} - D``), an unloading one's
deformation reaching ``P`` (``D - P``: separation) or passing ``M`` again (``M - D``: reload onto
the loading curve), a sliding vehicle's speed through zero (``±v``: it stops, and sticks unless
the net contact force exceeds ``μ_s m g``), a stuck vehicle's net contact force reaching
``±μ_s m g`` (break-away). Each is a sum of sinusoids and a quadratic in time with a known bound
``B`` on its second derivative, so between two samples ``Δ`` apart where it is positive it stays
above ``min - B Δ² / 8``: an interval where that bound is not positive is bisected until the
bound is or a sample is negative (a function leaving its surface at the segment's start is
positive up to ``2 h'(0) / B``). No crossing can hide, however short. All the armed functions
are sampled together, in chunks of growing length, until one crosses.

Positions are kept relative to the rear vehicle's (only their differences enter), so that a
deformation of 1e-3 ft is not the difference of two positions tens of feet down the road.

:meth:`ModalChain.run` keeps every segment (its motion and each contact's force line), from which
tests/hard/modal_metrics.py computes every metric.
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
#: Windows (of two periods of the slowest mode) searched for the next event before giving up.
MAX_WINDOWS = 10_000


class _Series:
    """``h(τ) = base + (c + p1 τ + p2 τ² + Σ_j u_j cos(ω_j τ) + w_j sin(ω_j τ))`` (vectorised
    over τ; ``base, c, p1, p2`` (...), ``u, w`` (n_modes, ...)): the motion of a segment is its
    start ``base`` plus the change from it (``c = -Σ_j u_j``: ``h(0) = base``), summed apart,
    so that the change, the accelerations and the forces it gives are each rounded to their own
    size, not to that of the positions."""

    def __init__(self, c, p1, p2, u, w, omega, base=0.0):
        self.c, self.p1, self.p2, self.u, self.w, self.omega = c, p1, p2, u, w, omega
        self.base = base

    def __call__(self, tau):
        tau = np.asarray(tau, float)
        ph = np.multiply.outer(tau, self.omega)
        t = tau.reshape(tau.shape + (1,) * np.ndim(self.c))
        return (self.c + self.p1 * t + self.p2 * t ** 2 + np.cos(ph) @ self.u +
                np.sin(ph) @ self.w) + self.base

    def derivative(self):
        om = self.omega.reshape((-1,) + (1,) * (np.ndim(self.u) - 1))
        return _Series(self.p1, 2 * self.p2, 0.0 * self.p2, self.w * om, -self.u * om,
                       self.omega)

    def __getitem__(self, j):
        return _Series(self.c[j], self.p1[j], self.p2[j], self.u[:, j], self.w[:, j],
                       self.omega, np.broadcast_to(self.base, np.shape(self.c))[j])

    def __neg__(self):
        return _Series(-self.c, -self.p1, -self.p2, -self.u, -self.w, self.omega, -self.base)

    def __add__(self, other):
        return _Series(self.c + other.c, self.p1 + other.p1, self.p2 + other.p2,
                       self.u + other.u, self.w + other.w, self.omega, self.base + other.base)

    def scaled(self, a, b=0.0):
        """``a h + b``."""
        return _Series(a * self.c, a * self.p1, a * self.p2, a * self.u, a * self.w,
                       self.omega, a * self.base + b)

    def rebased(self, a, base):
        """``base + a (h - h.base)``: a contact's force ``F0 + s (D - D0)`` from its deformation
        ``D`` (``D0 = D.base``), ``F0`` the force at the start (not ``s D0`` less a line's
        offset, which rounds to ``s`` times the positions' ulps: 1e-9 of the force on a
        near-plastic line 1e9 lbf/ft stiff)."""
        return _Series(a * self.c, a * self.p1, a * self.p2, a * self.u, a * self.w,
                       self.omega, base)

    def curvature_bound(self):
        """A bound on ``|h''|`` for all τ."""
        om = self.omega.reshape((-1,) + (1,) * (np.ndim(self.u) - 1))
        return 2 * np.abs(self.p2) + np.sum(np.hypot(self.u, self.w) * om ** 2, axis=0)


def _eigen(m, s, free):
    """The modes of the free vehicles ``free`` (masses ``m``) on the contacts' slopes ``s``
    (every contact, the stuck vehicles held): eigenvalues ``λ`` [1/s²] and orthonormal vectors
    ``Q`` of ``M^-½ K M^-½`` (``K = Cᵀ diag(s) C`` on the free vehicles), and which modes are
    rigid (``λ`` zero). They are the squared singular values and the left singular vectors of
    the factor ``(diag(√s) C M^-½)ᵀ``, each to its own relative accuracy where the slopes spread
    over 1e12 (within 4e-15 and 4e-14 of a 40-digit eigensolve: tests/test_exact_chain.py);
    ``eigh`` of the product gives each eigenvalue only to rounding of the largest (a slow mode
    behind a 1e10 lbf/ft near-plastic line 1e-9 off, its vector 1e-6)."""
    C = np.eye(len(s), len(s) + 1) - np.eye(len(s), len(s) + 1, 1)   # (D = C x - gap)
    if min(s.tolist(), default=0.0) < 0:    # (a falling piece: no real factor)
        lam, Q = np.linalg.eigh((C[:, free].T @ (s[:, None] * C[:, free])) /
                                np.sqrt(np.multiply.outer(m, m)))
        rigid = np.abs(lam) <= 1e-10 * max(float(np.max(np.abs(lam))), 1e-300)
        return np.where(rigid, 0.0, lam), Q, rigid
    B = np.sqrt(s)[:, None] * C[:, free] / np.sqrt(m)[None, :]
    Q, sigma, _ = np.linalg.svd(B.T)
    lam = np.zeros(len(free))
    lam[:sigma.size] = sigma[:len(free)] ** 2
    # (a zero: rounding of the largest, ~1e-32 of it; a mode: above 1e-12 of it)
    rigid = lam <= 1e-20 * max(float(np.max(lam)), 1e-300)
    return np.where(rigid, 0.0, lam), Q, rigid


def _shift(h, c):
    return _Series(h.c, h.p1, h.p2, h.u, h.w, h.omega, h.base + c)


class ModalChain:
    """A chain, rear to front, solved segment by segment: masses ``m`` (N,), speeds ``v`` (N,);
    per contact a loading stiffness ``k`` or a loading ``table`` (``[[d, F], ...]`` from
    ``(0, 0)``, its last piece extended), a restitution ``e`` and a ``gap``; per vehicle an
    optional ``(mu, mu_static)`` brake, with gravity ``g``. :meth:`run` returns the final speeds
    (at the last separation) and the events ``(time, index, kind)`` (a vehicle's index for
    ``stop``, ``reversal`` and ``break_away``)."""

    def __init__(self, m, v, k, e, gap, tables=None, brakes=None, g=32.174):
        self.m, self.e = (np.asarray(a, float) for a in (m, e))
        self.gap = np.asarray(gap, float)
        self.N, self.K = len(self.m), len(self.e)
        self.g = float(g)
        tables = tables if tables is not None else [None] * self.K
        self.d, self.f, self.s, self.work = [], [], [], []
        for kj, tab in zip(k, tables):
            tab = np.array([[0.0, 0.0], [1.0, float(kj)]] if tab is None else tab, float)
            d, f = tab[:, 0], tab[:, 1]
            s = np.diff(f) / np.diff(d)
            self.d.append(d[:-1])
            self.f.append(f[:-1])
            self.s.append(s)
            # loading work up to each breakpoint
            self.work.append(np.concatenate([[0.0], np.cumsum(0.5 * (f[1:-1] + f[:-2]) *
                                                              np.diff(d[:-1]))]))
        brakes = brakes if brakes is not None else [None] * self.N
        self.braked = np.array([b is not None for b in brakes])
        self.mu = np.array([b[0] if b else 0.0 for b in brakes], float)
        self.mus = np.array([b[1] if b else 0.0 for b in brakes], float)
        self.C = np.zeros((self.K, self.N))
        self.C[np.arange(self.K), np.arange(self.K)] = 1.0
        self.C[np.arange(self.K), np.arange(self.K) + 1] = -1.0
        self.x, self.v = np.zeros(self.N), np.asarray(v, float).copy()
        closing = self.C @ self.v
        self.mode = np.where((self.gap == 0) & (closing > 0), LOADING, OPEN)
        self.piece = np.zeros(self.K, int)
        self.M = np.zeros(self.K)        # max deformation
        self.FM = np.zeros(self.K)       # force there
        self.perm = np.zeros(self.K)     # permanent set
        self.ec = np.zeros(self.K)       # loading work up to M
        self.er = np.zeros(self.K)       # work the unloading line returns
        self.scale = float(np.max(np.abs(closing)))
        self.slide = np.ones(self.N, bool)
        self.dir = np.sign(self.v)
        for i in np.flatnonzero(self.braked):
            self._settle(i, initial=True)
        self.segments, self.log = [], []
        self.v0, self.touching0 = self.v.copy(), self.mode == LOADING

    @classmethod
    def from_scene(cls, scene: dict) -> "ModalChain":
        """From a scene dict in US units with only the keys tests' chains use (read here, not
        by lsc)."""
        assert scene["units"] == "US" and "g" not in scene
        veh, con = scene["vehicles"], scene["contacts"]
        assert all(set(v) <= {"mass", "speed", "brake"} for v in veh)
        assert all(set(c) <= {"loading", "unloading", "gap"} and set(c["unloading"]) ==
                   {"restitution"} for c in con)
        brakes = [(b["mu"], b.get("mu_static", b["mu"])) if (b := v.get("brake")) else None
                  for v in veh]
        return cls([v["mass"] for v in veh], [v["speed"] for v in veh],
                   [c["loading"].get("stiffness", 0.0) for c in con],
                   [c["unloading"]["restitution"] for c in con],
                   [c.get("gap", 0.0) for c in con],
                   tables=[c["loading"].get("table") for c in con], brakes=brakes)

    # -- one segment's motion
    def lines(self):
        """Each contact's force in its current mode, ``F = a + s D``: ``(a, s)`` (K,)."""
        a, s = np.zeros(self.K), np.zeros(self.K)
        for j in range(self.K):
            if self.mode[j] == LOADING:
                i = self.piece[j]
                s[j] = self.s[j][i]
                a[j] = self.f[j][i] - s[j] * self.d[j][i]
            elif self.mode[j] == UNLOADING:
                s[j] = self.FM[j] / (self.M[j] - self.perm[j])
                a[j] = self.FM[j] - s[j] * self.M[j]
        return a, s

    def forces(self):
        """Each contact's force [lbf] now (K,), from its line's anchor: ``f_i + s_i (D - d_i)``
        on a loading piece, ``F_M + s (D - M)`` unloading (exactly ``F_M`` at the max)."""
        D = self.C @ self.x - self.gap
        F = np.zeros(self.K)
        for j in range(self.K):
            if self.mode[j] == LOADING:
                i = self.piece[j]
                F[j] = self.f[j][i] + self.s[j][i] * (D[j] - self.d[j][i])
            elif self.mode[j] == UNLOADING:
                F[j] = self.FM[j] + self.FM[j] / (self.M[j] - self.perm[j]) * (D[j] - self.M[j])
        return F

    def _modes(self):
        """The segment's motion ``x(τ)`` as a _Series over the vehicles (its base the positions
        now), and the force lines ``(a, s)`` with the forces now ``F0``. Each elastic mode moves
        about its centre from an offset ``-φ/λ``, ``φ`` the modal net force now (from ``F0``:
        not the difference of the positions' and the centre's modal coordinates, which rounds
        to the positions' ulps times ``λ``), a rigid one accelerates at ``φ``."""
        a, s = self.lines()
        F0 = self.forces()
        net = np.concatenate([[0.0], F0]) - np.concatenate([F0, [0.0]]) - np.where(
            self.braked & self.slide, self.mu * self.m * self.g * self.dir, 0.0)
        fr = np.flatnonzero(self.slide)
        const, p1, p2 = np.zeros(self.N), np.zeros(self.N), np.zeros(self.N)
        U, W, omega = np.zeros((self.N, fr.size)), np.zeros((self.N, fr.size)), np.zeros(fr.size)
        if fr.size:
            mf = self.m[fr]
            r = 1.0 / np.sqrt(mf)
            lam, Q, rigid = _eigen(mf, s, fr)
            T = r[:, None] * Q                      # x = T q
            qd0 = Q.T @ (np.sqrt(mf) * self.v[fr])
            phi = Q.T @ (r * net[fr])
            omega = np.sqrt(np.where(rigid, 0.0, lam))
            offset = np.where(rigid, 0.0, -phi / np.where(rigid, 1.0, lam))
            const[fr] = T @ -offset
            p1[fr] = T @ np.where(rigid, qd0, 0.0)
            p2[fr] = T @ np.where(rigid, 0.5 * phi, 0.0)
            U[fr] = T * offset
            W[fr] = T * np.where(rigid, 0.0, qd0 / np.where(rigid, 1.0, omega))
        return _Series(const, p1, p2, U.T, W.T, omega, self.x.copy()), (a, s, F0)

    def deformations(self, X):
        """The contacts' deformations ``D = C x - gap`` of the motion ``X`` (a _Series)."""
        return _Series(self.C @ X.c, self.C @ X.p1, self.C @ X.p2, X.u @ self.C.T,
                       X.w @ self.C.T, X.omega, self.C @ X.base - self.gap)

    def _net(self, D, a, s, F0):
        """Net contact force on each vehicle, as a _Series (from the deformations ``D``)."""
        F = D.rebased(s, F0)
        pad = _Series(np.zeros(1), np.zeros(1), np.zeros(1), np.zeros((len(D.omega), 1)),
                      np.zeros((len(D.omega), 1)), D.omega, np.zeros(1))
        cat = lambda p, q: _Series(*(np.concatenate([getattr(p, n), getattr(q, n)], axis=-1)
                                     for n in ("c", "p1", "p2", "u", "w")), D.omega,
                                   np.concatenate([p.base, q.base]))
        return cat(pad, F) + -cat(F, pad)

    def _events(self, X, lines):
        """The armed event functions ``[(key, kind, series, scale)]``; ``key``: ("c", contact)
        or ("v", vehicle)."""
        D = self.deformations(X)
        lscale, vscale = self.scale * self._time(), self.scale
        out = []
        for j in range(self.K):
            Dj = D[j]
            if self.mode[j] == OPEN:
                out.append((("c", j), "contact", _shift(-Dj, self.perm[j]), lscale))
            elif self.mode[j] == LOADING:
                out.append((("c", j), "max", Dj.derivative(), vscale))
                i = self.piece[j]
                if i + 1 < len(self.d[j]):
                    out.append((("c", j), "breakpoint", _shift(-Dj, self.d[j][i + 1]), lscale))
            else:
                out.append((("c", j), "separation", _shift(Dj, -self.perm[j]), lscale))
                out.append((("c", j), "reload", _shift(-Dj, self.M[j]), lscale))
        if self.braked.any():
            net = self._net(D, *lines)
            V = X.derivative()
            for i in np.flatnonzero(self.braked):
                if self.slide[i]:
                    out.append((("v", i), "stop", V[i].scaled(self.dir[i]), vscale))
                else:
                    lim = self.mus[i] * self.m[i] * self.g
                    out.append((("v", i), "break_forward", net[i].scaled(-1.0, lim), lim))
                    out.append((("v", i), "break_backward", net[i].scaled(1.0, lim), lim))
        return out

    @staticmethod
    def _first(h, tt, g, B, safe):
        """The first τ in ``(tt[0], tt[-1]]`` where ``h`` (samples ``g`` at ``tt``, curvature
        bound ``B``) crosses zero downward, none before ``safe`` (inf if none)."""
        # the intervals the curvature bound cannot clear, in order, up to the first sample past
        # the surface
        dt = tt[1] - tt[0]
        unclear = np.minimum(g[:-1], g[1:]) - B * dt ** 2 / 8 <= 0
        past = np.flatnonzero(g[1:] <= 0)
        if past.size:
            unclear[past[0] + 1:] = False
        for i in np.flatnonzero(unclear):
            a, ga = tt[i], g[i]
            if tt[i + 1] <= safe:
                continue
            if a < safe:
                a, ga = safe, float(h(safe))
            found = _hunt(h, a, tt[i + 1], ga, g[i + 1], B)
            if found is not None:
                return found
        return np.inf

    def _next(self, X, lines, fired):
        """The segment's first event: ``(tau, key, kind)`` (tau inf: none ever)."""
        om = X.omega
        omax = float(np.max(om, initial=0.0))
        armed = []
        for key, kind, h, size in self._events(X, lines):
            size = START_TOL * size
            h0 = float(h(0.0))
            # the restart: a function that starts on its surface (the event just fired) and
            # does not go on into it is moved off it; one of the contact or vehicle that just
            # fired that leaves its surface is moved off it however far its rounding put it
            # past (a contact re-closing along its unloading line, its deformation the
            # difference of positions many times larger: the separation at once otherwise)
            dh0 = float(h.derivative()(0.0))
            if (abs(h0) <= size and (key == fired or dh0 >= 0)) or \
                    (key == fired and dh0 > 0 and h0 < size):
                h = _shift(h, size - h0)
            armed.append((key, kind, h))
        none = (np.inf, None, None)
        if not armed:
            return none
        if omax == 0:   # no oscillation: quadratics, solved on the whole future
            best = min(((_quadratic_first(float(h.c + h.base), float(h.p1), float(h.p2), self.scale),
                         key, kind) for key, kind, h in armed), key=lambda b: b[0])
            return best if np.isfinite(best[0]) else none
        # every function at once, chunk by chunk (doubling) up to MAX_WINDOWS windows of two
        # periods of the slowest mode
        H = _Series(*(np.array([getattr(h, n) for _, _, h in armed]) for n in ("c", "p1", "p2")),
                    np.stack([h.u for _, _, h in armed], axis=1),
                    np.stack([h.w for _, _, h in armed], axis=1), om,
                    np.array([h.base for _, _, h in armed], float))
        B = H.curvature_bound()
        g0, dh0 = H(0.0), H.derivative()(0.0)
        for e in np.flatnonzero((g0 <= 0) & (dh0 < 0))[:1]:
            return 0.0, armed[e][0], armed[e][1]
        # leaving its surface, h >= h(0) + τ (h'(0) - B τ / 2) > 0 up to 2 h'(0) / B: no
        # crossing there (a restarted function is not bisected down to its rounding)
        safe = np.where((dh0 > 0) & (B > 0), 2 * dh0 / np.where(B > 0, B, 1.0), 0.0)
        dt = 1.0 / (PER_RADIAN * omax)
        limit = MAX_WINDOWS * 4 * np.pi / float(np.min(om[om > 0]))
        t0, n = 0.0, 64
        while t0 < limit:
            tt = t0 + np.arange(n + 1) * dt
            G = H(tt)
            if t0 == 0:
                G[0] = np.maximum(G[0], 0.0)
            best = none
            for e, (key, kind, _) in enumerate(armed):
                tau = self._first(H[e], tt, G[:, e], float(B[e]), float(safe[e]))
                if tau < best[0]:
                    best = (tau, key, kind)
            if best[1] is not None:
                return best
            t0, n = tt[-1], min(2 * n, 8192)
        raise RuntimeError(f"no event within {MAX_WINDOWS} windows")

    def run(self, max_events=200, horizon=np.inf):
        """Final speeds (N,) (at the last separation, or at the end of the run where nothing
        separated) and the list of ``(time, index, kind)`` events; the segments
        ``(t0, t1, X, (a, s, F0))`` in :attr:`segments`. ``horizon`` [s]: where a crash ends
        (a contact closing only after it, at a rate of 1e-11 of the speeds, does not close)."""
        t, events, fired, v_post = 0.0, [], None, None
        while True:
            X, lines = self._modes()
            tau, key, kind = self._next(X, lines, fired)
            if key is not None and t + tau > horizon and np.all(self.mode == OPEN) and \
                    not np.any(self.braked & self.slide):
                # (over at the horizon: every contact open, the next closing after it)
                self.v_post = self.v.copy() if v_post is None else v_post
                return self.v_post, events
            if key is None:
                # over: every contact open and none closing, or held shut between two stuck
                # vehicles (braked cars pressed together, friction holding the force), and no
                # braked vehicle sliding
                held = ~self.slide[:-1] & ~self.slide[1:]
                if np.all((self.mode == OPEN) | held) and \
                        np.all((self.C @ self.v <= 1e-12 * self.scale) | held) \
                        and not np.any(self.braked & self.slide):
                    # (the speeds at the last separation; at the end where none separated)
                    self.v_post = self.v.copy() if v_post is None else v_post
                    return self.v_post, events
                raise RuntimeError("no event in a loaded chain")
            self.segments.append((t, t + tau, X, lines))
            self.x, self.v = X(tau), X.derivative()(tau)
            # (only the positions' differences matter: kept small, so that a deformation of
            # 1e-3 ft is not the difference of two positions tens of feet down the road)
            self.x -= self.x[0]
            t += tau
            fired = key
            name = self._apply(key[1], kind)
            events.append((t, key[1], name))
            self.log.append((t, key, name, self.v.copy()))
            if "separation" in name:
                v_post = self.v.copy()
            if len(events) > max_events:
                raise RuntimeError("too many events")

    def _time(self) -> float:
        """A contact time scale [s] (for the restart tolerance of lengths)."""
        mu = np.min(self.m[:-1] * self.m[1:] / (self.m[:-1] + self.m[1:]))
        return float(np.sqrt(mu / max(np.max(np.concatenate(self.s)), 1e-300)))

    def _settle(self, i, initial=False):
        """Vehicle ``i`` (braked) at rest or moving: slides or sticks; True if it slides."""
        if initial and self.v[i] != 0:
            self.slide[i], self.dir[i] = True, np.sign(self.v[i])
            return True
        self.v[i] = 0.0
        F = self.forces()
        net = (F[i - 1] if i > 0 else 0.0) - (F[i] if i < self.K else 0.0)
        pushed = abs(net) > self.mus[i] * self.m[i] * self.g
        self.slide[i], self.dir[i] = pushed, (np.sign(net) if pushed else 0.0)
        return pushed

    def _apply(self, j, kind):
        """The state after event ``kind`` of contact or vehicle ``j``; lsc's name of it."""
        if kind == "stop":
            return "reversal" if self._settle(j) else "stop"
        if kind in ("break_forward", "break_backward"):
            self.slide[j], self.dir[j] = True, (1.0 if kind == "break_forward" else -1.0)
            return "break_away"
        D = float(self.C[j] @ self.x - self.gap[j])
        if kind == "contact":
            if self.M[j] <= 0 or self.perm[j] >= self.M[j]:
                self._load(j, D)
            else:
                self.mode[j] = UNLOADING
            return "contact"
        if kind == "breakpoint":
            self.piece[j] += 1
            return "breakpoint"
        if kind == "max":
            i = self.piece[j]
            x = D - self.d[j][i]
            F = self.f[j][i] + self.s[j][i] * x
            self.M[j], self.FM[j] = D, F
            self.ec[j] = self.work[j][i] + self.f[j][i] * x + 0.5 * self.s[j][i] * x * x
            if self.e[j] == 0 or F <= 0:
                self.mode[j], self.perm[j], self.er[j] = OPEN, D, 0.0
                return "max_deformation+separation"
            self.mode[j] = UNLOADING
            self.perm[j] = D - 2 * self.e[j] ** 2 * self.ec[j] / F
            self.er[j] = self.e[j] ** 2 * self.ec[j]
            return "max_deformation"
        if kind == "separation":
            self.mode[j] = OPEN
            return "separation"
        self._load(j, self.M[j])   # reload past the max deformation
        return "reload_past_max"

    def _load(self, j, D):
        self.mode[j] = LOADING
        self.piece[j] = max(int(np.searchsorted(self.d[j], D, side="right")) - 1, 0)


def _quadratic_first(c, p1, p2, scale):
    """First τ > 0 where ``c + p1 τ + p2 τ²`` (``c >= 0``) crosses zero downward (inf if
    never; a rate below rounding with no acceleration never closes)."""
    if c <= 0 and p1 < 0:
        return 0.0
    if p2 == 0:
        return c / -p1 if -p1 > 1e-12 * scale else np.inf
    disc = p1 * p1 - 4 * p2 * c
    if disc < 0:
        return np.inf
    q = -0.5 * (p1 + np.copysign(np.sqrt(disc), p1))
    roots = sorted(r for r in ((q / p2) if p2 else np.inf, (c / q) if q else np.inf) if r > 0)
    for r in roots:
        if p1 + 2 * p2 * r < 0 or (p1 + 2 * p2 * r == 0 and p2 < 0):
            return float(r)
    return np.inf


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
