"""Effects a scene names: damping laws, braking, bumper failure, chains — and only those."""

import numpy as np
import pytest

import lsc
from lsc.contact import brach_restitution, hunt_crossley_a, kelvin_restitution
from lsc.model import HybridModel

M1, M2 = 1400.0, 1000.0
MU = M1 * M2 / (M1 + M2)


def damped(law, v0=3.0, m1=M1, m2=M2, **keys):
    return {"units": "SI", "vehicles": [{"mass": m1, "speed": v0}, {"mass": m2, "speed": 0.0}],
            "contacts": [{"law": law, **keys}]}


# ------------------------------------------------------------------ Kelvin
@pytest.mark.parametrize("zeta", [0.05, 0.3, 0.7])
def test_kelvin_against_its_closed_form(zeta):
    k, v0 = 2.0e5, 3.0
    w = np.sqrt(k / MU)
    wd = w * np.sqrt(1 - zeta**2)
    c = 2 * zeta * np.sqrt(k * MU)
    r = lsc.solve(damped("kelvin", v0, stiffness=k, damping=c), method="scipy", rtol=1e-12)
    t_max = [ev.time for ev in r.events if ev.kind == "max_deformation"][0]
    assert t_max == pytest.approx(np.arccos(zeta) / wd, rel=1e-8)
    D_max = v0 / wd * np.exp(-zeta * w * t_max) * np.sin(wd * t_max)
    assert r.max_deformation[0] == pytest.approx(D_max, rel=1e-8)
    assert r.duration == pytest.approx(2 * np.arccos(zeta) / wd, rel=1e-8)
    e = np.exp(-2 * zeta * np.arccos(zeta) / np.sqrt(1 - zeta**2))
    assert r.restitution[0] == pytest.approx(e, rel=1e-8)
    assert r.restitution_energy[0] == pytest.approx(e, rel=1e-8)
    # the force jumps to c v0 at t = 0: the known flaw of the Kelvin model
    assert r.force[0, 0] == pytest.approx(c * v0, rel=1e-12)


def test_kelvin_zeta_03_gives_0451_and_restitution_input_is_exact():
    assert float(kelvin_restitution(0.3)) == pytest.approx(0.451, abs=5e-4)
    r = lsc.solve(damped("kelvin", stiffness=2.0e5, restitution=0.451), method="scipy",
                  rtol=1e-12)
    assert r.restitution[0] == pytest.approx(0.451, abs=1e-9)


# ------------------------------------------------------------------ Hunt–Crossley
@pytest.mark.parametrize("n", [1.0, 1.5, 2.0])
@pytest.mark.parametrize("e", [0.2, 0.5, 0.9])
def test_hunt_crossley_restitution_relation(n, e):
    a = hunt_crossley_a(e)
    assert a * (1 + e) == pytest.approx(np.log((1 + a) / (1 - a * e)), rel=1e-12)
    v0 = 2.5
    # given as a damping alpha = a / v0: the achieved restitution must be e
    r = lsc.solve(damped("hunt-crossley", v0, stiffness=5e6, exponent=n, damping=a / v0),
                  method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(e, abs=1e-8)
    assert r.force[0, 0] == 0.0  # no force jump: F ∝ D^n
    # given as the restitution itself
    r2 = lsc.solve(damped("hunt-crossley", v0, stiffness=5e6, exponent=n, restitution=e),
                   method="scipy", rtol=1e-12)
    assert r2.restitution[0] == pytest.approx(e, abs=1e-8)
    assert r2.restitution_energy[0] == pytest.approx(e, abs=1e-8)


# ------------------------------------------------------------------ Brach
@pytest.mark.parametrize("c1, c2", [(0.0, 4e4), (2e4, 8e4), (5e4, 5e4)])
def test_brach_restitution_against_its_energy_integral(c1, c2):
    k, v0 = 2.0e5, 3.0
    r = lsc.solve(damped("brach", v0, stiffness=k, damping=c1, damping_restitution=c2),
                  method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(brach_restitution(k, c1, c2, v0, MU), abs=1e-8)
    assert r.force[0, 0] == 0.0  # F = D (k + c Ḋ) starts at zero


def test_brach_restitution_target_sets_c2():
    r = lsc.solve(damped("brach", 3.0, stiffness=2.0e5, damping=1e4, restitution=0.6),
                  method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(0.6, abs=1e-8)


def test_damping_law_energy_balance():
    r = lsc.solve(damped("kelvin", 3.0, stiffness=2.0e5, restitution=0.5), method="scipy",
                  rtol=1e-12)
    ke0 = 0.5 * M1 * 9.0
    ke1 = 0.5 * (M1 * r.v_final[0] ** 2 + M2 * r.v_final[1] ** 2)
    lost = r.energy_absorbed[0] - r.energy_returned[0]
    assert ke0 - ke1 == pytest.approx(lost, rel=1e-9)
    assert r.energy_absorbed[0] == pytest.approx(0.5 * MU * 9.0, rel=1e-9)


# ------------------------------------------------------------------ braking
def braked(v1=2.0, mu1=None, mu2=None, mus2=None, k=2.0e5, e=0.5, m1=M1, m2=M2, g=9.81):
    veh = [{"mass": m1, "speed": v1}, {"mass": m2, "speed": 0.0}]
    if mu1:
        veh[0]["brake"] = {"mu": mu1}
    if mu2:
        veh[1]["brake"] = {"mu": mu2, "mu_static": mus2 or mu2}
    return {"units": "SI", "g": g, "vehicles": veh,
            "contacts": [{"loading": {"stiffness": k}, "unloading": {"restitution": e}}]}


@pytest.mark.parametrize("method", ["scipy", "exact"])
def test_braked_target_below_breakaway_never_moves(method):
    # the target stays put, so the bullet meets a wall: F_max = v0 √(k m1) < μs m2 g
    v0, k, m1 = 0.3, 2.0e4, 800.0
    fmax = v0 * np.sqrt(k * m1)
    mus = 1.2
    assert fmax < mus * 3000 * 9.81
    opts = {"rtol": 1e-12} if method == "scipy" else {}
    r = lsc.solve(braked(v0, mu2=0.9, mus2=mus, k=k, m1=m1, m2=3000.0, e=0.5), method=method,
                  **opts)
    assert np.all(r.x[:, 1] == 0.0) and np.all(r.v[:, 1] == 0.0)
    assert r.peak_force[0] == pytest.approx(fmax, rel=1e-9)
    assert r.v_final[0] == pytest.approx(-0.5 * v0, rel=1e-9)  # rebounds off a wall with e


@pytest.mark.parametrize("method, tol", [("scipy", 1e-9), ("exact", 1e-12)])
def test_bullet_braking_throughout_against_hand_closed_form(method, tol):
    v0, k, e, mu1, g = 3.0, 2.0e5, 0.4, 0.7, 9.81
    opts = {"rtol": 1e-12} if method == "scipy" else {}
    r = lsc.solve(braked(v0, mu1=mu1, k=k, e=e, g=g), method=method, **opts)
    assert r.method.startswith(method)
    # relative motion: D'' = -F/μ - μ1 g, loading F = k D, then unloading k/e² to D_perm
    w = np.sqrt(k / MU)
    d = mu1 * g / w**2
    A, B = v0 / w, d
    t_m = np.arctan2(A, B) / w
    D_max = -d + np.hypot(A, B)
    D_perm = D_max * (1 - e**2)
    ku = k / e**2
    wu = np.sqrt(ku / MU)
    du = mu1 * g / wu**2
    amp = D_max - D_perm + du
    tau = np.arccos(du / amp) / wu
    impulse = k * (-d * t_m + A / w * (1 - np.cos(w * t_m)) + B / w * np.sin(w * t_m)) \
        + ku * (-du * tau + amp * np.sin(wu * tau) / wu)
    T = t_m + tau
    assert r.max_deformation[0] == pytest.approx(D_max, rel=tol)
    assert r.duration == pytest.approx(T, rel=tol)
    assert r.v_final[1] == pytest.approx(impulse / M2, rel=tol)
    assert r.v_final[0] == pytest.approx(v0 - impulse / M1 - mu1 * g * T, rel=tol)
    # momentum changes by exactly the friction impulse
    dp = M1 * r.delta_v[0] + M2 * r.delta_v[1]
    assert dp == pytest.approx(-mu1 * M1 * g * T, rel=tol)
    # for a linear loading line a constant friction force leaves the velocity restitution at e
    # (its work in compression and in restitution scales with D_max - D_perm = e² D_max) ...
    assert r.restitution[0] == pytest.approx(e, rel=tol)


def test_braking_with_a_nonlinear_curve_separates_the_two_restitutions():
    # ... but not for a curved loading branch: report both
    scene = braked(3.0, mu1=0.7, e=0.4)
    scene["contacts"][0]["loading"] = {"table": [[0, 0], [0.01, 500], [0.05, 8000], [0.3, 9e4]]}
    r = lsc.solve(scene, method="scipy", rtol=1e-12)
    assert r.restitution_energy[0] == pytest.approx(0.4, rel=1e-12)
    assert abs(r.restitution[0] - 0.4) > 1e-3
    ex = lsc.solve(scene, method="exact")
    assert ex.restitution_energy[0] == pytest.approx(0.4, rel=1e-14)
    assert ex.restitution[0] == pytest.approx(r.restitution[0], rel=1e-9)


@pytest.mark.parametrize("method", ["scipy", "exact"])
def test_braked_vehicles_stop_and_the_series_shows_it(method):
    opts = {"rtol": 1e-10} if method == "scipy" else {}
    r = lsc.solve(braked(3.0, mu1=0.7, mu2=0.7), method=method, t_end=2.0, **opts)
    kinds = [ev.kind for ev in r.events]
    assert kinds.count("stop") == 2
    assert np.all(np.abs(r.v[-1]) < 1e-12)
    assert r.v_final[1] > 0  # the post-crash velocity, not the velocity at rest


# ------------------------------------------------------------------ failure
def test_failure_force_reported_with_its_time():
    scene = {"units": "US", "g": "32.2 ft/s^2",
             "vehicles": [{"weight": 3500, "speed": 5}, {"weight": 3500, "speed": 0}],
             "contacts": [{"loading": {"stiffness": 18462}, "unloading": {"restitution": 0.8},
                           "failure": {"force": "4500 lbf"}}]}
    mu = 3500 / 32.2 / 2
    w = np.sqrt(18462 / mu)
    fmax = 5 * np.sqrt(18462 * mu)
    t_fail = np.arcsin(4500 / fmax) / w
    for method in ("closed-form", "scipy"):
        r = lsc.solve(scene, method=method, rtol=1e-12) if method == "scipy" else \
            lsc.solve(scene, method=method)
        assert r.failed[0]
        assert r.failure_time[0] == pytest.approx(t_fail, rel=1e-9)
    lower = lsc.Scene.load(scene).with_values({"vehicles.0.speed": 4.0})
    assert not lsc.solve(lower).failed[0]


# ------------------------------------------------------------------ chains
def chain(gap2=0.0, e=1.0, v0=2.0, masses=(1200.0, 1200.0, 1200.0), k=1.0e5):
    return {"units": "SI",
            "vehicles": [{"mass": m, "speed": s} for m, s in zip(masses, (v0, 0.0, 0.0))],
            "contacts": [{"loading": {"stiffness": k}, "unloading": {"restitution": e}},
                         {"loading": {"stiffness": k}, "unloading": {"restitution": e},
                          "gap": gap2}]}


def test_three_car_chain_momentum_and_event_order():
    r = lsc.solve(chain(gap2=0.05, e=0.6, masses=(1500.0, 1100.0, 1300.0)), method="scipy",
                  rtol=1e-12)
    m = np.array([1500.0, 1100.0, 1300.0])
    p0 = m @ np.array([2.0, 0.0, 0.0])
    assert abs(m @ r.v_final - p0) <= 1e-12 * p0
    assert np.max(np.abs(r.v @ m - p0)) <= 1e-11 * p0
    first = {k: min(ev.time for ev in r.events if ev.kind == "contact" and ev.index == k)
             for k in (0, 1)}
    assert first[0] < first[1], "contact 1 closes before contact 2"


def test_elastic_chain_passes_the_speed_down_exactly_when_contacts_do_not_overlap():
    T = np.pi * np.sqrt(600.0 / 1.0e5)  # elastic pulse of one equal-mass pair
    gap = 2.0 * T * 1.5  # the middle car covers it at 2 m/s after the first pulse
    r = lsc.solve(chain(gap2=gap), method="scipy", rtol=1e-12)
    assert r.v_final == pytest.approx([0.0, 0.0, 2.0], abs=1e-9)


def test_elastic_chain_with_overlapping_contacts_does_not():
    r = lsc.solve(chain(gap2=0.0), method="scipy", rtol=1e-12)
    m = 1200.0
    assert m * np.sum(r.v_final) == pytest.approx(m * 2.0, rel=1e-12)  # momentum still
    spread = np.max(np.abs(r.v_final - [0.0, 0.0, 2.0]))
    assert spread > 0.05, f"overlapping contacts share the impulse (off by {spread:.3f} m/s)"


def test_chain_contacts_close_again_and_reload():
    # a light middle car between two heavy ones rattles: contacts close more than once
    r = lsc.solve(chain(gap2=0.0, e=0.5, masses=(2000.0, 300.0, 2000.0)), method="scipy",
                  rtol=1e-11)
    kinds = [ev.kind for ev in r.events]
    assert "reload_past_max" in kinds
    m = np.array([2000.0, 300.0, 2000.0])
    assert abs(m @ r.v_final - 4000.0) <= 1e-12 * 4000.0
    ke0 = 0.5 * 2000.0 * 4.0
    ke1 = 0.5 * m @ r.v_final**2
    lost = np.sum(r.energy_absorbed - r.energy_returned)
    assert ke0 - ke1 == pytest.approx(lost, rel=1e-8)


# ------------------------------------------------------------------ only what a scene names
def test_a_scene_without_an_effect_evaluates_no_term_of_it(monkeypatch):
    from lsc import effects

    calls = []
    for name in ("accel", "events"):
        orig = getattr(effects.BrakeEffect, name)
        monkeypatch.setattr(effects.BrakeEffect, name,
                            staticmethod(lambda *a, _o=orig, _n=name: calls.append(_n) or _o(*a)))
    plain = braked(2.0)
    model = HybridModel(lsc.Scene.load(plain))
    assert model.brakes == [] and model.failures == [] and model.work == []
    assert len(model.events) == 3 and model.n_state == 4
    lsc.solve(plain, method="scipy")
    assert calls == []
    lsc.solve(braked(2.0, mu1=0.7), method="scipy")
    assert "accel" in calls and "events" in calls
