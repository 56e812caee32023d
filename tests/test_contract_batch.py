"""The batch contract of the exact backends (issue 12): ``solve_batch(model, values)`` of the
closed form and of the exact piecewise stepper gives, member by member, the metrics of a single
``lsc.solve`` of that member (every name of :data:`lsc.result.METRICS`); a member the stepper
cannot complete carries the single solve's own message; a batch refuses what its declaration
does not name; and ``lsc.sweep`` reaches every batch path through the declarations alone."""

import ast
import importlib
import io
import tokenize
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import lsc
from conftest import two_cars
from lsc import solvers
from lsc.model import HybridModel
from lsc.result import METRICS
from lsc.solvers.base import Backend
from test_batch_equals_single import _assert_members_equal

# A table with a plateau and a dip that ends at 0.4 m (fast members run off its end) and a
# bumper failure force crossed by most members.
TABLE = {"table": [[0, 0], [0.02, 3000], [0.1, 25000], [0.15, 40000], [0.2, 40000],
                   [0.25, 35000], [0.4, 120000]]}


def _scene(loading, unloading, failure=None, gap=0.05):
    sc = two_cars(1500.0, 1000.0, 3.0, 0.0, loading, unloading, gap=gap)
    if failure is not None:
        sc["contacts"][0]["failure"] = {"force": failure}
    return sc


def _random_members(rng, n, paths):
    """``n`` values per dotted path, drawn uniformly from its (low, high) range."""
    return {p: rng.uniform(lo, hi, n) for p, (lo, hi) in paths.items()}


def _batch(method, scene, values, **options):
    """``solve_batch`` of backend ``method`` through its declaration, with a progress callback
    whose counts are returned as well."""
    counts = []
    out = solvers.backend(method).solve_batch(HybridModel(lsc.Scene.load(scene)), values,
                                              progress=counts.append, **options)
    return out, counts


def _assert_members_are_single_solves(out, scene, values, method, **options):
    """Every member of a ``solve_batch`` answer (every metric of METRICS, leading axis n)
    against ``lsc.solve`` of that member alone: the same metrics to 1e-12 relative, or the
    single solve's own message. Returns the number of members solved."""
    n = len(next(iter(values.values())))
    assert set(out["metrics"]) == set(METRICS) and out["status"].shape == (n,)
    assert all(out["metrics"][name].shape[0] == n for name in METRICS)
    return _assert_members_equal(SimpleNamespace(**out), scene, values, method, 1e-12, **options)


# ------------------------------------------------------------------------------ closed form
@pytest.mark.parametrize("unloading", [{"restitution": 0.4}, {"stiffness": 60000.0}])
def test_closed_form_batch_equals_single_solves_on_random_members(unloading):
    scene = _scene({"stiffness": 24000.0}, unloading, failure=3000.0)
    paths = {"vehicles.0.speed": (0.5, 8.0), "vehicles.1.mass": (600.0, 2500.0),
             "contacts.0.loading.stiffness": (1e4, 5e4), "contacts.0.gap": (0.0, 0.3)}
    key = "contacts.0.unloading." + next(iter(unloading))
    paths[key] = (0.0, 1.0) if "restitution" in key else (5.5e4, 2e5)
    values = _random_members(np.random.default_rng(11), 40, paths)
    out, counts = _batch("closed-form", scene, values)
    assert _assert_members_are_single_solves(out, scene, values, "closed-form") == 40
    assert sum(counts) == 40
    # the failure force is crossed by some members and not by others
    failed = np.isfinite(out["metrics"]["failure_time"][:, 0])
    assert failed.any() and not failed.all()


# ------------------------------------------------------------------------------------ exact
@pytest.mark.parametrize("unloading", [{"restitution": 0.5}, {"stiffness": 9e5},
                                       {"table": [[0.3, 1], [0.1, 0]]}])
def test_exact_batch_equals_single_solves_on_random_members(unloading):
    scene = _scene(TABLE, unloading, failure=30000.0)
    paths = {"vehicles.0.speed": (1.0, 9.0), "vehicles.1.mass": (800.0, 2500.0),
             "contacts.0.loading.scale": (0.8, 1.25), "contacts.0.gap": (0.0, 0.2)}
    if "restitution" in unloading:
        paths["contacts.0.unloading.restitution"] = (0.0, 1.0)
    values = _random_members(np.random.default_rng(5), 60, paths)
    out, counts = _batch("exact", scene, values)
    solved = _assert_members_are_single_solves(out, scene, values, "exact")
    assert 0 < solved < 60   # fast members run off the table: the single solve's message
    assert sum(counts) == 60


def test_a_member_the_stepper_cannot_complete_gets_the_single_solves_message():
    """The stepper stops a member at its event limit or at the end of its table; solved alone
    (with the same limit), its status is that solve's message word for word."""
    scene = _scene(TABLE, {"restitution": 0.5}, gap=0.0)
    values = {"vehicles.0.speed": np.array([2.0, 3.0, 20.0])}
    limited, _ = _batch("exact", scene, values, max_events=4)
    assert _assert_members_are_single_solves(limited, scene, values, "exact", max_events=4) == 0
    assert all("event limit reached (4 events" in st for st in limited["status"])
    out, _ = _batch("exact", scene, values)
    assert _assert_members_are_single_solves(out, scene, values, "exact") == 2
    assert "table" in out["status"][2]


def test_exact_batch_restitution_of_a_pushed_shut_member_is_not_applicable():
    """The batch's metrics are lsc.metrics' (the first-impact record carried through the
    stepper): a member touching at t = 0 at a closing speed of rounding (at most
    lsc.metrics.PUSHED of its speed) is pushed shut, its restitution NaN as in the single
    solve, while a struck member's is separation over closing speed (Eq. 9)."""
    scene = _scene(TABLE, {"restitution": 0.5}, gap=0.0)
    values = {"vehicles.0.speed": np.array([3.0, 3.0, 3.0]),
              "vehicles.1.speed": np.array([0.0, 3.0 - 1e-9, 3.0 - 1e-3])}
    out, counts = _batch("exact", scene, values)
    assert _assert_members_are_single_solves(out, scene, values, "exact") == 3
    e = out["metrics"]["restitution"][:, 0]
    assert np.isnan(e[1]) and np.isfinite(e[[0, 2]]).all()
    vf = out["metrics"]["v_final"]
    assert e[0] == pytest.approx((vf[0, 1] - vf[0, 0]) / 3.0, rel=1e-14)


def test_braked_scene_is_refused_by_the_exact_batch_and_swept_one_by_one():
    scene = _scene(TABLE, {"restitution": 0.5})
    scene["vehicles"][1]["brake"] = {"mu": 0.7}
    values = {"vehicles.0.speed": np.array([2.0, 3.0, 4.0])}
    with pytest.raises(lsc.SceneError, match="does not solve braking") as err:
        _batch("exact", scene, values)
    assert err.value.path == "solver.method"
    s = lsc.sweep(scene, values, progress=False)
    assert s.method == "exact" and s.ok.all()
    for j, speed in enumerate(values["vehicles.0.speed"]):
        r = lsc.solve(lsc.Scene.load(scene).with_values({"vehicles.0.speed": speed}))
        np.testing.assert_allclose(s.delta_v[j], r.delta_v, rtol=1e-12)


# ----------------------------------------------------------------------- sweep, generically
def test_an_option_the_batch_path_does_not_take_is_not_dropped():
    """``t_end`` is an option of the closed form's single solve, not of its batch path: the
    sweep then solves each member with it (a ``t_end`` that cuts the crash gets the single
    solve's error) instead of dropping it."""
    scene = _scene({"stiffness": 24000.0}, {"restitution": 0.4})
    speeds = [2.0, 5.0]
    s = lsc.sweep(scene, {"vehicles.0.speed": speeds}, method="closed-form", t_end=0.01,
                  progress=False)
    base = lsc.Scene.load(scene)
    for j, speed in enumerate(speeds):
        with pytest.raises(lsc.SimulationError) as err:
            lsc.solve(base.with_values({"vehicles.0.speed": speed}), method="closed-form",
                      t_end=0.01)
        assert s.status[j] == f"SimulationError: {err.value}"


def test_sweep_source_names_no_backend():
    """``sweep.py`` reaches backends through their declarations only: no backend's module or
    method name appears in it as a name or as a string literal of its code."""
    source = Path(importlib.import_module("lsc.sweep").__file__).read_text()
    backends = {"exact", "closed_form", "diffrax", "diffrax_ode", "scipy", "scipy_ode",
                "reference"}
    methods = set(solvers.METHODS) - {"auto"}
    tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    names = {t.string for t in tokens if t.type == tokenize.NAME}
    assert not names & backends
    docstrings = {ast.get_docstring(n, clean=False) for n in ast.walk(ast.parse(source))
                  if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef))}
    literals = {ast.literal_eval(t.string) for t in tokens if t.type == tokenize.STRING
                and not t.string.startswith(("f", "F"))}
    assert not (literals - docstrings) & methods


class _Recorder:
    """Calls of the toy backend's batch path."""
    calls: list = []


def solve(model, **options):
    """The toy backend's single solve: the closed form's."""
    return solvers.backend("closed-form").solve(model, **options)


def solve_batch(model, values, *, progress=None):
    """The toy backend's batch path: the closed form's, recorded."""
    _Recorder.calls.append({p: v.copy() for p, v in values.items()})
    return solvers.backend("closed-form").solve_batch(model, values, progress=progress)


@pytest.fixture
def toy_backend():
    """A backend registered from this module: the closed form under another name, with a batch
    path that records its calls."""
    cf = solvers.backend("closed-form")
    solvers.register(Backend(name="toy-batch", module=__name__, options=cf.options,
                             solves=cf.solves, vehicles=cf.vehicles, batch=cf.batch))
    _Recorder.calls = []
    yield _Recorder.calls
    solvers.unregister("toy-batch")


def test_sweep_sends_valid_members_to_any_declared_batch_path(toy_backend):
    scene = _scene({"stiffness": 24000.0}, {"restitution": 0.4})
    speeds = [2.0, -1.0, 5.0, 7.0]   # a member that does not close is invalid: not batched
    s = lsc.sweep(scene, {"vehicles.0.speed": speeds}, method="toy-batch", progress=False)
    assert s.method == "toy-batch"
    assert len(toy_backend) == 1
    np.testing.assert_array_equal(toy_backend[0]["vehicles.0.speed"], [2.0, 5.0, 7.0])
    assert list(s.ok) == [True, False, True, True] and "SceneError" in s.status[1]
    ref = lsc.sweep(scene, {"vehicles.0.speed": speeds}, method="closed-form", progress=False)
    for name in METRICS:
        np.testing.assert_array_equal(s.metrics[name], ref.metrics[name])


def test_sweep_loops_when_the_batch_path_does_not_take_a_control(toy_backend):
    scene = _scene({"stiffness": 24000.0}, {"restitution": 0.4})
    s = lsc.sweep(scene, {"vehicles.0.speed": [2.0, 5.0]}, method="toy-batch", chunk=8,
                  progress=False)
    assert toy_backend == [] and s.ok.all()
    r = lsc.solve(lsc.Scene.load(scene).with_values({"vehicles.0.speed": 5.0}))
    np.testing.assert_allclose(s.delta_v[1], r.delta_v, rtol=1e-14)


def test_sweep_loops_over_a_path_the_batch_cannot_set(toy_backend):
    scene = _scene({"stiffness": 24000.0}, {"restitution": 0.4})
    s = lsc.sweep(scene, {"solver.t_end": [1.0, 2.0]}, method="toy-batch", progress=False)
    assert toy_backend == [] and s.ok.all()
