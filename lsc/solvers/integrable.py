"""What the generic integrators (SciPy, diffrax) solve, declared once for both.

Apart from either backend so that reading one declaration imports neither the other's
integrators nor its dependencies (the diffrax backend no longer loads SciPy's).
"""

from __future__ import annotations

from ..effects import integrable_features

__all__ = ["BUILTIN", "FEATURES"]

#: The model's built-in features that both integrators solve.
BUILTIN = frozenset({
    "law:ifd", "loading:linear", "loading:table", "unloading:restitution",
    "unloading:stiffness", "unloading:table", "law:kelvin", "law:hunt-crossley", "law:brach",
    "effect:brake", "effect:failure", "effect:post-failure", "gap:open"})
#: Every built-in feature of the model, and those of registered laws and effects that declare
#: ``integrable``: the integrators solve any scene of the hybrid ODE (a live set: a backend
#: that adds features of its own builds its set with
#: :func:`lsc.effects.integrable_features`, not with ``|``, which would freeze it).
FEATURES = integrable_features(BUILTIN)
