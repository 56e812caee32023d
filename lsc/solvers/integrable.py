"""What the generic integrators (SciPy, diffrax) solve, declared once for both.

Apart from either backend so that reading one declaration imports neither the other's
integrators nor its dependencies (the diffrax backend no longer loads SciPy's).
"""

from __future__ import annotations

from ..effects import integrable_features

__all__ = ["FEATURES"]

#: Every built-in feature of the model, and those of registered laws and effects that declare
#: ``integrable``: the integrators solve any scene of the hybrid ODE.
FEATURES = integrable_features({
    "law:ifd", "loading:linear", "loading:table", "unloading:restitution",
    "unloading:stiffness", "unloading:table", "law:kelvin", "law:hunt-crossley", "law:brach",
    "effect:brake", "effect:failure", "effect:post-failure", "gap:open"})
