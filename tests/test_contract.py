"""The backend contract: declarations, the registry, auto's choice, refusals of what a backend
does not declare (lsc.solvers.base, lsc.solvers)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import pytest

import lsc
from lsc import solvers
from lsc.model import HybridModel
from lsc.solvers.base import CONTROLS, OPTIONS, Backend

HAVE_DIFFRAX = importlib.util.find_spec("diffrax") is not None


def two_cars(**contact):
    c = {"loading": {"stiffness": 24000.0}, "unloading": {"restitution": 0.4}}
    c.update(contact)
    return {"units": "US", "vehicles": [{"name": "bullet", "weight": 3000.0, "speed": "10 mph"},
                                        {"name": "target", "weight": 3000.0, "speed": 0.0}],
            "contacts": [c]}


def chain(n=3):
    return {"units": "US",
            "vehicles": [{"name": f"v{i}", "weight": 3000.0, "speed": 15.0 if i == 0 else 0.0}
                         for i in range(n)],
            "contacts": [{"loading": {"stiffness": 24000.0}, "unloading": {"restitution": 0.4}}
                         for _ in range(n - 1)]}


def kelvin_chain():
    """A chain that no exact backend declares (a Kelvin contact)."""
    scene = chain(3)
    scene["contacts"][1] = {"law": "kelvin", "stiffness": 24000.0, "damping": 300.0}
    return scene


def test_every_declaration_is_well_formed():
    for b in solvers.backends():
        assert isinstance(b, Backend)
        assert set(b.options) <= set(OPTIONS)
        assert set(b.batch_options) <= set(OPTIONS) | set(CONTROLS)
        assert b.name in solvers.methods()
        # what a batch path solves, its single solve solves too
        assert b.batch is None or b.batch <= b.solves


def test_reading_the_declarations_imports_no_jax():
    code = ("import sys, lsc.solvers as s; [b.name for b in s.backends()]; "
            "print(any(m in sys.modules for m in ('jax', 'diffrax')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("scene, expected", [
    (two_cars(), "closed-form"),
    (two_cars(loading={"table": [[0, 0], [0.5, 20000], [1.0, 24000]]}), "exact"),
    (chain(3), "exact-chain"),
    (kelvin_chain(), "scipy"),
    (two_cars(law="kelvin", loading=None, unloading=None, stiffness=24000.0, restitution=0.4),
     "closed-form"),
    (two_cars(law="hunt-crossley", loading=None, unloading=None, stiffness=24000.0,
              restitution=0.4), "scipy"),
])
def test_auto_picks_the_cheapest_exact_backend_that_declares_the_scene(scene, expected):
    scene["contacts"][0] = {k: v for k, v in scene["contacts"][0].items() if v is not None}
    assert solvers.pick(lsc.Scene.load(scene), "auto") == expected


def test_a_large_batch_with_no_exact_backend_goes_to_the_batched_integrator():
    model = HybridModel(lsc.Scene.load(kelvin_chain()))
    assert solvers.pick(model, "auto", members=10) == "scipy"
    big = solvers.pick(model, "auto", members=solvers.LARGE_BATCH)
    assert big == ("diffrax" if HAVE_DIFFRAX else "scipy")
    # an exact backend stays the choice however large the batch
    assert solvers.pick(HybridModel(lsc.Scene.load(two_cars())), "auto", members=10**6) == \
        "closed-form"


@pytest.fixture
def toy_feature(monkeypatch):
    """Every model uses a feature that no backend declares (as a new effect would)."""
    real = HybridModel.features
    monkeypatch.setattr(HybridModel, "features", lambda self: real(self) | {"effect:toy"})


@pytest.mark.parametrize("method", ["closed-form", "exact", "scipy", "reference", "diffrax"])
def test_a_feature_no_backend_declares_is_refused_not_ignored(toy_feature, method):
    if method == "diffrax" and not HAVE_DIFFRAX:
        pytest.skip("diffrax not installed")
    with pytest.raises(lsc.SceneError) as ei:
        lsc.solve(two_cars(), method=method)
    assert ei.value.path == "solver.method"
    assert f"method {method!r} does not apply to this scene" in ei.value.message
    assert "it does not solve the feature 'effect:toy'" in ei.value.message
    assert "no registered backend solves this scene" in ei.value.message


def test_auto_refuses_a_scene_no_backend_declares(toy_feature):
    with pytest.raises(lsc.SceneError) as ei:
        lsc.solve(two_cars())
    assert "it does not solve the feature 'effect:toy'" in ei.value.message


def test_a_backend_refuses_what_it_does_not_declare_and_names_it():
    braked = two_cars()
    braked["vehicles"][1]["brake"] = {"mu": 0.7}
    with pytest.raises(lsc.SceneError) as ei:
        lsc.solve(braked, method="closed-form")
    assert "it does not solve braking" in ei.value.message
    assert "use method 'scipy' (or 'auto')" in ei.value.message
    with pytest.raises(lsc.SceneError) as ei:
        lsc.solve(chain(3), method="exact")
    assert "it solves exactly 2 vehicles, the scene has 3" in ei.value.message
    # the exact backend has a batch path, but not for braking
    model = HybridModel(lsc.Scene.load(braked))
    assert solvers.backend("exact").missing(model) == []
    assert solvers.backend("exact").missing(model, batch=True) == ["it does not solve braking"]


def test_options_are_checked_by_the_one_definition():
    with pytest.raises(lsc.SceneError) as ei:
        lsc.solve(two_cars(), method="exact", rtol=1e-9)
    assert ei.value.message == ("option 'rtol' does not apply to method 'exact'; it accepts: "
                                "max_events, n_samples, t_end")
    with pytest.raises(lsc.SceneError) as ei:
        lsc.solve(two_cars(), method="scipy", max_steps=0)
    assert ei.value.path == "solver.max_steps"


def test_a_registered_backend_is_solved_through_the_contract():
    calls = []

    class Toy:
        """A backend module: its solve delegates to the closed form, and records the call."""

        @staticmethod
        def solve(model, **options):
            calls.append(options)
            return solvers.backend("closed-form").solve(model, **options)

    sys.modules["_lsc_toy_backend"] = Toy
    toy = Backend(name="toy", module="_lsc_toy_backend", options=("n_samples",),
                  vehicles=(2, 2), solves=frozenset({"law:ifd", "loading:linear",
                                                      "unloading:restitution"}))
    solvers.register(toy)
    try:
        assert "toy" in solvers.methods()
        model = HybridModel(lsc.Scene.load(two_cars()))
        r = solvers.run(model, "toy", {"n_samples": 50})
        assert calls == [{"n_samples": 50}]
        ref = lsc.solve(two_cars(), method="closed-form")
        assert r.delta_v.tolist() == ref.delta_v.tolist()
        # not exact: auto does not pick it; it refuses what it does not declare
        assert solvers.pick(model, "auto") == "closed-form"
        with pytest.raises(lsc.SceneError, match="it does not solve an initial gap"):
            solvers.run(HybridModel(lsc.Scene.load(two_cars(gap=0.1))), "toy", {})
    finally:
        solvers.unregister("toy")
        del sys.modules["_lsc_toy_backend"]
    assert "toy" not in solvers.methods()
