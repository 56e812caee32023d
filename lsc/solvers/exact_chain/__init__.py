"""Exact backend for chains of three or more vehicles on IF-D contacts (``method="exact-chain"``).

Between two events every contact is open or on an affine piece of its law, so the motion is
linear, ``M x'' = -K x + f``, and is solved in closed form in the modes of ``M^{-1} K``
(:mod:`._modes`); every event function is then a finite sum of sinusoids (and hyperbolic terms
on a falling table piece) plus a quadratic, whose first downward zero is found with a guarantee
that none is missed (:mod:`._roots`). The transitions are the model's own.

Braked vehicles slide (a constant friction force in the segment's constant force) or stick
(held: their degree of freedom leaves the modal problem); their stops and break-aways are event
functions like the others (:mod:`._brakes`).

A near-plastic pair pressed shut by its neighbours locks by :mod:`lsc.locking`'s rules (as in
SciPy): a segment with locked contacts is the closed-form motion of the reduced chain of
clusters, and the locks' releases are event functions like the others (:mod:`._locks`). A
braked chain never locks (:func:`lsc.locking.can_lock`, for every backend alike).

Many chains of one shape (straight loading and unloading lines) are solved at once by
:func:`solve_batch` (:mod:`._batch`: one NumPy evaluation per event over every member).

This module holds the declaration only; :func:`solve` and :func:`solve_batch` are imported on
first use.
"""

from __future__ import annotations

import importlib
import sys

from ..base import Backend

__all__ = ["BACKEND", "solve", "solve_batch"]

BACKEND = Backend(
    name="exact-chain", module="lsc.solvers.exact_chain",
    options=("t_end", "n_samples", "max_events"), exact=True, cost=2.0, vehicles=(3, None),
    solves=frozenset({"law:ifd", "loading:linear", "loading:table", "unloading:restitution",
                      "unloading:stiffness", "gap:open", "contact:lock", "effect:brake"}),
    batch=frozenset({"law:ifd", "loading:linear", "unloading:restitution",
                     "unloading:stiffness", "gap:open"}),
    batch_options=("max_events",),
    summary="exact piecewise solution of chains (modal closed form, guaranteed event search)",
    # auto picks it for every chain it declares (exact, and many times faster than SciPy)
    auto=True)

#: The module each lazily imported name comes from.
_LAZY = {"solve": "_solve", "solve_batch": "_batch"}


def __getattr__(name):
    # (read from its module every time, so that a patched one is seen; once imported, looked
    # up in sys.modules rather than through the import statement: a solve asks every time)
    if name in _LAZY:
        module = sys.modules.get(f"{__name__}.{_LAZY[name]}")
        if module is None:
            module = importlib.import_module(f".{_LAZY[name]}", __name__)
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
