"""The closed-form motion of many chains at once (the batch's :mod:`._modes`).

Every array has a leading member axis ``b``. A segment of each member is solved in the modes of
``M^{-1/2} Cᵀ diag(s) C M^{-1/2}`` exactly as :func:`._modes._modes` does for one chain (the
rigid modes built exactly, one translation per group of vehicles joined by loaded contacts; the
others' vectors from ``np.linalg.eigh`` on the stacked matrices, made orthogonal to them, their
eigenvalues the squared singular values of each member's factor ``diag(√s) C M^{-1/2}`` as in
the single solve, :func:`._eigen._factor_kappa`), the members grouped by which contacts carry a
slope. An event function, a force or an acceleration is a
:class:`Sums`: ``g(τ) = c + Σ_j α_j S_j(τ) + γ_j C_j(τ)`` (``S = sin ωτ/ω``, ``C = (1 - cos
ωτ)/ω²``, or ``τ, τ²/2`` for a rigid mode), for a batch of functions ``(b, F)`` at once. Only
slopes >= 0 occur (straight loading and unloading lines), so no mode is hyperbolic.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ._eigen import _factor_kappa

__all__ = ["BatchMotion", "ModesCache", "Sums", "basis", "half_angle", "msum", "mmax", "mmin",
           "many", "many_rows", "mall", "first_true"]


def msum(x):
    """``np.sum(x, axis=-1)``, the same numbers, many times faster on a short last axis (a
    member's few modes): NumPy adds fewer than 8 terms one after the other, as the columns are
    added here; 8 or more are left to it (it adds them pairwise)."""
    n = x.shape[-1]
    if n < 2 or n >= 8:
        return np.sum(x, axis=-1)
    out = x[..., 0] + x[..., 1]
    for j in range(2, n):
        out += x[..., j]
    return out


#: The longest last axis that :func:`mmax`, :func:`mmin`, :func:`many`, :func:`mall` and
#: :func:`first_true` run through column by column (NumPy's reductions over a short last axis
#: cost tens of nanoseconds a row: an elementwise pass per column is several times cheaper).
SHORT = 16


def _columns_fold(x, op, reduce):
    n = x.shape[-1]
    if n < 2 or n >= SHORT:
        return reduce(x, axis=-1)
    out = op(x[..., 0], x[..., 1])
    for j in range(2, n):
        op(out, x[..., j], out=out)
    return out


def mmax(x):
    """``np.max(x, axis=-1)``, the same numbers (see :data:`SHORT`)."""
    return _columns_fold(x, np.maximum, np.max)


def mmin(x):
    """``np.min(x, axis=-1)``, the same numbers (see :data:`SHORT`)."""
    return _columns_fold(x, np.minimum, np.min)


def many(x):
    """``np.any(x, axis=-1)`` of a bool array (see :data:`SHORT`)."""
    return _columns_fold(x, np.logical_or, np.any)


def many_rows(x):
    """``np.any(x, axis=1)`` of a bool array (b, F, ...) of a few functions ``F`` (one pass
    per function: several times cheaper than NumPy's reduction over a middle axis)."""
    if x.shape[1] < 2 or x.shape[1] >= SHORT:
        return np.any(x, axis=1)
    out = x[:, 0] | x[:, 1]
    for j in range(2, x.shape[1]):
        out |= x[:, j]
    return out


def mall(x):
    """``np.all(x, axis=-1)`` of a bool array (see :data:`SHORT`)."""
    return _columns_fold(x, np.logical_and, np.all)


def first_true(x, none: int):
    """The index of the first True along the last axis of ``x`` (bool), ``none`` where there
    is none (``np.where(x.any(-1), np.argmax(x, -1), none)``; see :data:`SHORT`)."""
    n = x.shape[-1]
    if n >= SHORT:
        return np.where(np.any(x, axis=-1), np.argmax(x, axis=-1), none)
    out = np.full(x.shape[:-1], none)
    for j in range(n - 1, -1, -1):
        out[x[..., j]] = j
    return out


def half_angle(h, inv, out=None):
    """``S = sin(2h)/ω = 2u/(ω(1 + u²))`` and ``C = (1 - cos 2h)/ω² = S u/ω`` (``u = tan h``)
    of the half angles ``h = ωτ/2`` (``inv = 1/ω``, broadcast against ``h``; ``h`` is
    overwritten; ``out``: the arrays ``S, C`` to write). Both from one tangent: no
    cancellation near τ = 0, as from ``sin h`` and ``cos h``, to a few ulps (``|u|`` stays
    below 1e19 for a float ``h``: ``1 + u²`` does not overflow), and many times cheaper:
    NumPy's tangent of float64 is vectorised, its sine and cosine are not."""
    u = np.tan(h, out=h)
    d = u * u
    d += 1.0
    S = np.multiply(u, inv, out=None if out is None else out[0])
    S *= 2.0
    S /= d
    C = np.multiply(S, u, out=d if out is None else out[1])
    C *= inv
    return S, C


def _sin_cos(h, ws):
    """``S, C`` of the half angles ``h = ωτ/2`` (``ws = ω``) from ``sin h`` and ``cos h``, as
    :meth:`._modes.Modes.basis` computes them."""
    sw = np.sin(h) / ws
    two_sw = 2.0 * sw
    return two_sw * np.cos(h), two_sw * sw


def basis(w, tau, exact=False):
    """``S, C`` (..., n) at times ``tau`` (...) [s] for the modes of angular frequency ``w``
    (..., n) [1/s] (0: rigid), from half angles (:func:`half_angle`; ``exact``: from their sine
    and cosine, as the single solve, for the few times whose values are kept: the states at the
    events, each function at its own time; :func:`stacked_basis`: laid out for products).
    (Mode 0 is rigid in every member of a chain, the translation of the group of its first
    vehicle (:func:`_modes`): where it is, its sines are not computed.)"""
    tau = np.asarray(tau, float)[..., None]
    first = 1 if w.shape[-1] > 1 and not w[..., 0].any() else 0
    we = w[..., first:]
    rigid = we == 0
    some_rigid = bool(rigid.any())
    ws = np.where(rigid, 1.0, we) if some_rigid else we
    h = (0.5 * ws) * tau
    Se, Ce = _sin_cos(h, ws) if exact else half_angle(h, 1.0 / ws)
    if some_rigid:
        np.copyto(Se, tau, where=rigid)
        np.copyto(Ce, 0.5 * tau * tau, where=rigid)
    if not first:
        return Se, Ce
    S = np.empty(Se.shape[:-1] + (w.shape[-1],))
    C = np.empty_like(S)
    S[..., 0] = tau[..., 0]
    np.multiply(0.5 * tau[..., 0], tau[..., 0], out=C[..., 0])
    S[..., 1:] = Se
    C[..., 1:] = Ce
    return S, C


def stacked_basis(w, tau):
    """``[S; C]`` (b, 2n, T) at times ``tau`` (b, T) [s] of each member's modes ``w`` (b, n)
    [1/s] (:func:`basis`'s numbers, from half angles, laid out for one product per member:
    mode by mode, each a contiguous (b, T) block)."""
    b, n = w.shape
    SC = np.empty((b, 2 * n, tau.shape[1]))
    first = 1 if n > 1 and not w[:, 0].any() else 0
    if first:   # (mode 0 rigid in every member, :func:`basis`)
        SC[:, 0] = tau
        np.multiply(0.5 * tau, tau, out=SC[:, n])
    we = w[:, first:]                   # (every other mode at once: a (b, n - first, T) block)
    rigid = we == 0
    some_rigid = bool(rigid.any())
    ws = np.where(rigid, 1.0, we) if some_rigid else we
    half_angle((0.5 * ws)[:, :, None] * tau[:, None, :], (1.0 / ws)[:, :, None],
               out=(SC[:, first:n], SC[:, n + first:]))
    if some_rigid:
        np.copyto(SC[:, first:n], tau[:, None, :], where=rigid[:, :, None])
        np.copyto(SC[:, n + first:], (0.5 * tau * tau)[:, None, :], where=rigid[:, :, None])
    return SC


@dataclass
class Sums:
    """Functions ``g(τ) = c + Σ α S(τ) + γ C(τ)``: ``c`` (b, F), ``alpha, gamma`` (b, F, n) on
    the modes ``kappa, w`` (b, n) of their member."""

    c: np.ndarray
    alpha: np.ndarray
    gamma: np.ndarray
    kappa: np.ndarray
    w: np.ndarray

    def derivative(self) -> "Sums":
        """``g'`` (``S' = 1 - κ C``, ``C' = S``)."""
        return Sums(msum(self.alpha), self.gamma, -self.kappa[:, None] * self.alpha,
                    self.kappa, self.w)

    def at(self, tau):
        """``g`` (b, F, T) at times ``tau`` (b, T) of each member."""
        return self.on(self.basis(tau))

    def basis(self, tau):
        """``[S; C]`` (b, 2n, T) at times ``tau`` (b, T) of each member (for :meth:`on`)."""
        return stacked_basis(self.w, tau)

    @cached_property
    def coefficients(self):
        """``[α, γ]`` (b, F, 2n): the coefficients of the basis of :meth:`basis`."""
        return np.concatenate([self.alpha, self.gamma], axis=2)

    def on(self, SC):
        """``g`` (b, F, T) on the basis ``[S; C]`` (b, 2n, T) of :meth:`basis` (one product:
        NumPy's stacked products of small matrices cost mostly their count)."""
        out = np.matmul(self.coefficients, SC)
        out += self.c[:, :, None]
        return out

    def each_at(self, tau):
        """``g`` (b, F) at one time per function ``tau`` (b, F), or per member (b,)."""
        if np.ndim(tau) == 1:     # (one basis per member)
            S, C = (x[:, None, :] for x in basis(self.w, tau, exact=True))
        else:
            S, C = basis(self.w[:, None, :], tau, exact=True)
        return self.c + msum(self.alpha * S + self.gamma * C)

    def curvature_bound(self, T=None):
        """Bounds (b, F) on ``|g''|`` over ``[0, T]`` (:meth:`._modes.Modes.curvature_bounds`;
        ``T`` (b, F) or None: over any interval, ``|S| <= 1/ω``)."""
        w = self.w[:, None, :]
        inv = 1.0 / np.where(w > 0, w, 1.0)
        if T is None:
            s_max = np.where(w > 0, inv, 0.0)   # (a rigid mode's κ α term is 0)
        else:
            s_max = np.where(w > 0, np.minimum(np.asarray(T)[..., None], inv),
                             np.asarray(T)[..., None])
        k = self.kappa[:, None, :]
        term = np.where(k != 0, np.abs(self.alpha * k) * s_max, 0.0)
        return msum(term) + msum(np.abs(self.gamma))

    @staticmethod
    def joined(parts) -> "Sums":
        """The functions of ``parts`` (Sums on as many modes) one after the other."""
        if len(parts) == 1:
            return parts[0]
        return Sums(*(np.concatenate([getattr(q, name) for q in parts])
                      for name in ("c", "alpha", "gamma", "kappa", "w")))

    def take(self, rows, cols=None) -> "Sums":
        """The functions of members ``rows`` (and, per member, ``cols``)."""
        if cols is None:
            return Sums(self.c[rows], self.alpha[rows], self.gamma[rows], self.kappa[rows],
                        self.w[rows])
        return Sums(self.c[rows, cols][:, None], self.alpha[rows, cols][:, None],
                    self.gamma[rows, cols][:, None], self.kappa[rows], self.w[rows])


class ModesCache:
    """The last :data:`SLOTS` sets of modes (``κ, Q`` of :class:`BatchMotion`) of each of
    ``n`` members of ``N`` vehicles and ``K`` contacts, by their slopes: a member's modes
    depend on its masses and slopes only, and a contact that chatters takes few slopes over
    and over (the same numbers as computed anew: each member's are its own LAPACK calls)."""

    SLOTS = 4

    def __init__(self, n: int, N: int, K: int):
        self.slope = np.full((n, self.SLOTS, K), np.nan)    # (NaN: an empty slot)
        self.kappa = np.zeros((n, self.SLOTS, N))
        self.Q = np.zeros((n, self.SLOTS, N, N))
        self.next = np.zeros(n, int)

    def get(self, ix, slope):
        """``(κ (b, N), Q (b, N, N), have (b,))`` of members ``ix`` (b,) at slopes ``slope``
        (b, K): their modes where ``have`` (zeros elsewhere), for ``BatchMotion(known=)``."""
        match = mall(self.slope[ix] == slope[:, None, :])
        have = many(match)
        slot = np.argmax(match, axis=1)
        kappa, Q = self.kappa[ix, slot], self.Q[ix, slot]
        kappa[~have], Q[~have] = 0.0, 0.0
        return kappa, Q, have

    def put(self, ix, slope, motion: BatchMotion, new) -> None:
        """Keep the modes of ``motion`` of the members ``ix[new]`` at ``slope``."""
        rows = ix[new]
        slot = self.next[rows]
        self.slope[rows, slot] = slope[new]
        self.kappa[rows, slot], self.Q[rows, slot] = motion.kappa[new], motion.Q[new]
        self.next[rows] = (slot + 1) % self.SLOTS


def _groups(slope_on: np.ndarray) -> np.ndarray:
    """(N,) the group of each vehicle (joined by contacts with a slope, ``slope_on`` (K,))."""
    return np.concatenate([[0], np.cumsum(~slope_on)])


class BatchMotion:
    """The closed-form motion of one segment of every member.

    Parameters: ``m`` (b, N) [mass]; ``x0, v0`` (b, N) [length, velocity]; ``slope, force``
    (b, K) each contact's active slope [force/length] (0: open) and force at the start
    [force]; ``C`` (K, N) the deformation map (:func:`._modes.deformation_map`); ``known``,
    optional: ``(κ (b, N), Q (b, N, N), have (b,) bool)``, the modes of the members ``have``,
    already computed (:class:`ModesCache`).
    """

    def __init__(self, m, x0, v0, slope, force, C, known=None):
        self.x0, self.v0, self.m, self.force, self.C = x0, v0, m, force, C
        b, N = m.shape
        root = np.sqrt(m)
        kappa, Q, have = known if known is not None else (np.zeros((b, N)),
                                                          np.zeros((b, N, N)),
                                                          np.zeros(b, bool))
        on = slope != 0
        code = on @ (1 << np.arange(on.shape[1]))
        for pattern in np.unique(code[~have]):
            rows = np.flatnonzero((code == pattern) & ~have)
            kappa[rows], Q[rows] = _modes(C, slope[rows], root[rows], on[rows[0]])
        self.kappa, self.Q = kappa, Q
        self.w = np.sqrt(kappa)
        self.T = Q / root[:, :, None]                                    # Δx = T q
        for pattern in np.unique(code):   # (as :func:`._carry.rigid_rows`: a group's rigid
            rows = np.flatnonzero(code == pattern)   # column one number on its vehicles)
            group = _groups(on[rows[0]])
            for g in range(int(group[-1]) + 1):
                members = np.flatnonzero(group == g)
                self.T[rows[:, None], members, g] = self.T[rows, members[0], g][:, None]
        f0 = force @ -C                                                  # (b, N)
        self.a = np.einsum("bji,bj->bi", Q, root * v0)                   # q'(0)
        self.b = np.einsum("bji,bj->bi", Q, f0 / root)                   # q''(0)
        self.P = np.einsum("kn,bnj->bkj", C, self.T)                     # ΔD = P q
        self.fastest = mmax(self.w)

    def state(self, tau):
        """Positions and velocities (b, N) each at its member's time ``tau`` (b,)."""
        S, C = basis(self.w, tau, exact=True)
        q = S * self.a + C * self.b
        dq = S * self.b - self.kappa * C * self.a
        return (self.x0 + np.einsum("bij,bj->bi", self.T, q),
                self.v0 + np.einsum("bij,bj->bi", self.T, dq))

    def deformations(self, tau, D0, W0):
        """The deformations (b, K) [length] each at its member's time ``tau`` (b,) from those
        at the start ``D0`` and the closing rates ``W0`` (b, K), as
        :func:`._carry.deformations`: ``D0 + P q(τ)``; a contact between two groups
        (a rigid part in its row of ``P``) ``D0 + W0 τ + A0 τ²/2 + P ((S - τ) a + (C - τ²/2)
        b)``, ``A0`` the relative acceleration at the start."""
        S, C = basis(self.w, tau, exact=True)
        t = np.asarray(tau, float)[:, None]
        half = 0.5 * t * t
        D = D0 + np.einsum("bkj,bj->bk", self.P, S * self.a + C * self.b)
        rigid = (self.kappa == 0)[:, None, :]
        spans = np.any((self.P != 0) & rigid, axis=2)
        if not spans.any():
            return D
        acc = (self.force @ -self.C) / self.m
        rel = np.where(rigid[:, 0], 0.0, (S - t) * self.a + (C - half) * self.b)
        moved = W0 * t + (acc @ self.C.T) * half + np.einsum("bkj,bj->bk", self.P, rel)
        return np.where(spans, D0 + moved, D)

    def rows(self, M) -> Sums:
        """``M q(τ)`` for rows ``M`` (b, F, N) of the modal coordinates, with ``c = 0``."""
        return Sums(np.zeros(M.shape[:2]), M * self.a[:, None, :], M * self.b[:, None, :],
                    self.kappa, self.w)

    def rates(self, M) -> Sums:
        """``M q'(τ) - M q'(0)`` for rows ``M`` (b, F, N), with ``c = 0``: ``q' - q'(0) =
        a (S' - 1) + b S``, written as the series ``Σ b S - κ a C``."""
        return Sums(np.zeros(M.shape[:2]), M * self.b[:, None, :],
                    -self.kappa[:, None, :] * M * self.a[:, None, :], self.kappa, self.w)


def _modes(C, slope, root, on):
    """Eigenvalues (b, N) and orthonormal eigenvectors (b, N, N) of the members ``slope``
    (b, K), ``root`` (b, N) that share the pattern ``on`` (K,) of loaded contacts, with the same
    arithmetic as :func:`._modes._modes` for one chain."""
    b, N = root.shape
    group = _groups(on)
    n_rigid = int(group[-1]) + 1
    R = np.zeros((b, N, n_rigid))
    R[:, np.arange(N), group] = root
    R /= np.linalg.norm(R, axis=1, keepdims=True)
    if n_rigid == N:
        return np.zeros((b, N)), R
    Cr = C[None, :, :] / root[:, None, :]
    A = np.swapaxes(Cr, 1, 2) @ (slope[:, :, None] * Cr)
    A = 0.5 * (A + np.swapaxes(A, 1, 2))
    lam, V = np.linalg.eigh(A)
    elastic = np.argsort(np.abs(lam), axis=1)[:, n_rigid:]
    E = np.take_along_axis(V, elastic[:, None, :], axis=2)
    E = E - R @ (np.swapaxes(R, 1, 2) @ E)
    E, _ = np.linalg.qr(E)
    lam_e = np.einsum("bij,bij->bj", E, A @ E)
    # (each eigenvalue the squared singular value of its member's factor, as the single
    # solve's, :func:`._eigen._factor_kappa`, paired with these vectors in ascending order;
    # the batch's slopes are never negative: no falling table piece)
    rank = np.argsort(np.argsort(lam_e, axis=1), axis=1)
    lam_e = np.take_along_axis(_factor_kappa(np.sqrt(slope)[:, :, None] * Cr, N - n_rigid),
                               rank, axis=1)
    return (np.concatenate([np.zeros((b, n_rigid)), lam_e], axis=1),
            np.concatenate([R, E], axis=2))
