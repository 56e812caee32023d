"""A solve that names no SciPy integrator takes Radau where a two-vehicle damping law's rebound is
stiffer than DOP853 follows at its tolerance (lsc.solvers.stiffness), DOP853 everywhere else.

Hunt–Crossley at e = 1e-12 under plain ``lsc.solve`` ran DOP853 for ~40 s and ended at its event
limit (the turn and the recompression alternating); it now finishes with the plastic ΔV, (1 + e)
times it, and the energy relations of tests/hard/damping_quadrature.py."""

import sys

import numpy as np
import pytest

import lsc
from hard import damping_quadrature as dq
from lsc.api import model_of
from lsc.solvers import stiffness
from test_fd_step_floor import M1, M2, PLASTIC_DV, V1, _scene

K, N = 1e6, 1.5          # _scene's Hunt–Crossley stiffness and exponent
MU = M1 * M2 / (M1 + M2)


def _law(law, e):
    keys = {"stiffness": K, "restitution": e}
    return {"vehicles": [{"mass": M1, "speed": V1}, {"mass": M2, "speed": 0.0}],
            "contacts": [{"law": law, **keys}]}


@pytest.mark.parametrize("e", [1e-12, 1e-15])
def test_a_tiny_restitution_under_auto_is_solved_by_radau_with_the_energy_relations(e):
    r = lsc.solve(_scene(e))
    assert r.method == "scipy-Radau"
    np.testing.assert_allclose(r.delta_v, (1 + e) * PLASTIC_DV, rtol=1e-13, atol=0)
    assert r.restitution[0] == pytest.approx(e, rel=0.1)   # (1e-15 m/s: 7e-17 of rounding)
    # the max crush from k D^{n+1}/(n+1) = G_α(v0), the absorbed energy ½ μ v0², the peak force
    alpha = lsc.contact.hunt_crossley_a(e) / V1
    g1 = dq.energy(MU, alpha, V1)
    d_max = ((N + 1) * g1 / K) ** (1 / (N + 1))
    assert r.max_deformation[0] == pytest.approx(d_max, rel=1e-9)
    assert r.energy_absorbed[0] == pytest.approx(0.5 * MU * V1 ** 2, rel=1e-9)
    assert r.peak_force[0] == pytest.approx(dq._peak_force(MU, V1, K, N, alpha, g1, d_max),
                                            rel=1e-9)


@pytest.mark.parametrize("law", ["kelvin", "brach", "hunt-crossley"])
def test_every_damping_law_at_a_tiny_restitution_is_solved_by_scipy_naming_no_integrator(law):
    r = lsc.solve(_law(law, 1e-12), method="scipy")
    assert r.method == "scipy-Radau"
    np.testing.assert_allclose(r.delta_v, (1 + 1e-12) * PLASTIC_DV, rtol=1e-13, atol=0)


@pytest.mark.parametrize("e", [1e-7, 1e-3, 0.5, 1e-200])
def test_the_normal_cases_keep_dop853_and_their_numbers(e):
    """(1e-200: below the floor, the hold speed under anything resolved; DOP853 solves it and
    Radau's finite-difference Jacobian overflows.)"""
    r = lsc.solve(_scene(e))
    ref = lsc.solve(_scene(e), method="scipy", integrator="DOP853")
    assert r.method == "scipy-DOP853"
    for name in ("delta_v", "max_deformation", "peak_force", "restitution", "energy_absorbed"):
        np.testing.assert_array_equal(getattr(r, name), getattr(ref, name), err_msg=name)


def test_ifd_and_chains_keep_dop853():
    ifd = {"vehicles": [{"mass": M1, "speed": V1}, {"mass": M2, "speed": 0.0}],
           "contacts": [{"loading": {"stiffness": 1e6}, "unloading": {"restitution": 1e-12}}]}
    assert lsc.solve(ifd, method="scipy").method == "scipy-DOP853"
    chain = {"vehicles": [{"mass": M1, "speed": V1}, {"mass": M2, "speed": 0.0},
                          {"mass": 1200.0, "speed": 0.0}],
             "contacts": [_scene(1e-12)["contacts"][0]] * 2}
    assert stiffness.integrator_for(model_of(lsc.Scene.load(chain)), 1e-10) == "DOP853"


def test_the_criterion_follows_the_tolerance():
    """The hold speed against the velocity tolerance: e = 1e-12 is stiff at rtol 1e-10 and not
    at 1e-15 (100 rtol = 1e-13), nor under a fine atol (1e-18 m/s)."""
    model = model_of(lsc.Scene.load(_scene(1e-12)))
    assert stiffness.integrator_for(model, 1e-10) == "Radau"
    assert stiffness.integrator_for(model, 1e-15) == "DOP853"
    assert stiffness.integrator_for(model, 1e-10, atol=1e-18) == "DOP853"
    (k, hold), = stiffness.stiff_contacts(model, 1e-10)
    assert k == 0 and hold == pytest.approx(1e-12 * V1, rel=1e-9)   # 1/α = v0/a ≈ e v0


def test_an_explicit_integrator_is_respected_with_its_message():
    with pytest.raises(lsc.SimulationError, match="solve with integrator='Radau'"):
        lsc.solve(_scene(1e-12), integrator="DOP853", max_events=40)


def test_a_sweep_picks_the_integrator_member_by_member():
    """SciPy has no batch path: each member is solved as lsc.solve solves it, with its own
    integrator (Radau at 1e-12 and 1e-15, DOP853 at 0.5)."""
    s = lsc.sweep(_scene(0.5), {"contacts.0.restitution": [1e-12, 1e-15, 0.5]}, progress=False)
    assert list(s.status) == ["ok"] * 3
    np.testing.assert_allclose(s.metrics["delta_v"],
                               [(1 + e) * PLASTIC_DV for e in (1e-12, 1e-15, 0.5)], rtol=1e-9)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__]))


def test_a_finite_difference_stencil_is_solved_by_one_integrator(monkeypatch):
    """A sensitivity's stencil around e = 1e-11 (rtol 1e-12: stiff below e ≈ 1e-10) reaches
    e ≈ 1e-6 (its step's floor): each solve picking its own integrator mixed Radau at the centre
    with DOP853 around it, their differences of a tolerance's size taken for a slope. The base
    scene's integrator solves them all."""
    from lsc import api
    from lsc.analysis import sensitivity

    methods = []
    solve = api.solve

    def recorded(*args, **kwargs):
        r = solve(*args, **kwargs)
        methods.append(r.method)
        return r

    monkeypatch.setattr(api, "solve", recorded)
    s = sensitivity(_scene(1e-11), ["contacts.0.restitution"], method="finite-difference",
                    metrics=["delta_v"])
    assert len(methods) > 2 and set(methods) == {"scipy-Radau"}
    np.testing.assert_allclose(s.derivatives["delta_v"][:, 0], PLASTIC_DV, rtol=1e-6)


def test_a_chain_at_its_event_limit_names_no_integrator_that_misreads_it():
    """A Hunt–Crossley chain at e = 1e-12, its pairs touching at rest, stays on DOP853 (two
    vehicles only take Radau) and chatters to its event limit. The message named Radau, which
    finishes it with the front car's ΔV 0 where it leaves at 1.35 m/s (rounding parts and
    touches the pair at rest at one instant again and again in its first 2e-11 s; the first of
    those episodes, with nothing exchanged, is taken for its first impact): it now says so."""
    chain = {"vehicles": [{"mass": 1000, "speed": 5}, {"mass": 1500, "speed": 0},
                          {"mass": 1200, "speed": 0}],
             "contacts": [_scene(1e-12)["contacts"][0]] * 2}
    with pytest.raises(lsc.SimulationError) as err:
        lsc.solve(chain, max_events=40)
    assert str(err.value).endswith(
        "(its damping law's restoring factor is stiffer at this restitution than an explicit "
        "integrator steps: in a chain no integrator of lsc is known to follow it: Radau and BDF "
        "finish but rounding may part a pair touching at rest and its first impact is then "
        "misread, a car's delta_v 0; a larger restitution is followed)")
    radau = lsc.solve(chain, method="scipy", integrator="Radau")
    assert radau.delta_v[2] == 0.0 and radau.v_final[2] == pytest.approx(5000 / 3700)
