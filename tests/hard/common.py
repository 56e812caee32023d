"""Shared pieces of the hard-case suite: the hard-mode switch, hypothesis settings, scene builders,
the backends that apply to a case and the checks every result must pass.

Every check is relative to a stated scale so that a failure says how far off a number was:

- no NaN or inf anywhere in a Result (series and metrics);
- momentum conserved to 1e-12 of ``sum m_i |v_i|`` where no external force acts;
- the energy balance, kinetic energy lost (in the centre-of-mass frame, so that a fast common
  motion does not cancel it away) = ``sum(energy_absorbed - energy_returned)``, closing to the
  backend's tolerance relative to the relative kinetic energy;
- agreement with an exact solution to the backend's tolerance (:func:`tolerance`).
"""

from __future__ import annotations

import functools
import os

import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

import helpers
import lsc

#: Hard mode: ``LSC_HARD=1`` in the environment, or ``pytest --hard`` (tests/conftest.py sets it).
HARD = helpers.hard_mode()

#: Rounding: float64 machine epsilon.
EPS = float(np.finfo(float).eps)

#: Momentum, relative to ``sum m_i |v_i|`` (the issue's 1e-12; every backend conserves it to a
#: few ulps: the contact force acts equal and opposite in every stage of every step).
MOMENTUM_RTOL = 1e-12

#: Global error allowed per unit of ``rtol`` for each SciPy integrator and diffrax solver (the
#: local error per step is ``rtol``; these are the measured worst global errors on the hard cases
#: times a margin of about 10). A mislocated or missed event is off by far more.
GLOBAL_FACTOR = {"DOP853": 100.0, "RK45": 300.0, "RK23": 300.0, "LSODA": 3000.0, "BDF": 3000.0,
                 "Radau": 300.0, "Dopri8": 300.0, "Tsit5": 300.0, "Dopri5": 300.0}

#: The SciPy integrators every applicable hard case runs on (DOP853 is the default).
SCIPY_INTEGRATORS = ("DOP853", "RK45", "LSODA")


#: ``LSC_CASES_SCALE``: multiply every case count (e.g. 0.1 while developing a property).
SCALE = float(os.environ.get("LSC_CASES_SCALE", "1") or 1)


def cases(default: int, hard: int | None = None) -> int:
    """Number of generated cases: ``default``, or ``hard`` (20 x default) in hard mode."""
    n = (hard if hard is not None else 20 * default) if HARD else default
    return max(1, int(round(n * SCALE)))


def hard_settings(default: int, hard: int | None = None, **kw):
    """Hypothesis settings for a hard-case property: ``cases(default, hard)`` examples, no
    deadline (a case's time depends on its numbers) and no too-slow health check."""
    return settings(max_examples=cases(default, hard), deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much],
                    **kw)


have_diffrax = helpers.have_diffrax


# ----------------------------------------------------------------------------- strategies
def log_uniform(lo: float, hi: float):
    """Floats spread evenly in log10 between ``lo`` and ``hi`` (both ends included)."""
    return st.floats(np.log10(lo), np.log10(hi)).map(lambda x: float(10.0 ** x))


#: Restitution: the three named hard values, anything in [0, 1], or near-plastic (1e-12 to 1e-2:
#: rebounds a few ulps to a few thousand ulps of the max deformation wide).
restitutions = st.one_of(st.sampled_from([0.0, 1e-6, 1.0]), st.floats(0.0, 1.0),
                         log_uniform(1e-12, 1e-2))
#: Mass of the rear vehicle [slug] and the mass ratio m2/m1 from 1:1000 to 1000:1.
masses = st.tuples(log_uniform(1.0, 1000.0), log_uniform(1e-3, 1e3)).map(
    lambda mr: (mr[0], mr[0] * mr[1]))
#: System stiffness [lbf/ft].
stiffnesses = log_uniform(1e2, 1e9)
#: Closing speed [ft/s].
closing_speeds = log_uniform(1e-4, 150.0)
#: Speed of the front vehicle [ft/s]: at rest, or moving either way.
front_speeds = st.one_of(st.just(0.0), st.floats(-30.0, 60.0))


# ----------------------------------------------------------------------------- scenes
#: The shared builders (tests/helpers.py) in US units: masses [slug], speeds [ft/s].
two_cars = functools.partial(helpers.two_cars, units="US")
chain = functools.partial(helpers.chain, units="US")


# ----------------------------------------------------------------------------- checks
def all_finite(r: lsc.Result) -> None:
    """No NaN or inf in any series or in the metrics a completed crash defines."""
    for name in ("t", "x", "v", "a", "deformation", "force"):
        arr = getattr(r, name)
        assert np.all(np.isfinite(arr)), f"{r.method}: non-finite values in {name}"
    for name in ("delta_v", "v_final", "peak_acceleration", "peak_acceleration_g",
                 "max_deformation", "permanent_deformation", "peak_force", "energy_absorbed",
                 "energy_returned"):
        arr = np.asarray(getattr(r, name), float)
        assert np.all(np.isfinite(arr)), f"{r.method}: non-finite {name} = {arr}"
    # the restitutions where they are defined: the velocity one over a contact's first impact
    # where it was struck (NaN where it never touched or was pushed shut: docs/metrics.rst),
    # the energy one of a contact that absorbed any
    first = {}
    for imp in r.impacts:
        first.setdefault(imp.contact, imp)
    struck = np.array([k in first and first[k].struck for k in range(len(r.scene.contacts))], bool)
    assert np.all(np.isfinite(r.restitution[struck])), f"{r.method}: restitution {r.restitution}"
    assert np.all(np.isnan(r.restitution[~struck])), f"{r.method}: restitution {r.restitution}"
    loaded = np.asarray(r.energy_absorbed) > 0
    assert np.all(np.isfinite(r.restitution_energy[loaded])), \
        f"{r.method}: restitution_energy {r.restitution_energy}"
    assert np.isfinite(r.duration) and r.duration >= 0, f"{r.method}: duration {r.duration}"
    assert np.all(np.diff(r.t) >= 0), f"{r.method}: time runs backwards"
    assert r.method and isinstance(r.tolerances, dict) and isinstance(r.stats, dict)


def speed_scale(scene) -> float:
    """The largest speed or speed difference of a scene [velocity] (the backends' own scale)."""
    v = np.asarray(scene.speeds, float)
    return float(max(np.max(np.abs(v)), np.max(np.abs(np.diff(v)))))


def closing_scale(scene) -> float:
    """The largest closing speed of a scene [velocity] (the scale of every ΔV)."""
    return float(np.max(np.abs(np.diff(np.asarray(scene.speeds, float)))))


def momentum_error(r: lsc.Result) -> float:
    """Change of the total momentum, relative to ``sum m_i |v_i|``."""
    m, v0 = r.scene.masses, r.scene.speeds
    return float(abs(m @ r.v_final - m @ v0) / (m @ np.abs(v0)))


def relative_ke(m, v) -> float:
    """Kinetic energy in the centre-of-mass frame [energy]."""
    m, v = np.asarray(m, float), np.asarray(v, float)
    vcm = (m @ v) / m.sum()
    return float(0.5 * m @ (v - vcm) ** 2)


def energy_error(r: lsc.Result) -> float:
    """``(KE lost - sum(absorbed - returned))`` relative to the initial relative kinetic energy
    (the centre-of-mass frame keeps a fast common motion from cancelling it away)."""
    m = r.scene.masses
    ke0 = relative_ke(m, r.scene.speeds)
    lost = ke0 - relative_ke(m, r.v_final)
    bumpers = float(np.sum(r.energy_absorbed - r.energy_returned))
    return abs(lost - bumpers) / ke0


def rounding_floor(scene) -> float:
    """The relative accuracy float64 allows a ΔV at all: velocities near the speed scale are
    held to an ulp of it, a ΔV is a fraction of the closing speed."""
    return 64 * EPS * speed_scale(scene) / closing_scale(scene)


def straight_restitution(scene) -> float | None:
    """The restitution of a two-vehicle scene's straight unloading line (a restitution, or the
    ``sqrt(k/k_u)`` of a stiffness over a linear loading branch); None for anything else."""
    from lsc.scene import Hysteresis, Restitution, UnloadingStiffness

    c = scene.contacts[0]
    if not isinstance(c.law, Hysteresis):
        return None
    u = c.law.unloading
    if isinstance(u, Restitution):
        return float(u.e)
    if isinstance(u, UnloadingStiffness) and c.law.loading.is_linear:
        return float(np.sqrt(c.law.loading.stiffness / u.stiffness))
    return None


def rebound_floor(scene) -> float:
    """The float64 floor of a backend that integrates the motion (SciPy, diffrax) on a
    near-plastic rebound, relative to the closing speed. The rebound is ``w = e² D_max`` wide and
    such a backend holds a deformation to ``ε D_max`` at best (both integrate each segment in
    its own frame for that; absolute positions would hold it only to their own ulps, and diffrax,
    which did, was off by 2200 ε / e after a foot of travel): the rebound speed ``e v0`` is off by about ``ε / e`` of ``v0``, or, below
    ``w = 4 ε D_max`` where the law drops the rebound (:data:`lsc.contact.REBOUND_RESOLUTION`),
    by ``e``. ``64 ε / e`` bounds the measured errors with a margin of 10."""
    e = straight_restitution(scene)
    if not e:
        return 0.0
    return min(e, 64 * EPS / e)


def position_floor(r: lsc.Result) -> float:
    """The relative accuracy a deformation has at all when the vehicles have travelled far
    before or while it forms: positions are held to their ulps, so a deformation ``D_max`` formed
    after ``x`` of travel (a contact that closes after 3.5 ft at 1e-3 ft/s, 2e-7 ft deep) is
    known to ``ε x / D_max`` (4e-9 there), and so are the energies and speeds that follow from
    it."""
    x = float(np.max(np.abs(r.x))) if r.x.size else 0.0
    d = np.asarray(r.max_deformation, float)
    d = d[d > 0]
    if not d.size or not x > 0:
        return 0.0
    return 64 * EPS * x / float(np.min(d))


def tolerance(r: lsc.Result) -> float:
    """The relative accuracy (of a ΔV, relative to the closing speed) that ``r``'s backend
    promises: rounding for the exact backends, ``GLOBAL_FACTOR x rtol`` (on the backend's speed
    scale, the largest speed) for the integrators, not below their :func:`rebound_floor`. ``reference`` has no tolerance (first order in
    dt) and is only checked for convergence."""
    floor = max(rounding_floor(r.scene), position_floor(r))
    if r.method in ("closed-form", "exact", "exact-chain"):
        return max(1e-12, floor)
    integ = r.method.split("-", 1)[1]
    rtol = r.tolerances["rtol"]
    return max(GLOBAL_FACTOR[integ] * rtol * speed_scale(r.scene) / closing_scale(r.scene), floor,
               rebound_floor(r.scene))


def check_result(r: lsc.Result, *, external: bool = False) -> None:
    """The checks every hard-case result passes on its own: finite, momentum, energy balance."""
    all_finite(r)
    if not external:
        err = momentum_error(r)
        assert err <= MOMENTUM_RTOL, f"{r.method}: momentum changed by {err:.3g} (relative)"
    err = energy_error(r)
    tol = 4 * tolerance(r)   # KE ~ w²: twice the relative error of w, and both ends of it
    assert err <= tol, f"{r.method}: energy balance off by {err:.3g} (tolerance {tol:.3g})"


def check_agrees(r: lsc.Result, ref: lsc.Result, *, tol: float | None = None,
                 contacts: bool = True, dmax_tol: float | None = None) -> None:
    """``r`` agrees with the exact ``ref`` to ``r``'s tolerance: ΔV of every vehicle (relative
    to the closing speed), the energies (relative to the relative kinetic energy) and the max
    deformation (relative to ref's; to ``dmax_tol`` where it is worse conditioned than the
    velocities: on a separatrix, where an energy off by ``ε`` moves it by ``√ε``)."""
    tol = tolerance(r) if tol is None else tol
    w = closing_scale(ref.scene)
    dv = float(np.max(np.abs(r.delta_v - ref.delta_v))) / w
    assert dv <= tol, f"{r.method}: ΔV off by {dv:.3g} of the closing speed (tolerance {tol:.3g})" \
                      f"\n  got {r.delta_v}\n  ref {ref.delta_v} ({ref.method})"
    if not contacts:
        return
    ke0 = relative_ke(ref.scene.masses, ref.scene.speeds)
    de = float(np.max(np.abs(r.energy_absorbed - ref.energy_absorbed))) / ke0
    assert de <= 4 * tol, f"{r.method}: absorbed energy off by {de:.3g} (tolerance {4 * tol:.3g})"
    dd = np.abs(r.max_deformation - ref.max_deformation) / np.maximum(ref.max_deformation, 1e-300)
    assert np.all(dd <= (max(4 * tol, 1e-9) if dmax_tol is None else dmax_tol)), \
        f"{r.method}: max deformation {r.max_deformation} vs {ref.max_deformation} ({ref.method})"


def event_kinds(r: lsc.Result) -> list[str]:
    """The kinds of ``r``'s events, a combined kind (``max_deformation+separation``: a rebound
    below the backend's resolution) split into its parts."""
    return [part for e in r.events for part in e.kind.split("+")]


def solve_all(scene, runs):
    """``{name: Result}`` for each ``(name, kwargs)`` of ``runs`` (lsc.solve keyword arguments)."""
    return {name: lsc.solve(scene, **kw) for name, kw in runs}


def scipy_runs(integrators=SCIPY_INTEGRATORS, **kw):
    """``(name, kwargs)`` pairs running the SciPy backend with each of ``integrators``."""
    return [(f"scipy-{i}", dict(method="scipy", integrator=i, **kw)) for i in integrators]
