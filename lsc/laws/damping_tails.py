"""A damping law's rebound whose end rounding decides (Hunt–Crossley, Brach): said in
``Result.warnings`` by every backend (docs/physics.rst)."""

from __future__ import annotations

__all__ = ["damping_tails"]

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
    left at separation are not converged."""
    out = []
    for k, (contact, rec) in enumerate(zip(scene.contacts, contacts)):
        name = getattr(contact.law, "law", None)
        dmax, dsep = float(rec["dmax"]), float(rec["dperm"])
        if name in _DAMPING_FACTORS and dmax > 0 and dsep > _TAIL * dmax:
            out.append(
                f"contact {k} ({name}): its rebound ended where the force's damping factor "
                f"({_DAMPING_FACTORS[name]}) reached zero to the solver's rounding, at a "
                f"deformation of {dsep:.4g} ({dsep / dmax:.3g} of its max), where the law's "
                "force ends at zero deformation: at this restitution the force falls below the "
                "solver's resolution long before that, so the impact's duration, separation time "
                "and the deformation left at separation are where rounding put them (they change "
                "with rtol); the ΔV is not affected")
    return tuple(out)
