"""Contact laws (this module keeps the names other modules import; the laws live in
:mod:`lsc.laws`: the IF-D hysteresis, the spring–dashpot family, their restitution relations
and the registry)."""

from __future__ import annotations

from .laws import (BIG, MODE_LOADING, MODE_OPEN, MODE_UNLOADING, REBOUND_RESOLUTION, STATUS,
                   BrachLaw, HuntCrossleyLaw, HysteresisLaw, KelvinLaw, SpringDashpotLaw,
                   brach_restitution, hunt_crossley_a, kelvin_restitution, kelvin_zeta, make_law)

#: The spring–dashpot laws' base class (the name this module gave it).
DampingLaw = SpringDashpotLaw

__all__ = ["HysteresisLaw", "DampingLaw", "SpringDashpotLaw", "KelvinLaw", "HuntCrossleyLaw",
           "BrachLaw", "make_law", "kelvin_restitution", "kelvin_zeta", "hunt_crossley_a",
           "brach_restitution", "MODE_OPEN", "MODE_LOADING", "MODE_UNLOADING", "STATUS", "BIG",
           "REBOUND_RESOLUTION"]
