"""lsc.chunks.validate: each member's status is the loader's own, and a member is loaded in full
only where a screen cannot clear it."""

import numpy as np
import pytest

import lsc
from lsc import chunks
from lsc.scene import Scene

_CHAIN = {"units": "US",
          "vehicles": [{"mass": 100.0, "speed": 10.0}, {"mass": 100.0, "speed": 0.0},
                       {"mass": 100.0, "speed": 0.0}],
          "contacts": [{"loading": {"stiffness": 1e4}, "unloading": {"restitution": 0.5},
                        "gap": 0.1} for _ in range(2)]}


def _loader_status(scene, values, j):
    try:
        scene.with_values({p: float(v[j]) for p, v in values.items()})
        return "ok"
    except lsc.SceneError as e:
        return f"SceneError: {e}"


def _counted(monkeypatch):
    calls = [0]
    original = Scene.with_values

    def counting(self, values):
        calls[0] += 1
        return original(self, values)

    monkeypatch.setattr(Scene, "with_values", counting)
    return calls


def test_a_rear_car_slower_than_the_base_speeds_is_not_loaded_in_full(monkeypatch):
    # every member closes (its front cars slower still), but its rear car's speed, probed
    # beside the base scene's cars at rest, was refused by the closing rule: every member with
    # a negative rear speed was loaded in full (7 % of the benchmark's random chains)
    scene = lsc.load_scene(_CHAIN)
    rng = np.random.default_rng(3)
    n = 400
    v2 = rng.uniform(-10.0, -5.0, n)
    values = {"vehicles.0.speed": v2 + rng.uniform(0.5, 3.0, n),
              "vehicles.1.speed": v2 + rng.uniform(0.0, 0.4, n), "vehicles.2.speed": v2}
    calls = _counted(monkeypatch)
    status = chunks.validate(scene, values, n)
    assert np.all(status == "ok")
    assert calls[0] < 100, calls[0]     # (a bisection per path: O(log n) loads, not n)


def test_statuses_are_the_loaders_own_with_speeds_swept():
    scene = lsc.load_scene(_CHAIN)
    rng = np.random.default_rng(4)
    n = 60
    values = {f"vehicles.{i}.speed": rng.uniform(-5.0, 5.0, n) for i in range(3)}
    values["vehicles.1.speed"][:4] = [np.inf, 1e101, -1e101, np.nan]   # (the field's own bounds)
    values["vehicles.2.speed"][4:6] = values["vehicles.1.speed"][4:6] = values[
        "vehicles.0.speed"][4:6]                                        # (not closing)
    status = chunks.validate(scene, values, n)
    want = [_loader_status(scene, values, j) for j in range(n)]
    assert list(status) == want
    assert sum(s != "ok" for s in want) >= 6 and sum(s == "ok" for s in want) >= 10


def test_a_gap_too_wide_for_the_members_energy_has_the_loaders_message():
    # the rule of the gaps against the crush the relative kinetic energy can reach is one of
    # the speeds, masses, stiffnesses and gaps together: a rear car barely closing (the speed
    # probed beside cars closing on it is accepted) or barely heavy must still be refused
    scene = lsc.load_scene(_CHAIN)
    cases = [{"vehicles.0.speed": np.array([5.0, 1e-6, 1e-8, 1e-12, -3.0])},
             {"vehicles.0.speed": np.array([5.0, 1e-6, 2.0, 1e-6, 1e-3]),
              "vehicles.0.mass": np.array([100.0, 1e-30, 1e-40, 1e-3, 1e-9]),
              "contacts.1.gap": np.array([0.0, 0.5, 0.9, 1e-3, 0.7]),
              "contacts.0.loading.stiffness": np.array([1e4, 1e6, 1e9, 1e3, 1e5])}]
    for values in cases:
        status = chunks.validate(scene, values, 5)
        want = [_loader_status(scene, values, j) for j in range(5)]
        assert list(status) == want
        assert any("too wide" in s for s in want) and want[0] == "ok"


@pytest.mark.parametrize("contact", [
    {"loading": {"table": [[0, 0], [0.02, 3000], [0.1, 25000], [0.4, 120000]]},
     "unloading": {"restitution": 0.4}},
    {"law": "hunt-crossley", "stiffness": 6e4, "exponent": 1.5, "restitution": 0.4}])
def test_the_gap_rule_is_screened_on_a_curved_line_and_on_damping(contact):
    # (no straight line: the crush the energy reaches is the loading's own, not sqrt(2E/k))
    scene = lsc.load_scene({"units": "US", "vehicles": [{"weight": 3500, "speed": 10},
                                                        {"weight": 3000, "speed": 0}],
                            "contacts": [dict(contact, gap=0.05)]})
    values = {"vehicles.0.speed": np.array([5.0, 1e-6, 2.0, 1e-6, 1e-3, 3.0]),
              "vehicles.0.weight": np.array([3500.0, 1e-30, 1e-40, 1e-3, 1e-9, 2e3]),
              "contacts.0.gap": np.array([0.0, 0.5, 0.9, 1e-3, 0.7, 1e-2])}
    status = chunks.validate(scene, values, 6)
    want = [_loader_status(scene, values, j) for j in range(6)]
    assert list(status) == want
    assert sum("too wide" in s for s in want) >= 2 and want[0] == want[5] == "ok"


def test_the_gap_rule_with_a_swept_path_the_screen_cannot_follow():
    # (g moves the masses of vehicles given by weight: every member with a gap loaded in full)
    scene = lsc.load_scene({"units": "US", "vehicles": [{"weight": 3500, "speed": 10},
                                                        {"weight": 3000, "speed": 0}],
                            "contacts": [{"loading": {"stiffness": 2e4},
                                          "unloading": {"restitution": 0.4}, "gap": 0.05}]})
    values = {"vehicles.0.speed": np.array([5.0, 1e-9, 1e-6, 3.0]),
              "g": np.array([32.2, 32.0, 32.1, 32.2])}
    status = chunks.validate(scene, values, 4)
    want = [_loader_status(scene, values, j) for j in range(4)]
    assert list(status) == want
    assert "too wide" in want[1] and want[0] == want[3] == "ok"
