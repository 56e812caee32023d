"""lsc.analysis.mer: Momentum–Energy–Restitution ΔVs against the simulation."""

import numpy as np
import pytest

import lsc
from helpers import paper_scene, two_cars
from lsc.analysis import format_mer, mer, mer_for

CASES = [  # m1, m2, v1, v2, k, e   (SI)
    (1500.0, 1500.0, 4.0, 0.0, 3.5e5, 0.4),
    (2000.0, 1100.0, 3.0, 1.0, 8.0e5, 0.0),
    (900.0, 2500.0, 6.0, -1.0, 2.0e5, 1.0),
    (1300.0, 1700.0, 2.5, 0.5, 5.0e5, 0.73),
]


@pytest.mark.parametrize("method", ["closed-form", "exact", "scipy"])
@pytest.mark.parametrize("m1, m2, v1, v2, k, e", CASES)
def test_mer_equals_simulation_linear(method, m1, m2, v1, v2, k, e):
    sc = two_cars(m1, m2, v1, v2, {"stiffness": k}, {"restitution": e})
    r = lsc.solve(sc, method=method, **({"rtol": 1e-12} if method == "scipy" else {}))
    tol = 1e-9 if method != "scipy" else 1e-8
    m = mer(m1, m2, v1, v2, restitution=e)
    assert [m.delta_v1, m.delta_v2] == pytest.approx(r.delta_v, abs=tol * abs(v1 - v2))
    assert [m.v1_final, m.v2_final] == pytest.approx(r.v_final, abs=tol * abs(v1 - v2))
    # with the restitution the simulation achieved (from its energies)
    mr = mer_for(r)
    assert mr.delta_v == pytest.approx(r.delta_v, abs=tol * abs(v1 - v2))
    # the energy lost is what the simulation absorbed and did not return
    lost = r.energy_absorbed[0] - r.energy_returned[0]
    assert m.energy_lost == pytest.approx(lost, rel=tol, abs=tol * m.energy_available)


def test_mer_equals_simulation_nonlinear_table():
    """Momentum holds whatever the curve: MER with the achieved e equals the exact backend."""
    sc = two_cars(1600.0, 1200.0, 3.0, 0.0,
                  {"table": [[0, 0], [0.01, 2e3], [0.03, 3e4], [0.05, 3.2e4], [0.2, 4e5]]},
                  {"restitution": 0.35})
    r = lsc.solve(sc)
    assert r.method == "exact"
    assert mer_for(r).delta_v == pytest.approx(r.delta_v, abs=1e-9 * 3.0)
    assert mer_for(sc).delta_v == pytest.approx(r.delta_v, abs=1e-9 * 3.0)  # the scene's own e
    # unloading given as a stiffness: the scene is solved for its restitution
    sc2 = two_cars(1600.0, 1200.0, 3.0, 0.0, {"stiffness": 4e5}, {"stiffness": 9e5})
    r2 = lsc.solve(sc2)
    assert mer_for(sc2).restitution == pytest.approx(np.sqrt(4 / 9), rel=1e-12)
    assert mer_for(sc2).delta_v == pytest.approx(r2.delta_v, abs=1e-9 * 3.0)


def test_energy_forms():
    m1, m2, v1, v2, e = 1500.0, 1200.0, 5.0, 1.0, 0.3
    ref = mer(m1, m2, v1, v2, restitution=e)
    mu = m1 * m2 / (m1 + m2)
    assert ref.energy_available == pytest.approx(0.5 * mu * 16.0)
    # energy lost and e → closing speed and ΔVs (the MER estimate of an unknown crash)
    m = mer(m1, m2, energy=ref.energy_lost, restitution=e)
    assert m.closing_speed == pytest.approx(4.0, rel=1e-14)
    assert m.delta_v == pytest.approx(ref.delta_v, rel=1e-14)
    assert np.isnan(m.v1_final)
    # speeds and energy lost → e
    m = mer(m1, m2, v1, v2, energy=ref.energy_lost)
    assert m.restitution == pytest.approx(e, rel=1e-13)
    assert m.delta_v == pytest.approx(ref.delta_v, rel=1e-13)
    # losing more than was available has no restitution
    assert np.isnan(mer(m1, m2, v1, v2, energy=2 * ref.energy_available).restitution)


def test_vectorised():
    v = np.linspace(1, 10, 7)
    e = np.array([[0.0], [0.5], [1.0]])
    m = mer(1000.0, 1500.0, v, 0.0, restitution=e)
    assert m.delta_v2.shape == (3, 7)
    assert m.delta_v2 == pytest.approx((1 + e) * 1000 * v / 2500)
    assert m.delta_v.shape == (3, 7, 2)
    # momentum is conserved member by member
    assert 1000 * m.delta_v1 + 1500 * m.delta_v2 == pytest.approx(np.zeros((3, 7)), abs=1e-9)


def test_paper_study1_and_format():
    r = lsc.solve(paper_scene())
    m = mer_for(r)
    assert m.delta_v == pytest.approx([-7.0, 7.0], abs=1e-9)
    text = format_mer(r)
    assert "MER" in text and "bullet" in text and "+7" in text
    chain = {"vehicles": [{"mass": 1000, "speed": 3}, {"mass": 1000, "speed": 0}, {"mass": 1000, "speed": 0}],
             "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 0.5}}] * 2}
    assert format_mer(lsc.solve(chain)) is None
    with pytest.raises(lsc.SceneError, match="two vehicles"):
        mer_for(chain)


def test_mer_uses_the_speeds_at_first_contact():
    # the target brakes from 10 ft/s to rest before the bullet (5 ft/s) closes a 1 ft gap:
    # MER starts from the speeds at the touch (closing 5 ft/s), not those at t = 0 (-5 ft/s)
    sc = {"units": "US", "g": "32.2 ft/s^2",
          "vehicles": [{"weight": 3500, "speed": 5.0},
                       {"weight": 3000, "speed": 10.0, "brake": {"mu": 0.7, "mu_static": 0.8}}],
          "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4},
                        "gap": 1.0}]}
    r = lsc.solve(sc, method="exact")
    m = mer_for(r)
    assert m.closing_speed == pytest.approx(5.0, rel=1e-12)
    m1, m2 = 3500.0 / 32.2, 3000.0 / 32.2
    assert m.delta_v1 == pytest.approx(-1.4 * m2 * 5.0 / (m1 + m2), rel=1e-12)
    assert m.delta_v2 == pytest.approx(1.4 * m1 * 5.0 / (m1 + m2), rel=1e-12)
    text = format_mer(r)
    assert "speeds at first contact" in text and "closing speed 5 ft/s" in text
    # set beside the simulated ΔV of that impact, not v_final - v0 (-10 ft/s for the target)
    assert f"{r.delta_v[1]:+.6g} ft/s (simulation)" in text and r.delta_v[1] > 0
    # a scene is solved first when something acts before the touch
    assert mer_for(sc).closing_speed == pytest.approx(5.0, rel=1e-12)


def test_bad_arguments():
    with pytest.raises(lsc.SceneError, match="exactly two"):
        mer(1.0, 1.0, 3.0, 0.0)
    with pytest.raises(lsc.SceneError, match="exactly two"):
        mer(1.0, 1.0, 3.0, 0.0, restitution=0.5, energy=1.0)
    with pytest.raises(lsc.SceneError, match="between 0 and 1"):
        mer(1.0, 1.0, 3.0, 0.0, restitution=1.5)
    with pytest.raises(lsc.SceneError, match="positive"):
        mer(-1.0, 1.0, 3.0, 0.0, restitution=0.5)
