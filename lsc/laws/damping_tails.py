"""A damping law's rebound whose end rounding decides (Hunt–Crossley, Brach): said in
``Result.warnings`` by every backend, and in a study's ``warnings`` for every member
(docs/physics.rst)."""

from __future__ import annotations

import numpy as np

__all__ = ["damping_tails", "member_tails"]

#: The factor of a damping law's force that decides its rebound's end: ``F = k D^n (1 + α Ḋ)``
#: (Hunt–Crossley), ``F = D (k + c Ḋ)`` (Brach).
_DAMPING_FACTORS = {"hunt-crossley": "1 + α dD/dt", "brach": "k + c dD/dt"}
#: A damping law's contact that separates above this fraction of its max deformation ended its
#: rebound on its damping factor, not at ``D = 0``.
_TAIL = 1e-9


def damping_tails(scene, contacts) -> tuple:
    """A warning for each Hunt–Crossley or Brach contact whose rebound ended where its damping
    factor (:data:`_DAMPING_FACTORS`) reached zero, at a deformation above :data:`_TAIL` of its
    max. By the law's energy relation that factor only tends to zero as the rebound speed tends to
    its limit (the integral of ``μ u du`` over the factor diverges there), so the force ends at
    ``D = 0``; at a small restitution (Brach from about 0.05, Hunt–Crossley from about 0.01) the
    factor falls below the solver's rounding long before, and where it is taken to reach zero
    depends on the tolerance: the impact's duration, its separation time and the deformation
    left at separation are not converged. ``contacts``: each contact's record (``dmax``,
    ``dperm`` [length])."""
    return tuple(_tail(k, name, float(rec["dmax"]), float(rec["dperm"]))
                 for k, name, rec in _laws(scene, contacts)
                 if _ends_on_factor(float(rec["dmax"]), float(rec["dperm"])))


def member_tails(scene, max_deformation, permanent_deformation) -> list:
    """:func:`damping_tails` of every member of a study from its metrics (``(n, K)`` arrays
    [length]: each contact's max deformation and the deformation it separated at): ``[(n,)
    tuples]`` (empty where none; NaN metrics, a failed member: none)."""
    dmax = np.asarray(max_deformation, float)
    dsep = np.asarray(permanent_deformation, float)
    out = [() for _ in range(dmax.shape[0])]
    for k, name, _ in _laws(scene, range(dmax.shape[1])):
        with np.errstate(invalid="ignore"):
            hit = _ends_on_factor(dmax[:, k], dsep[:, k])
        for j in np.flatnonzero(hit):
            out[j] += (_tail(k, name, float(dmax[j, k]), float(dsep[j, k])),)
    return out


def _laws(scene, contacts):
    """``(k, law name, item of contacts)`` of the damping-law contacts."""
    for k, (contact, rec) in enumerate(zip(scene.contacts, contacts)):
        name = getattr(contact.law, "law", None)
        if name in _DAMPING_FACTORS:
            yield k, name, rec


def _ends_on_factor(dmax, dsep):
    """Whether a rebound separated above :data:`_TAIL` of its max deformation (floats or
    arrays)."""
    return (dmax > 0) & (dsep > _TAIL * dmax)


def _tail(k: int, name: str, dmax: float, dsep: float) -> str:
    return (f"contact {k} ({name}): its rebound ended where the force's damping factor "
            f"({_DAMPING_FACTORS[name]}) reached zero to the solver's rounding, at a "
            f"deformation of {dsep:.4g} ({dsep / dmax:.3g} of its max), where the law's "
            "force ends at zero deformation: at this restitution the force falls below the "
            "solver's resolution long before that, so the impact's duration, separation time "
            "and the deformation left at separation are where rounding put them (they change "
            "with rtol); the ΔV is not affected")
