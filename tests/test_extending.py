"""Extending lsc: a new damping law is one class plus its scene keys, a new vehicle effect is one
effect class plus its scene keys (issue 12). Each toy below is defined in this file alone,
registered, loaded from a scene dict and solved, and checked against an independent solution of
its own equations of motion (scipy.integrate.solve_ivp of the two-mass ODE written here)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import lsc
import lsc.solvers
from lsc.effects import VehicleEffect, register_vehicle_effect, unregister_vehicle_effect
from lsc.laws import Param, SpringDashpotLaw, register_law, unregister_law
from lsc.solvers import methods

M1, M2, V0 = 1.0, 1.5, 3.0          # kg, kg, m/s (SI scenes)
K, C = 400.0, 2.0                   # N/m, kg/m


# ----------------------------------------------------------------- (a) a toy damping law
class QuadraticDampingLaw(SpringDashpotLaw):
    """A linear spring with quadratic damping, ``F = max(0, k D + c Ḋ |Ḋ|)``."""

    name = "toy"
    params_declared = (
        Param("stiffness", "stiffness", "k in F = k D + c dD/dt |dD/dt|", minimum=0.0),
        Param("damping", "quadratic_damping", "c in F = k D + c dD/dt |dD/dt|", minimum=0.0,
              strict=False, unit=("kg/m", "slug/ft", ("2 slug/ft", "30 kg/m"))),
    )

    @staticmethod
    def build(values, mu, xp):
        return {"k": xp.asarray(values["stiffness"], float),
                "cq": xp.asarray(values["damping"], float)}

    def at_contact(self, st, Ddot, p, xp, mu):
        return {"c": xp.asarray(p["cq"], float)}

    def spring_force(self, D, Ddot, st):
        return st["k"] * D + st["c"] * Ddot * abs(Ddot)

    def event_linear(self, laws):
        return (False, True, True, True)   # the separation, k D = c Ḋ², is not linear


@pytest.fixture
def toy_law():
    register_law(QuadraticDampingLaw)
    yield QuadraticDampingLaw
    unregister_law("toy")


def toy_scene(**contact):
    return {"vehicles": [{"mass": M1, "speed": V0}, {"mass": M2, "speed": 0.0}],
            "contacts": [{"law": "toy", "stiffness": K, "damping": C, **contact}]}


def quadratic_damping_reference():
    """ΔV (2,) and max deformation of the toy law's crash, from the relative motion
    ``μ D'' = -F`` integrated to the separation (the force back to 0)."""
    mu = M1 * M2 / (M1 + M2)

    def force(y):
        return K * y[0] + C * y[1] * abs(y[1])

    def rhs(t, y):
        return [y[1], -force(y) / mu]

    def separation(t, y):
        return force(y) if y[1] < 0 else 1.0
    separation.terminal, separation.direction = True, -1

    def turn(t, y):
        return y[1]
    turn.direction = -1
    sol = solve_ivp(rhs, (0.0, 10.0), [0.0, V0], method="DOP853", rtol=1e-13, atol=1e-16,
                    events=(separation, turn))
    impulse = mu * (V0 - sol.y_events[0][0][1])
    return np.array([-impulse / M1, impulse / M2]), sol.y_events[1][0][0]


def test_a_toy_damping_law_is_one_class_and_matches_its_own_equation(toy_law):
    r = lsc.solve(toy_scene(), method="scipy", rtol=1e-12)
    dv, dmax = quadratic_damping_reference()
    np.testing.assert_allclose(r.delta_v, dv, rtol=1e-8, atol=1e-8 * V0)
    np.testing.assert_allclose(r.max_deformation[0], dmax, rtol=1e-8)
    assert 0 < -r.delta_v[0] < 2 * M2 * V0 / (M1 + M2)       # a damped rebound, not elastic
    np.testing.assert_allclose(M1 * r.delta_v[0] + M2 * r.delta_v[1], 0.0, atol=1e-12)


def test_a_toy_law_reads_its_own_keys_and_units(toy_law):
    scene = lsc.Scene.load({**toy_scene(), "units": "US",
                            "contacts": [{"law": "toy", "stiffness": 1000, "damping": "2 slug/ft"}]})
    assert scene.contacts[0].law.damping == pytest.approx(2.0)
    si = lsc.Scene.load(toy_scene(damping="2 slug/ft"))
    assert si.contacts[0].law.damping == pytest.approx(2 * 14.593902937206364 / 0.3048)
    with pytest.raises(lsc.SceneError) as ei:
        lsc.Scene.load(toy_scene(dampnig=1.0))
    assert ei.value.path == "contacts[0].dampnig"
    assert 'did you mean "damping"' in str(ei.value)
    with pytest.raises(lsc.SceneError) as ei:
        lsc.Scene.load(toy_scene(damping="2 N*s/m"))
    assert ei.value.path == "contacts[0].damping"


def test_backends_that_do_not_declare_a_toy_law_refuse_it_by_name(toy_law):
    for method in ("closed-form", "exact", "reference"):
        with pytest.raises(lsc.SceneError) as ei:
            lsc.solve(toy_scene(), method=method)
        assert ei.value.path == "solver.method"
        assert "'law:toy'" in str(ei.value)
    assert lsc.solve(toy_scene()).method.startswith("scipy")   # auto: the generic integrator


def test_an_unregistered_law_is_an_unknown_law():
    with pytest.raises(lsc.SceneError) as ei:
        lsc.Scene.load(toy_scene())
    assert ei.value.path == "contacts[0].law"
    assert 'unknown contact law "toy"' in str(ei.value)


# ----------------------------------------------------------------- (b) a toy vehicle effect
class Drag(VehicleEffect):
    """A constant force ``force`` [force] pushing the vehicle back (a toy: no events)."""

    table = "drag"
    feature = "effect:drag"
    example = '{ force = "100 N" }'
    summary = "a constant drag force"
    params_declared = (Param("force", "force", "the drag force", minimum=0.0, strict=False),)

    @staticmethod
    def build(values, g, xp):
        return {"force": xp.asarray(values["force"], float)}

    @staticmethod
    def accel(net, m, st, p):
        return (net - p["force"]) / m


@pytest.fixture
def drag():
    register_vehicle_effect(Drag)
    yield Drag
    Drag.integrable = False
    unregister_vehicle_effect("drag")


FD, E = 30.0, 0.4   # N, restitution


def drag_scene():
    return {"vehicles": [{"mass": M1, "speed": V0, "drag": {"force": f"{FD} N"}},
                         {"mass": M2, "speed": 0.0}],
            "contacts": [{"loading": {"stiffness": K}, "unloading": {"restitution": E}}]}


def drag_reference():
    """(t, v (2,)) at the separation and the max deformation of the IF-D crash with a constant
    drag ``FD`` on the rear vehicle: loading ``F = k D`` to the common velocity, then the
    unloading line of slope ``k / e²`` to zero force."""
    def run(force, y0, stop, t0):
        def rhs(t, y):
            F = force(y[0] - y[2])
            return [y[1], (-F - FD) / M1, y[3], F / M2]
        stop.terminal, stop.direction = True, -1
        return solve_ivp(rhs, (t0, t0 + 10.0), y0, method="DOP853", rtol=1e-13, atol=1e-16,
                         events=stop)
    load = run(lambda D: K * D, [0.0, V0, 0.0, 0.0], lambda t, y: y[1] - y[3], 0.0)
    t1, y1 = load.t_events[0][0], load.y_events[0][0]
    dmax = y1[0] - y1[2]
    fmax = K * dmax
    unload = run(lambda D: fmax + K / E**2 * (D - dmax), y1,
                 lambda t, y: fmax + K / E**2 * (y[0] - y[2] - dmax), t1)
    return unload.t_events[0][0], unload.y_events[0][0][[1, 3]], dmax


def test_a_toy_effect_is_refused_by_every_backend_that_does_not_declare_it(drag):
    for method in methods():
        with pytest.raises(lsc.SceneError) as ei:
            lsc.solve(drag_scene(), method=method)
        assert ei.value.path == "solver.method", method
        assert "'effect:drag'" in str(ei.value), method


def test_a_toy_effect_declared_integrable_is_solved_by_scipy(drag):
    Drag.integrable = True
    r = lsc.solve(drag_scene(), method="scipy", rtol=1e-12)
    assert r.method.startswith("scipy")
    t_sep, v_sep, dmax = drag_reference()
    np.testing.assert_allclose(r.max_deformation[0], dmax, rtol=1e-8)
    (imp,) = r.impacts
    np.testing.assert_allclose(imp.t_end, t_sep, rtol=1e-8)
    np.testing.assert_allclose(imp.v_end, v_sep, rtol=1e-8, atol=1e-8 * V0)
    # the drag took momentum: M1 ΔV1 + M2 ΔV2 = -FD t over the impact
    np.testing.assert_allclose(M1 * (imp.v_end[0] - V0) + M2 * imp.v_end[1], -FD * t_sep,
                               rtol=1e-8)
    for method in ("closed-form", "exact", "reference"):   # still refused where not declared
        with pytest.raises(lsc.SceneError):
            lsc.solve(drag_scene(), method=method)


def test_the_generic_integrators_declare_registered_integrable_parts_only(toy_law, drag):
    scipy, diffrax = (lsc.solvers.backend(name) for name in ("scipy", "diffrax"))
    exact = lsc.solvers.backend("exact")
    assert "law:toy" in scipy.solves and "law:toy" in diffrax.solves
    assert "law:toy" not in exact.solves
    assert "effect:drag" not in scipy.solves and "effect:drag" not in diffrax.batch
    Drag.integrable = True
    assert "effect:drag" in scipy.solves and "effect:drag" in diffrax.batch
    unregister_law("toy")
    assert "law:toy" not in scipy.solves
