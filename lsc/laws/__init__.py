"""Contact laws, written once as plain array code for NumPy and ``jax.numpy``, and their registry.

Every law works on one contact with deformation ``D`` [length] and closing rate ``Ddot``
[velocity] and keeps a small *discrete state* ``st`` (a dict of scalars) that is frozen inside a
segment and changes only at events. A law provides

- ``force(D, Ddot, st)``: the contact force [force], smooth inside a segment (no branch);
- ``events(D, Ddot, st)``: a tuple of event functions, each crossing zero **downward** when the
  event happens (inactive ones stay at a positive constant);
- ``init(D, Ddot, xp)`` and ``on_event(which, D, Ddot, st, xp)``: the discrete state at the start
  and after event ``which``, computed with ``xp.where`` so that the same code traces under JAX;

and declares itself: its ``name`` in scenes (``law = ...``), its scene keys
(``params_declared``, :class:`Param`), how it reads them (``read``) and how its model numbers
are built from them (``numbers``), and whether the generic integrators solve it
(``integrable``). :func:`register_law` adds a law; the scene loader and :func:`make_law` find
it by name.
"""

from __future__ import annotations

from ._common import (BIG, MODE_LOADING, MODE_OPEN, MODE_UNLOADING, REBOUND_RESOLUTION, REQUIRED,
                      STATUS, Param)
from .damping import BrachLaw, Damping, HuntCrossleyLaw, KelvinLaw, SpringDashpotLaw
from .hysteresis import Hysteresis, HysteresisLaw, Restitution, UnloadingStiffness, UnloadingTable
from .relations import brach_restitution, hunt_crossley_a, kelvin_restitution, kelvin_zeta

__all__ = ["HysteresisLaw", "SpringDashpotLaw", "KelvinLaw", "HuntCrossleyLaw", "BrachLaw",
           "Hysteresis", "Restitution", "UnloadingStiffness", "UnloadingTable", "Damping", "Param",
           "REQUIRED", "make_law", "law_class", "laws", "register_law", "unregister_law",
           "aliases", "kelvin_restitution", "kelvin_zeta", "hunt_crossley_a", "brach_restitution",
           "MODE_OPEN", "MODE_LOADING", "MODE_UNLOADING", "STATUS", "BIG", "REBOUND_RESOLUTION"]

#: Law name → class, in the order scenes' messages list them.
_LAWS: dict[str, type] = {}
_BUILT_IN = ("hysteresis", "kelvin", "hunt-crossley", "brach")


def register_law(cls: type) -> type:
    """Add a contact law class (usable as a decorator): scenes name it by ``cls.name`` (or one
    of ``cls.aliases``)."""
    if not getattr(cls, "name", ""):
        raise ValueError(f"a contact law needs a name, {cls.__name__} has none")
    _LAWS[cls.name] = cls
    return cls


def unregister_law(name: str) -> None:
    """Remove a law added with :func:`register_law` (built-in ones stay)."""
    if name not in _BUILT_IN:
        _LAWS.pop(name, None)


for _cls in (HysteresisLaw, KelvinLaw, HuntCrossleyLaw, BrachLaw):
    register_law(_cls)


def laws() -> dict[str, type]:
    """Every registered law: name → class."""
    return dict(_LAWS)


def aliases() -> dict[str, str]:
    """Other names scenes may use: alias → law name."""
    return {a: name for name, cls in _LAWS.items() for a in getattr(cls, "aliases", ())}


def law_class(name: str) -> type:
    """The class of the law named ``name`` (a registered name)."""
    return _LAWS[name]


def make_law(contact, mu_pair: float = 1.0):
    """The law object of a scene contact (only the laws the scene declares are built).

    ``mu_pair`` is the reduced mass of the two vehicles it joins [mass] (a Kelvin damping given
    as a damping coefficient needs it)."""
    spec = contact.law
    cls = _LAWS.get(getattr(spec, "name", None))
    if cls is None:
        raise TypeError(f"no contact law implements {type(spec).__name__}")
    if cls is HysteresisLaw:
        return HysteresisLaw(spec, getattr(contact, "failure", None), mu_pair)
    return cls(spec, mu_pair)
