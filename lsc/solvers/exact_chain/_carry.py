"""The deformations exact-chain carries from segment to segment, not re-derived from the
positions (:mod:`._solve`, the batch's :mod:`._batch`).

Far down the road a deformation taken as a difference of positions is known only to an ulp of
the distance travelled (2.8e-14 ft at 244 ft), and a stiff contact makes that a wrong impulse.
So each segment ends with its start's deformations plus the change its closed-form motion gives
(:func:`deformations`), relative by construction: a group of vehicles joined by loaded contacts
has one number for its translation on all of them (:func:`rigid_rows`), so a deformation inside
it has exactly none of it; a contact between two groups (:func:`spanning`) moves by their
relative speed and acceleration at the start and the modes' departure from them. The model's
transitions and forces read those through :func:`frame` (:class:`Carried`); the positions the
Result reports stay the absolute ones.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rigid_rows", "spanning", "deformations", "frame", "Carried", "event_rows"]


def rigid_rows(T, kappa):
    """``T`` (N, n) with each rigid mode's column (``κ = 0``) one number on every vehicle of
    its group (its first vehicle's: ``1/√M_g`` to rounding, as each is): a contact inside a
    group then has exactly no rigid part (its row of ``P = C T`` is 0 there), so the group's
    translation, however far it goes, never enters its deformation."""
    for j in np.flatnonzero(kappa == 0).tolist():
        rows = np.flatnonzero(T[:, j])
        T[rows, j] = T[rows[0], j]
    return T


def spanning(P, kappa):
    """The contacts whose row of ``P`` (K, n) has a rigid part (``κ = 0``): those between two
    groups (open, or to a held vehicle), whose deformation changes by the groups' relative
    translation (:func:`deformations`)."""
    return np.flatnonzero(np.any(P[:, kappa == 0] != 0, axis=1))


def deformations(motion, tau: float, D0: list, W0: list) -> list:
    """The deformations (K,) [length] at one time ``tau`` [s] of a segment's ``motion``
    (:class:`~._modes.Motion`) from those at its start, ``D0`` (K,), and the closing rates
    ``W0`` (K,) [velocity]: ``D0 + P q(τ)``, the change in the modes, not a difference of
    positions (a group's translation has no part in a deformation inside it: :func:`rigid_rows`).
    A contact between two groups (:func:`spanning`) changes by their relative translation too,
    taken from the relative motion at the start, ``W0 τ + A0 τ²/2`` (``A0`` the relative
    acceleration), and the modes' departure from it, ``Σ P (S - τ) a + (C - τ²/2) b`` (zero on
    the rigid modes): two groups moving alike keep their deformation exactly."""
    tau = float(tau)
    q, _ = motion._modal_at(tau)
    _, _, S, C, a, b = motion._at
    P = motion.P
    D = np.asarray(D0, float) + P @ q
    spans = motion.shape.spanning
    if spans.size:
        half = 0.5 * tau * tau
        rel = [(s - tau) * x + (c - half) * y for s, c, x, y in zip(S, C, a, b)]
        acc = motion.shape.peak_of_force[len(D0):] @ motion.force
        if motion.offset is not None:
            acc = acc + motion.offset[len(D0):]
        for k in spans.tolist():
            D[k] = D0[k] + (W0[k] * tau + (acc[k] - acc[k + 1]) * half + float(P[k] @ rel))
    return D.tolist()


def frame(y, p, D):
    """``(y, p)`` as the model reads deformations ``D`` (K, ...) [length] from them: every
    position at the largest ``|x|`` (the positions' rounding, which tolerances such as
    :func:`lsc.lock_law.force_rounding` read, as it was) and the gaps ``-D``, so that
    ``x_k - x_{k+1} - gap_k`` is ``D_k`` exactly; the velocities (the closing rates) as they
    are. ``y`` (2N, ...), ``p`` the model's parameters."""
    D = np.asarray(D, float)
    y, N = np.array(y, float), len(D) + 1
    y[:N] = np.abs(y[:N]).max(axis=0)
    return y, dict(p, gap=-D)


class Carried:
    """The transitions the segment loop drives (``parts``), each event's read at the
    deformations ``chain`` (a :class:`~._solve._Chain`) carried to the segment's end
    (:func:`frame`), not at the positions' differences; everything else is ``parts``' own."""

    def __init__(self, parts, chain):
        self._parts, self._chain = parts, chain

    def __getattr__(self, name):
        value = self.__dict__[name] = getattr(self._parts, name)   # (looked up once)
        return value

    def apply_event(self, i, t, y, disc, p, xp=None):
        """``parts``' transition of event ``i`` at the end state ``y``, its deformations the
        carried ones (where ``y`` is the last segment's end, as the loop passes it)."""
        carried = self._chain.carried_at(y)
        if carried is not None:
            y, p = frame(y, p, carried)
        return self._parts.apply_event(i, t, y, disc, p)


def event_rows(chain, segments, model=None) -> dict | None:
    """The rows at the event points (:func:`~lsc.solvers.segments.event_rows`: both ends of
    every segment, in its own discrete state) from the states and the deformations ``chain``
    (a :class:`~._solve._Chain`) carried at the segments' ends (``None``: no segment): the
    forces ``model``'s (the chain's own by default, evaluated once on all of them; a locking
    model's, its locked ones included, segment by segment)."""
    if not segments or len(segments) != len(chain.ends):
        return None
    N = chain.N
    Y = np.array([y for pair in chain.ends for y in pair]).T      # (2N, 2S)
    # (the forces from the deformations carried, not from the positions: frame)
    D = np.array([d for pair in chain.deformations for d in pair]).T   # (K, 2S)
    if model is None:
        # each contact's (and brake's) discrete state on both ends of every segment
        disc = [_Ends(segments, k) for k in range(len(segments[0].disc))]
        Yd, p = frame(Y, chain.model.params, D)
        F, _, acc = chain.model.accelerations(Yd, disc, p)
    else:
        F, acc = np.empty(D.shape), np.empty((N, D.shape[1]))
        for i, s in enumerate(segments):
            ends = slice(2 * i, 2 * i + 2)
            Yd, p = frame(Y[:, ends], model.params, D[:, ends])
            f, _, a = model.accelerations(Yd, s.disc, p)
            F[:, ends], acc[:, ends] = np.asarray(f, float), np.asarray(a, float)
    return {"t": np.array([t for s in segments for t in (s.t0, s.t1)]), "x": Y[:N].T,
            "v": Y[N:2 * N].T, "a": acc.T, "deformation": D.T, "force": F.T}


class _Ends(dict):
    """Contact ``k``'s discrete state on both ends of every segment: each entry an array (2S,),
    gathered when the law first reads it."""

    def __init__(self, segments, k: int):
        super().__init__()
        self.segments, self.k = segments, k

    def __missing__(self, name):
        k = self.k   # (each segment's value twice, as np.repeat(values, 2) gives them)
        value = self[name] = np.array([v for s in self.segments for v in (s.disc[k][name],) * 2])
        return value
