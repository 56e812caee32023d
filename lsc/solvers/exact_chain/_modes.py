"""The motion of a chain between two events, in closed form in the modes of ``M^{-1} K``.

Inside a segment each contact ``k`` is open (no force) or on an affine piece of its law,
``F_k = fa_k + s_k (D_k - da_k)`` (:class:`~lsc.contact.HysteresisLaw`), so with ``C`` (K, N)
the deformation map (``D = C x - gap``) the vehicles obey ``M Δx'' = -K Δx + f0``, with
``K = Cᵀ diag(s) C`` [force/length], ``Δx`` the displacement since the segment start [length]
and ``f0`` the net contact force on each vehicle at the start [force].

In mass-weighted coordinates ``q = Qᵀ M^{1/2} Δx`` (``Q`` the orthonormal eigenvectors of
``M^{-1/2} K M^{-1/2}``, eigenvalues ``κ_j`` [1/s²]) every mode is independent:

    q_j(τ) = a_j S_j(τ) + b_j C_j(τ),   a_j = Q_jᵀ M^{1/2} v0,  b_j = Q_jᵀ M^{-1/2} f0,

with ``S = sin(ωτ)/ω, C = (1 - cos ωτ)/ω²`` (``κ = ω² > 0``), ``S = τ, C = τ²/2`` (rigid
modes, ``κ = 0``) or ``S = sinh(λτ)/λ, C = (cosh λτ - 1)/λ²`` (``κ = -λ² < 0``: a falling
table piece). ``S' = 1 - κ C`` and ``C' = S``. The rigid modes are not left to the eigensolver:
by Sylvester's law of inertia ``K`` has exactly one zero eigenvalue per group of vehicles joined
by contacts of non-zero slope, whose mode is that group's common translation; it is built
exactly and the other modes are taken orthogonal to it, so a group's momentum changes only by
the constant forces acting on it (a plateau's), to rounding.

Every event function of the IF-D law is linear in ``(D, Ḋ)``, hence of the form
``g(τ) = c + Σ_j α_j S_j(τ) + γ_j C_j(τ)`` (:class:`Series`): the basis is closed under
differentiation (``g' = Σα + Σ γ_j S_j - κ_j α_j C_j``), which gives every derivative and a
bound on ``|g''|`` over an interval in closed form.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Modes", "Series", "Motion", "deformation_map"]


def deformation_map(N: int) -> np.ndarray:
    """``C`` (N-1, N): ``D_k = x_k - x_{k+1} - gap_k``."""
    C = np.zeros((N - 1, N))
    C[np.arange(N - 1), np.arange(N - 1)] = 1.0
    C[np.arange(N - 1), np.arange(1, N)] = -1.0
    return C


class Modes:
    """The modes of one segment: eigenvalues ``kappa`` (n,) [1/s²], split once into harmonic
    (``κ > 0``), rigid (``κ = 0``) and hyperbolic (``κ < 0``) ones."""

    def __init__(self, kappa):
        self.kappa = np.asarray(kappa, float)
        self.w = np.sqrt(np.abs(self.kappa))
        self.pos = np.flatnonzero(self.kappa > 0)
        self.neg = np.flatnonzero(self.kappa < 0)
        self.rigid = np.flatnonzero(self.kappa == 0)
        # (for one time at a time, in plain floats: ten times cheaper than NumPy on a few modes)
        self._kinds = [(1 if k > 0 else -1 if k < 0 else 0, float(w))
                       for k, w in zip(self.kappa, self.w)]

    def basis_at(self, tau: float) -> tuple[list, list]:
        """``S, C`` (lists, one per mode) at one time ``tau`` [s] (as :meth:`basis`)."""
        S, C = [], []
        for kind, w in self._kinds:
            if kind == 0:
                S.append(tau)
                C.append(0.5 * tau * tau)
                continue
            h = 0.5 * w * tau
            try:
                s, c = (math.sin(h), math.cos(h)) if kind > 0 else (math.sinh(h), math.cosh(h))
            except OverflowError:
                s = c = math.inf
            sw = s / w
            S.append(2.0 * sw * c)
            C.append(2.0 * sw * sw)
        return S, C

    def basis(self, tau):
        """``S, C`` (len(tau), n) at times ``tau`` (1-d) [s], from half angles (no cancellation
        near τ = 0): ``S = 2 sin h cos h / ω``, ``C = 2 (sin h / ω)²``, ``h = ωτ/2`` (and
        ``sinh, cosh``); ``S = τ, C = τ²/2`` for the rigid modes."""
        tau = np.asarray(tau, float).reshape(-1, 1)
        S = np.empty((tau.shape[0], self.kappa.size))
        C = np.empty_like(S)
        for idx, sin, cos in ((self.pos, np.sin, np.cos), (self.neg, np.sinh, np.cosh)):
            if idx.size:
                w = self.w[idx]
                h = (0.5 * w) * tau
                with np.errstate(over="ignore", invalid="ignore"):
                    sw = sin(h) / w
                    S[:, idx] = 2.0 * sw * cos(h)
                    C[:, idx] = 2.0 * sw * sw
        if self.rigid.size:
            S[:, self.rigid] = tau
            C[:, self.rigid] = 0.5 * tau * tau
        return S, C

    def curvature_bounds(self, alpha, gamma, T: float):
        """Bounds on ``|g''|`` over ``[0, T]`` for series of coefficients ``alpha, gamma``
        (..., n): ``g'' = Σ -κ α S + γ S'``, with ``|S| <= min(T, 1/ω)``, ``|S'| <= 1``
        (harmonic and rigid modes) and ``S <= sinh(λT)/λ``, ``S' <= cosh(λT)`` (hyperbolic)."""
        k, w = self.kappa, self.w
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            s_max = np.where(k > 0, np.minimum(T, 1.0 / np.where(w > 0, w, 1.0)),
                             np.where(k < 0, np.sinh(w * T) / np.where(w > 0, w, 1.0), T))
            ds_max = np.where(k < 0, np.cosh(w * T), 1.0)
        return np.abs(alpha * k) @ s_max + np.abs(gamma) @ ds_max

    def fastest(self) -> float:
        """The largest ``sqrt|κ|`` [1/s] (0: all rigid)."""
        return float(np.max(self.w)) if self.w.size else 0.0

    def slowest(self) -> float:
        """The smallest non-zero ``sqrt|κ|`` [1/s] (0: all rigid)."""
        w = self.w[self.w > 0]
        return float(np.min(w)) if w.size else 0.0


@dataclass
class Series:
    """``g(τ) = c + Σ_j α_j S_j(τ) + γ_j C_j(τ)`` on the :class:`Modes` of one segment."""

    c: float
    alpha: np.ndarray
    gamma: np.ndarray
    modes: Modes

    def derivative(self) -> "Series":
        """``g'``: ``S' = 1 - κ C``, ``C' = S``."""
        return Series(float(np.sum(self.alpha)), self.gamma, -self.modes.kappa * self.alpha,
                      self.modes)

    def __call__(self, tau):
        """``g`` at times ``tau`` (a scalar, or 1-d)."""
        if np.ndim(tau) == 0:
            if not hasattr(self, "_coef"):
                self._coef = list(zip(self.alpha.tolist(), self.gamma.tolist()))
            S, C = self.modes.basis_at(float(tau))
            return self.c + sum(a * s + g * c for (a, g), s, c in zip(self._coef, S, C))
        S, C = self.modes.basis(np.atleast_1d(tau))
        out = self.c + S @ self.alpha + C @ self.gamma
        return float(out[0]) if np.ndim(tau) == 0 else out

    def on(self, S, C):
        """``g`` on a grid whose basis is ``S, C`` (:meth:`Modes.basis`)."""
        return self.c + S @ self.alpha + C @ self.gamma

    def derivatives_at_zero(self, n: int) -> list[float]:
        """``g(0), g'(0), ..., g^(n)(0)`` (``S(0) = C(0) = 0``)."""
        out, g = [self.c], self
        for _ in range(n):
            g = g.derivative()
            out.append(g.c)
        return out

    def curvature_bound(self, T: float) -> float:
        """A bound on ``|g''|`` over ``[0, T]`` (:meth:`Modes.curvature_bounds`)."""
        return float(self.modes.curvature_bounds(self.alpha, self.gamma, T))

    def oscillates(self) -> bool:
        """True when a mode with ``κ != 0`` enters ``g`` (else it is a quadratic in τ)."""
        used = (self.alpha != 0) | (self.gamma != 0)
        return bool(np.any(used & (self.modes.kappa != 0)))


class Motion:
    """The closed-form motion of one segment.

    Parameters: ``m`` (N,) masses [mass]; ``x0, v0`` (N,) the state at the start [length,
    velocity]; ``slope`` (K,) each contact's active slope ``s_k`` [force/length] (0 when open)
    and ``force`` (K,) its force at the start [force]; ``incidence`` (N, K) the model's
    (contact ``k`` pushes vehicle ``k`` back and ``k+1`` forward).
    """

    def __init__(self, m, x0, v0, slope, force, incidence):
        self.m, self.x0, self.v0 = m, x0, v0
        N = m.size
        C = -incidence.T   # (K, N): D = C x - gap
        root = np.sqrt(m)
        kappa, Q = _modes(C, slope, root)
        self.modes = Modes(kappa)
        self.kappa = self.modes.kappa
        self.T = Q / root[:, None]                       # Δx = T q
        f0 = incidence @ force
        self.a = Q.T @ (root * v0)                       # q'(0)
        self.b = Q.T @ (f0 / root)                       # q''(0)
        self.P = C @ self.T                              # ΔD = P q
        self.N = N

    def state(self, tau):
        """Positions and velocities (2N, ...) at times ``tau`` (...) into the segment."""
        S, C = self.modes.basis(np.atleast_1d(tau))
        q = S * self.a + C * self.b
        dq = S * self.b - self.kappa * C * self.a    # q'(τ) - q'(0)
        x = self.x0[:, None] + self.T @ q.T
        v = self.v0[:, None] + self.T @ dq.T
        out = np.concatenate([x, v])
        return out[:, 0] if np.ndim(tau) == 0 else out

    def deformation(self, k: int, c: float, sign: float = 1.0) -> Series:
        """``c + sign ΔD_k(τ)`` as a :class:`Series`."""
        row = sign * self.P[k]
        return Series(float(c), row * self.a, row * self.b, self.modes)

    def closing_rate(self, k: int, w0: float) -> Series:
        """``Ḋ_k(τ) = w0 + ΔḊ_k(τ)`` as a :class:`Series` (``q' = a S' + b S``)."""
        row = self.P[k]
        return Series(float(w0), row * self.b, -self.kappa * row * self.a, self.modes)


def _modes(C, slope, root):
    """Eigenvalues (N,) [1/s²] and orthonormal eigenvectors (N, N) of
    ``M^{-1/2} Cᵀ diag(slope) C M^{-1/2}``: the rigid modes exactly (one translation per group
    of vehicles joined by contacts of non-zero slope, ``κ = 0``), the others from ``eigh`` on
    their complement."""
    N = root.size
    group = np.zeros(N, dtype=int)
    for k, s in enumerate(slope):
        group[k + 1] = group[k] if s != 0 else group[k] + 1
    n_rigid = int(group[-1]) + 1
    R = np.zeros((N, n_rigid))
    R[np.arange(N), group] = root
    R /= np.linalg.norm(R, axis=0)
    if n_rigid == N:
        return np.zeros(N), R
    A = (C / root[None, :]).T @ (slope[:, None] * (C / root[None, :]))
    A = 0.5 * (A + A.T)
    lam, V = np.linalg.eigh(A)
    elastic = np.argsort(np.abs(lam))[n_rigid:]
    E = V[:, elastic]
    E = E - R @ (R.T @ E)
    E, _ = np.linalg.qr(E)
    # Rayleigh quotients of the cleaned vectors (the eigenvalues they now carry)
    lam_e = np.einsum("ij,ij->j", E, A @ E)
    return np.concatenate([np.zeros(n_rigid), lam_e]), np.concatenate([R, E], axis=1)
