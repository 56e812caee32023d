"""The energy balance an exact chain solve closes: its own safety net.

Without brakes the contacts' work accounts for all the kinetic energy the chain loses: the
energy lost in the centre-of-mass frame equals what the contacts absorbed less what they
returned (``energy_absorbed``, ``energy_returned``). An exact solve closes that balance to
rounding (1e-14 of the relative kinetic energy, 1e-12 in the hard tests on thousands of random
chains); one that does not has handled some event wrongly, and its numbers are not given.
"""

from __future__ import annotations

import numpy as np

from ...errors import SimulationError

__all__ = ["BALANCE", "imbalance", "check_balance", "balanced"]

#: The largest energy imbalance (relative to the initial relative kinetic energy) a solve is
#: given with: far above rounding, far below a mishandled event (a contact left loading while
#: it opened for 5 ms beside a 1e15 lbf/ft rebound line: 2.8e-5).
BALANCE = 1e-8


def imbalance(m, v0, v_final, absorbed, returned):
    """``|KE lost - Σ (absorbed - returned)| / KE0`` in the centre-of-mass frame: masses ``m``,
    speeds ``v0``, ``v_final`` (..., N), the contacts' work (..., K), in one unit system."""
    m = np.asarray(m, float)

    def ke(v):
        v = np.asarray(v, float)
        vc = np.sum(m * v, axis=-1, keepdims=True) / np.sum(m, axis=-1, keepdims=True)
        return 0.5 * np.sum(m * (v - vc) ** 2, axis=-1)

    ke0 = ke(v0)
    work = np.sum(np.asarray(absorbed, float) - np.asarray(returned, float), axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.abs(ke0 - ke(v_final) - work) / ke0


def check_balance(result, brakes):
    """``result``, checked: a :class:`~lsc.errors.SimulationError` where, without ``brakes``
    (the model's: they take energy the contacts do not), it does not close its energy balance
    to :data:`BALANCE`."""
    if brakes:
        return result
    s = result.scene
    err = float(imbalance(s.masses, s.speeds, result.v_final, result.energy_absorbed,
                          result.energy_returned))
    if err > BALANCE:
        raise SimulationError(
            f"exact-chain: the energy balance closes only to {err:.3g} of the relative kinetic "
            f"energy (an exact solve closes it to rounding, below {BALANCE:g}): an event of "
            "this chain was handled wrongly (a contact's turn at a start within the rounding "
            "of a very stiff rebound line, for one), so its numbers are not given; solve it "
            "with method='scipy'")
    return result


def balanced(m, v0, metrics) -> np.ndarray:
    """(n,): the members of a batch (masses ``m``, speeds ``v0`` (n, N), ``metrics`` of
    :data:`lsc.result.METRICS`) that close their energy balance to :data:`BALANCE` (the others
    are solved alone, for :func:`check_balance`'s message)."""
    return ~(imbalance(m, v0, metrics["v_final"], metrics["energy_absorbed"],
                       metrics["energy_returned"]) > BALANCE)
