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

import functools
import math
from dataclasses import dataclass

import numpy as np

from ._carry import rigid_rows, spanning
from ._eigen import _block_eigh, _factor_kappa

__all__ = ["Modes", "Series", "Motion", "Shape", "deformation_map"]


@functools.lru_cache(maxsize=64)
def deformation_map(N: int) -> np.ndarray:
    """``C`` (N-1, N): ``D_k = x_k - x_{k+1} - gap_k`` (built once per ``N``, read-only)."""
    C = np.zeros((N - 1, N))
    C[np.arange(N - 1), np.arange(N - 1)] = 1.0
    C[np.arange(N - 1), np.arange(1, N)] = -1.0
    C.flags.writeable = False
    return C


class Modes:
    """The modes of one segment: eigenvalues ``kappa`` (n,) [1/s²], split once into harmonic
    (``κ > 0``), rigid (``κ = 0``) and hyperbolic (``κ < 0``) ones."""

    def __init__(self, kappa):
        self.kappa = np.asarray(kappa, float)
        self.w = np.sqrt(np.abs(self.kappa))
        # (for one time at a time, in plain floats: ten times cheaper than NumPy on a few modes)
        self._kappa = self.kappa.tolist()
        w = self.w.tolist()
        self._kinds = [(1 if k > 0 else -1 if k < 0 else 0, v) for k, v in zip(self._kappa, w)]
        self.pos, self.neg, self.rigid = (
            np.array([j for j, (kind, _) in enumerate(self._kinds) if kind == which], dtype=int)
            for which in (1, -1, 0))
        self._fastest = max(w, default=0.0)
        self._slowest = min((v for v in w if v > 0), default=0.0)
        # the harmonic modes (a slice where they follow each other, as they do after the rigid
        # ones) and their ω, for the basis on a grid
        if self.pos.size:
            lo, hi = int(self.pos[0]), int(self.pos[-1]) + 1
            idx = slice(lo, hi) if hi - lo == self.pos.size else self.pos
            self._harmonic = (idx, self.w[self.pos])
        else:
            self._harmonic = None
        # |S| <= 1/ω on a harmonic mode whatever the window (min with T in curvature_bounds)
        self._inv_w = np.array([1.0 / v if k > 0 else math.inf for k, v in zip(self._kappa, w)])

    def basis_at(self, tau: float) -> tuple[list, list]:
        """``S, C`` (lists, one per mode) at one time ``tau`` [s] (as :meth:`basis`, from half
        angles, on Python floats)."""
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
        if tau.shape[0] <= 4:   # (a few times: in plain floats, as basis_at)
            S, C = zip(*(self.basis_at(t) for t in tau[:, 0].tolist()))
            return np.array(S), np.array(C)
        S = np.empty((tau.shape[0], self.kappa.size))
        C = np.empty_like(S)
        if self._harmonic is not None:
            idx, w = self._harmonic
            h = (0.5 * w) * tau
            sw = np.sin(h) / w
            S[:, idx] = 2.0 * sw * np.cos(h)
            C[:, idx] = 2.0 * sw * sw
        if self.neg.size:
            w = self.w[self.neg]
            h = (0.5 * w) * tau
            with np.errstate(over="ignore", invalid="ignore"):
                sw = np.sinh(h) / w
                S[:, self.neg] = 2.0 * sw * np.cosh(h)
                C[:, self.neg] = 2.0 * sw * sw
        if self.rigid.size:
            S[:, self.rigid] = tau
            C[:, self.rigid] = 0.5 * tau * tau
        return S, C

    def curvature_bounds(self, alpha, gamma, T: float):
        """Bounds on ``|g''|`` over ``[0, T]`` for series of coefficients ``alpha, gamma``
        (..., n): ``g'' = Σ -κ α S + γ S'``, with ``|S| <= min(T, 1/ω)``, ``|S'| <= 1``
        (harmonic and rigid modes) and ``S <= sinh(λT)/λ``, ``S' <= cosh(λT)`` (hyperbolic)."""
        s_max = np.minimum(T, self._inv_w)
        if not self.neg.size:
            # (np.add.reduce: the sum np.sum computes, without its Python wrapper)
            return np.abs(alpha * self.kappa) @ s_max + np.add.reduce(np.abs(gamma), axis=-1)
        ds_max = np.ones_like(s_max)
        w = self.w[self.neg]
        with np.errstate(over="ignore"):
            s_max[self.neg] = np.sinh(w * T) / w
            ds_max[self.neg] = np.cosh(w * T)
        return np.abs(alpha * self.kappa) @ s_max + np.abs(gamma) @ ds_max

    def fastest(self) -> float:
        """The largest ``sqrt|κ|`` [1/s] (0: all rigid)."""
        return self._fastest

    def slowest(self) -> float:
        """The smallest non-zero ``sqrt|κ|`` [1/s] (0: all rigid)."""
        return self._slowest


@dataclass
class Series:
    """``g(τ) = c + Σ_j α_j S_j(τ) + γ_j C_j(τ)`` on the :class:`Modes` of one segment."""

    c: float
    alpha: np.ndarray
    gamma: np.ndarray
    modes: Modes

    def derivative(self) -> "Series":
        """``g'``: ``S' = 1 - κ C``, ``C' = S``."""
        return Series(float(np.add.reduce(self.alpha)), self.gamma,
                      -self.modes.kappa * self.alpha, self.modes)

    def __call__(self, tau):
        """``g`` at times ``tau`` (a scalar, or 1-d)."""
        if isinstance(tau, float) or np.ndim(tau) == 0:
            tau, total = float(tau), 0.0
            S, C = self.modes.basis_at(tau)
            for s, c, (_, _, a, g, _) in zip(S, C, self._modal()):
                total += a * s + g * c
            return self.c + total
        S, C = self.modes.basis(np.atleast_1d(tau))
        return self.c + S @ self.alpha + C @ self.gamma

    def _modal(self) -> list:
        """``[(kind, ω_j, α_j, γ_j, κ_j)]`` as Python floats (for one time at a time)."""
        coef = self.__dict__.get("_coef")   # (no AttributeError raised on the first call)
        if coef is None:
            coef = self._coef = [(kind, w, a, g, k) for (kind, w), a, g, k in
                                 zip(self.modes._kinds, self.alpha.tolist(),
                                     self.gamma.tolist(), self.modes._kappa)]
        return coef

    def with_slope(self, tau):
        """``(g(τ), g'(τ))`` at one time ``tau`` [s] (or at times, 1-d), from one evaluation of
        the basis (``g' = Σ α_j (1 - κ_j C_j) + γ_j S_j``)."""
        if not isinstance(tau, float):
            S, C = self.modes.basis(tau)
            return (self.c + S @ self.alpha + C @ self.gamma,
                    np.sum(self.alpha) - C @ (self.modes.kappa * self.alpha) + S @ self.gamma)
        g, dg = self.c, 0.0
        S, C = self.modes.basis_at(tau)
        for s_j, c_j, (_, _, a, c, k) in zip(S, C, self._modal()):
            g += a * s_j + c * c_j
            dg += a * (1.0 - k * c_j) + c * s_j
        return g, dg

    def on(self, S, C):
        """``g`` on a grid whose basis is ``S, C`` (:meth:`Modes.basis`)."""
        return self.c + S @ self.alpha + C @ self.gamma

    def derivatives_from_zero(self):
        """``g(0), g'(0), ..., g^(p)(0), ...`` one at a time, as many as are asked for:
        ``S^(2m+1)(0) = (-κ)^m``, ``C^(2m+2)(0) = (-κ)^m`` and the others vanish, so
        ``g^(2m+1)(0) = Σ α (-κ)^m``, ``g^(2m+2)(0) = Σ γ (-κ)^m``."""
        return _at_zero_terms(self.c, self.alpha.tolist(), self.gamma.tolist(),
                              [-k for k in self.modes._kappa])

    def each_at_zero(self, size: float):
        """``(g^(p)(0), the size of its terms)`` for ``p = 0, 1, ...``, one at a time (as
        :meth:`derivatives_from_zero` gives the first; the second is that on ``|α|, |γ|, |κ|``,
        ``size`` the size of ``g(0)``: their rounding is a few ulps of it; a search that stops at
        the first derivative clear of rounding computes no more)."""
        coef = self._modal()
        alpha, gamma = [x[2] for x in coef], [x[3] for x in coef]
        return zip(_at_zero_terms(self.c, alpha, gamma, [-x[4] for x in coef]),
                   _at_zero_terms(size, [abs(a) for a in alpha], [abs(g) for g in gamma],
                                  [abs(x[4]) for x in coef]))

    def curvature_bound(self, T: float) -> float:
        """A bound on ``|g''|`` over ``[0, T]`` (:meth:`Modes.curvature_bounds`)."""
        return float(self.modes.curvature_bounds(self.alpha, self.gamma, T))

    def oscillates(self) -> bool:
        """True when a mode with ``κ != 0`` enters ``g`` (else it is a quadratic in τ)."""
        used = (self.alpha != 0) | (self.gamma != 0)
        return bool(np.any(used & (self.modes.kappa != 0)))


class Shape:
    """The modes and maps of one set of active slopes (they repeat from segment to segment, so
    a chain keeps one per set): ``modes``, ``T`` (N, n) (``Δx = T q``), ``P`` (K, n)
    (``ΔD = P q``), and the maps from the start velocities (N,) and contact forces (K,) to the
    modal ``q'(0)``, ``q''(0)`` (n,).

    Parameters: ``m`` (N,) masses [mass]; ``slope`` (K,) each contact's active slope
    [force/length] (0 when open); ``incidence`` (N, K) the model's (contact ``k`` pushes
    vehicle ``k`` back and ``k+1`` forward).

    A Shape is a pure function of these three arrays and is never changed once built, so the
    ones built last are kept (:data:`SHAPES` of them, keyed by their bytes) and given back to a
    later chain with the same masses and slopes: the same object, hence the same numbers, without
    the eigensolver (a sweep's or a fit's chains repeat them solve after solve)."""

    _cache: dict = {}

    def __new__(cls, m, slope, incidence, held: tuple = ()):
        m, slope = np.asarray(m, float), np.asarray(slope, float)
        incidence = np.asarray(incidence, float)
        key = (m.tobytes(), slope.tobytes(), incidence.shape, incidence.tobytes(), held)
        shape = cls._cache.get(key)
        if shape is None:
            shape = super().__new__(cls)
            shape._build(m, slope, incidence, held)
            if len(cls._cache) >= SHAPES or len(cls._cache) * m.size ** 2 > SHAPE_ENTRIES:
                cls._cache.clear()
            cls._cache[key] = shape
        return shape

    def _build(self, m, slope, incidence, held=()):
        C = -incidence.T   # (K, N): D = C x - gap
        root = np.sqrt(m)
        kappa, Q = _modes(C, slope, root, held)
        self.modes = Modes(kappa)
        self.T = rigid_rows(Q / root[:, None], self.modes.kappa)
        self.P = C @ self.T
        self.minus_kappa_P = -self.modes.kappa * self.P   # (each row as -κ * P[k] gives it)
        self.spanning = spanning(self.P, self.modes.kappa)
        self.from_velocity = Q.T * root[None, :]
        self.from_force = self.T.T @ incidence
        # the contact forces and accelerations (K + N): from the forces at the start, and
        # their modal rows; those whose extrema are searched (the forces of the contacts with
        # a slope, the accelerations of vehicles between two of them: the others follow one
        # force, or none)
        inv_m = 1.0 / np.asarray(m, float)[:, None]
        force_rows = slope[:, None] * self.P
        if held:   # (a held vehicle's acceleration is 0: its rows are)
            incidence = incidence.copy()
            incidence[list(held)] = 0.0
        self.peak_of_force = np.concatenate([np.eye(slope.size), incidence * inv_m])
        self.peak_rows = np.concatenate([force_rows, (incidence @ force_rows) * inv_m])
        active = [s != 0 for s in slope.tolist()]
        pushed = [sum(a for a, x in zip(active, row) if x != 0) for row in incidence.tolist()]
        self.searched = np.array([k for k, a in enumerate(active) if a]
                                 + [len(active) + i for i, n in enumerate(pushed) if n > 1],
                                 dtype=int)


#: How many :class:`Shape` objects are kept for reuse (all dropped at once when full).
SHAPES = 4096
#: ... and at most about this many (N, N) matrix entries in all (each Shape holds a few (N, N)
#: and (K, N) matrices: a bound of some tens of MB for long chains).
SHAPE_ENTRIES = 1_000_000


def _at_zero_terms(c: float, alpha: list, gamma: list, factor: list):
    """``c, Σ α, Σ γ, Σ α f, Σ γ f, Σ α f², ...``, one at a time (as many as asked for)."""
    yield c
    power, p = [1.0] * len(alpha), 1
    while True:
        yield math.fsum(x * q for x, q in zip(alpha if p % 2 else gamma, power))
        if p % 2 == 0:
            power = [q * f for q, f in zip(power, factor)]
        p += 1


class Motion:
    """The closed-form motion of one segment.

    Parameters: ``m`` (N,) masses [mass]; ``x0, v0`` (N,) the state at the start [length,
    velocity]; ``slope`` (K,) each contact's active slope ``s_k`` [force/length] (0 when open)
    and ``force`` (K,) its force at the start [force]; ``incidence`` (N, K) the model's
    (contact ``k`` pushes vehicle ``k`` back and ``k+1`` forward); ``shape``: their
    :class:`Shape`, if already built (``slope`` is then not read); ``push`` (N,) constant
    forces on the vehicles beside the contacts' (a sliding brake's friction) [force], or
    ``None``: none (their accelerations, ``push / m``, are :attr:`offset`'s last N entries,
    after K zeros for the forces).
    """

    offset = None

    def __init__(self, m, x0, v0, slope, force, incidence, shape: Shape | None = None,
                 push=None):
        self.m, self.x0, self.v0, self.force = m, x0, v0, force
        shape = Shape(m, slope, incidence) if shape is None else shape
        self.shape = shape
        self.modes = shape.modes
        self.kappa = self.modes.kappa
        self.T, self.P = shape.T, shape.P
        self.a = shape.from_velocity @ v0                # q'(0)
        self.b = shape.from_force @ force                # q''(0)
        if push is not None:
            self.b = self.b + shape.T.T @ push
            self.offset = np.concatenate([np.zeros(len(force)), push / m])
        self.N = m.size
        self._pa = self._rate = self._at = None

    def state(self, tau):
        """Positions and velocities (2N, ...) at times ``tau`` (...) into the segment."""
        if isinstance(tau, float) or np.ndim(tau) == 0:   # (one time: the modal terms on
            # Python floats, same arithmetic)
            q, dq = self._modal_at(float(tau))
            return np.concatenate([self.x0 + self.T @ q, self.v0 + self.T @ dq])
        S, C = self.modes.basis(np.atleast_1d(tau))
        q = S * self.a + C * self.b
        dq = S * self.b - self.kappa * C * self.a    # q'(τ) - q'(0)
        x = self.x0[:, None] + self.T @ q.T
        v = self.v0[:, None] + self.T @ dq.T
        out = np.concatenate([x, v])
        return out[:, 0] if np.ndim(tau) == 0 else out

    def _modal_at(self, tau: float) -> tuple[list, list]:
        """``q(τ)`` and ``q'(τ) - q'(0)`` (lists, n) at one time ``tau`` [s] (the last time's
        kept, with its basis ``S, C`` and ``a, b`` as lists: a segment's end is asked for its
        state, then its deformations)."""
        if self._at is not None and self._at[0] == tau:
            return self._at[1]
        S, C = self.modes.basis_at(tau)
        a, b = self.a.tolist(), self.b.tolist()
        q = [s * x + c * y for s, c, x, y in zip(S, C, a, b)]
        dq = [s * y - k * c * x for s, c, x, y, k in zip(S, C, a, b, self.modes._kappa)]
        self._at = (tau, (q, dq), S, C, a, b)
        return q, dq

    def deformation(self, k: int, c: float, sign: float = 1.0) -> Series:
        """``c + sign ΔD_k(τ)`` (``sign`` ±1) as a :class:`Series`."""
        pa, pb = self._rows()
        if sign < 0:
            return Series(float(c), -pa[k], -pb[k], self.modes)
        return Series(float(c), pa[k], pb[k], self.modes)

    def closing_rate(self, k: int, w0: float) -> Series:
        """``Ḋ_k(τ) = w0 + ΔḊ_k(τ)`` as a :class:`Series` (``q' = a S' + b S``)."""
        if self._rate is None:
            self._rate = self.shape.minus_kappa_P * self.a
        return Series(float(w0), self._rows()[1][k], self._rate[k], self.modes)

    def velocity(self, i: int, sign: float = 1.0) -> Series:
        """``sign v_i(τ)`` (``sign`` ±1) as a :class:`Series` (as :meth:`closing_rate`)."""
        T = sign * self.T[i]
        return Series(sign * float(self.v0[i]), T * self.b, -self.kappa * T * self.a,
                      self.modes)

    def _rows(self):
        """``P a, P b`` (K, n): every contact's deformation in the modes (each row's products
        as a row alone would give them)."""
        if self._pa is None:
            self._pa = (self.P * self.a, self.P * self.b)
        return self._pa


def _modes(C, slope, root, held=()):
    """Eigenvalues (n,) [1/s²] and orthonormal eigenvectors (N, n) of
    ``M^{-1/2} Cᵀ diag(slope) C M^{-1/2}`` on the vehicles not ``held`` (``n`` of them; a held
    vehicle's row is 0: it does not move): the rigid modes exactly (one translation per group
    of free vehicles joined by contacts of non-zero slope, ``κ = 0``; none for a group that
    such a contact joins to a held vehicle: it is grounded), the others on their complement
    (:func:`_elastic`)."""
    N = root.size
    slopes = slope.tolist()
    if held:
        return _held_modes(C, slopes, root, held)
    group = [0]
    for s in slopes:
        group.append(group[-1] if s != 0 else group[-1] + 1)
    n_rigid = group[-1] + 1
    roots = root.tolist()
    mass = [0.0] * n_rigid   # (root² = m: each group's mass)
    for g, r in zip(group, roots):
        mass[g] += r * r
    norm = [math.sqrt(x) for x in mass]
    R = np.array([[r / norm[g] if g == j else 0.0 for j in range(n_rigid)]
                  for g, r in zip(group, roots)])
    if n_rigid == N:
        return np.zeros(N), R
    return _elastic(C / root[None, :], slope, R)


def _elastic(scaled, slope, R):
    """``(κ, Q)``: the rigid modes ``R`` (n, r) with κ = 0, then the other eigenvectors of
    ``A = scaledᵀ diag(slope) scaled`` (``scaled`` (K, n): ``C M^{-1/2}``), orthogonal to them.

    The eigenvectors are ``eigh``'s block by block (:func:`_block_eigh`); the eigenvalues,
    where no slope is negative, the squared singular values of the factor ``B = diag(√slope)
    scaled`` (:func:`_factor_kappa`; the batch's, :mod:`._batch_modes`, the same): ``eigh``
    gives every eigenvalue to rounding of the largest, so a slow mode behind a line ``1e10``
    times stiffer was ``1e-6`` off, and a long segment's motion drifted in energy by that
    (``4e-8`` of the chain's energy on a locked chain, ``3e-13`` with these)."""
    A = scaled.T @ (slope[:, None] * scaled)
    lam, V = _block_eigh(A, R)
    elastic = np.flatnonzero(~np.isnan(lam))
    kappa = lam[elastic]
    if elastic.size and min(slope.tolist()) >= 0.0:
        # (paired in ascending order, as eigh's: eigenvalues that eigh cannot tell apart are
        # within its error of each other either way)
        kappa = _factor_kappa(np.sqrt(slope)[:, None] * scaled, elastic.size)[np.argsort(
            np.argsort(kappa))]
    # (orthogonal to the rigid modes to rounding, and kept so: each group's momentum is exact)
    E = V[:, elastic]
    E -= R @ (R.T @ E)
    return np.concatenate([np.zeros(R.shape[1]), kappa]), np.concatenate([R, E], axis=1)


def _held_modes(C, slopes, root, held):
    """:func:`_modes` with the vehicles ``held`` (their rows 0, no mode of theirs)."""
    N = root.size
    free = [i for i in range(N) if i not in held]
    # the free vehicles' groups (a contact of non-zero slope between two free ones joins
    # them) and whether one is grounded (such a contact to a held vehicle)
    group, grounded = {}, []
    for i in free:
        if i > 0 and i - 1 in group and slopes[i - 1] != 0:
            group[i] = group[i - 1]
        else:
            group[i] = len(grounded)
            grounded.append(False)
        for k, j in ((i - 1, i - 1), (i, i + 1)):
            if 0 <= k < len(slopes) and slopes[k] != 0 and j in held:
                grounded[group[i]] = True
    rigid = [g for g, ground in enumerate(grounded) if not ground]
    roots = root.tolist()
    R = np.zeros((len(free), len(rigid)))
    for c, g in enumerate(rigid):
        rows = [r for r, i in enumerate(free) if group[i] == g]
        norm = math.sqrt(sum(roots[free[r]] ** 2 for r in rows))
        R[rows, c] = [roots[free[r]] / norm for r in rows]
    if not free:
        kappa, Qf = np.zeros(0), R
    elif len(rigid) == len(free):
        kappa, Qf = np.zeros(len(free)), R
    else:
        kappa, Qf = _elastic(C[:, free] / root[None, free], np.asarray(slopes, float), R)
    Q = np.zeros((N, len(free)))
    Q[free] = Qf
    return kappa, Q
