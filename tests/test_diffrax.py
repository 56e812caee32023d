"""The diffrax backend against the closed form, the SciPy backend and conservation laws."""

import itertools
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("diffrax")

import lsc  # noqa: E402
from lsc.model import HybridModel  # noqa: E402
from lsc.result import METRICS as RESULT_METRICS  # noqa: E402
from lsc.scene import Scene  # noqa: E402
from lsc.solvers import closed_form, scipy_ode  # noqa: E402
from lsc.solvers.diffrax_ode import api as dx, core, single  # noqa: E402
from helpers import NONLINEAR, max_rel_error as _rel, two_cars  # noqa: E402

METRICS = ("delta_v", "duration", "peak_force", "max_deformation")

def _model(scene):
    return HybridModel(Scene.load(scene))


@pytest.mark.parametrize("ratio, e", list(itertools.product([0.1, 1.0, 10.0], [0.0, 0.4, 1.0])))
def test_linear_grid_matches_closed_form_and_scipy(ratio, e):
    m1, m2, v1, v2, k = 1500.0 * ratio, 1500.0, 5.0, 1.0, 2.4e5
    model = _model(two_cars(m1, m2, v1, v2, {"stiffness": k}, {"restitution": e}))
    r = dx.solve(model, rtol=1e-12)
    sp = scipy_ode.solve(model, rtol=1e-12)
    exact = closed_form.metrics(m1, m2, v1, v2, k, e)
    for name in METRICS:
        assert _rel(getattr(r, name), exact[name]) < 1e-9, name
        assert _rel(getattr(r, name), getattr(sp, name)) < 1e-9, name
    assert r.method == "diffrax-Dopri8"
    assert [ev.kind for ev in r.events] == [ev.kind for ev in sp.events]
    # momentum: conserved to 1e-12 relative, at the end and along the sampled trajectory
    m = np.array([m1, m2])
    p0 = m @ np.array([v1, v2])
    assert abs(m @ r.v_final - p0) <= 1e-12 * abs(p0)
    assert np.max(np.abs(r.v @ m - p0)) <= 1e-12 * abs(p0)


def test_paper_scene_event_times(paper):
    # compression lasts π/(2ω), the pulse π/(2ω)(1 + e): the events to ~1e-12 relative
    r = lsc.solve(paper, method="diffrax", rtol=1e-13)
    mu = 3500 / 32.2 / 2
    w = np.sqrt(24000 / mu)
    t_max = [ev.time for ev in r.events if ev.kind == "max_deformation"][0]
    t_sep = [ev.time for ev in r.events if ev.kind == "separation"][0]
    assert t_max == pytest.approx(np.pi / (2 * w), rel=1e-12)
    assert t_sep == pytest.approx(np.pi / (2 * w) * 1.4, rel=1e-12)
    assert r.delta_v == pytest.approx([-7.0, 7.0], rel=1e-12)
    assert r.stats["steps"] > 0 and r.stats["wall_time"] > 0 and "compile_time" in r.stats


def test_nonlinear_table_matches_scipy():
    model = _model(two_cars(1600.0, 1200.0, 6.0, 0.0, NONLINEAR, {"restitution": 0.5}))
    r = dx.solve(model, rtol=1e-12)
    sp = scipy_ode.solve(model, integrator="DOP853", rtol=1e-12)
    for name in METRICS + ("permanent_deformation", "restitution", "energy_absorbed"):
        assert _rel(getattr(r, name), getattr(sp, name)) < 1e-9, name
    assert [(ev.kind, ev.index) for ev in r.events] == [(ev.kind, ev.index) for ev in sp.events]
    times = np.array([ev.time for ev in r.events])
    assert np.max(np.abs(times - [ev.time for ev in sp.events])) < 1e-9 * times[-1]
    assert r.restitution_energy[0] == pytest.approx(0.5, abs=1e-12)
    m = np.array([1600.0, 1200.0])
    assert abs(m @ r.v_final - 1600.0 * 6.0) <= 1e-12 * 1600.0 * 6.0
    # the loading force follows the table between the events
    curve = Scene.load(two_cars(1, 1, 1, 0, NONLINEAR, {"restitution": 0.5})).contacts[0]
    curve = curve.law.loading
    load = r.t <= [ev.time for ev in r.events if ev.kind == "max_deformation"][0]
    assert np.max(np.abs(r.force[load, 0] - curve.force(r.deformation[load, 0]))) < 1e-6 * 40000


def test_two_events_in_one_step_take_the_earliest():
    # on the plateau the force is constant, the steps grow large and one step crosses both the
    # next breakpoint and the (would-be) common velocity: the breakpoint comes first
    model = _model(two_cars(1600.0, 1200.0, 5.27721265, 0.0, NONLINEAR,
                            {"restitution": 0.31968164}))
    r = dx.solve(model, rtol=1e-10)
    sp = scipy_ode.solve(model, rtol=1e-12)
    assert [ev.kind for ev in r.events] == [ev.kind for ev in sp.events]
    assert _rel(r.delta_v, sp.delta_v) < 1e-8


def test_chain_touching_at_rest_closes_at_once():
    # the middle and front cars touch at rest: contact 1 is on its surface at t = 0 (restart trap)
    scene = {"units": "SI",
             "vehicles": [{"mass": 1500, "speed": 8}, {"mass": 1200, "speed": 0},
                          {"mass": 1400, "speed": 0}],
             "contacts": [{"loading": {"stiffness": 5e5}, "unloading": {"restitution": 0.5}},
                          {"loading": {"stiffness": 4e5}, "unloading": {"restitution": 0.3}}]}
    model = _model(scene)
    r = dx.solve(model, rtol=1e-12)
    sp = scipy_ode.solve(model, rtol=1e-12)
    assert [(ev.kind, ev.index) for ev in r.events] == [(ev.kind, ev.index) for ev in sp.events]
    contact1 = [ev.time for ev in r.events if ev.kind == "contact" and ev.index == 1][0]
    assert contact1 < 1e-3 * r.duration
    for name in METRICS:
        assert _rel(getattr(r, name), getattr(sp, name)) < 1e-9, name
    m = np.array([1500.0, 1200.0, 1400.0])
    assert abs(m @ r.v_final - 1500 * 8) <= 1e-12 * 1500 * 8


def test_a_contact_separated_at_its_permanent_set_does_not_close_again_at_once():
    # contact 0 separates at t = 0.01824 s a rounding error above its permanent set, opening at
    # 0.078 ft/s while contact 1 pushes the middle car back: it closes again 1.2 ms later. Its
    # closing event, a hair above zero at the segment's start, was taken as the root of the step
    # that crossed it 1.2 ms on: a "contact" at the separation instant, then a zero-length impact
    # (lasting 4.8e-14 s) that Result.build refused as unresolved (a SimulationError)
    scene = {"units": "US",
             "vehicles": [{"mass": 19.788475161779697, "speed": 1.0}, {"mass": 1.0, "speed": 0.0},
                          {"mass": 10.0, "speed": 0.0}],
             "contacts": [{"loading": {"stiffness": 64938.16315762113},
                           "unloading": {"restitution": 0.21875}, "gap": 0.0},
                          {"loading": {"stiffness": 10000.0}, "unloading": {"restitution": 1.0},
                           "gap": 0.0}]}
    r = lsc.solve(scene, method="diffrax")
    ref = lsc.solve(scene, method="exact-chain")
    assert [(ev.kind, ev.index) for ev in r.events] == \
        [(ev.kind, ev.index) for ev in ref.events]
    times, ref_times = [ev.time for ev in r.events], [ev.time for ev in ref.events]
    # (contact 1, touching at rest, is pushed shut at once: at t = 0 exactly in the closed form,
    # once 1e-12 into its surface here, see test_chain_touching_at_rest_closes_at_once)
    assert r.events[1].kind == "contact" and times[1] < 1e-3 * r.duration
    assert np.max(np.abs(np.subtract(times, ref_times)[2:])) < 1e-9 * ref.duration_total
    for name in METRICS:
        assert _rel(getattr(r, name), getattr(ref, name)) < 1e-8, name


def test_same_structure_does_not_retrace_or_recompile():
    a = _model(two_cars(1300.0, 1100.0, 7.0, 0.5, {"stiffness": 3.1e5}, {"restitution": 0.35}))
    b = _model(two_cars(1700.0, 900.0, 4.0, -1.0, {"stiffness": 1.7e5}, {"restitution": 0.7}))
    ra = dx.solve(a, rtol=1e-11)
    traces = dict(dx.TRACES)
    rb = dx.solve(b, rtol=1e-12)  # other numbers, tolerance included: same compiled code
    assert dx.TRACES == traces
    assert rb.stats["compile_time"] == 0.0
    exact = closed_form.metrics(1700.0, 900.0, 4.0, -1.0, 1.7e5, 0.7)
    assert _rel(rb.delta_v, exact["delta_v"]) < 1e-9
    assert _rel(ra.delta_v, rb.delta_v) > 0.1


def test_a_solve_that_fills_the_small_record_runs_again_with_the_full_one(monkeypatch):
    model = _model(two_cars(1500.0, 900.0, 4.0, 0.0, {"stiffness": 30000.0}, {"restitution": 0.6}))
    full = dx.solve(model, integrator="Tsit5", rtol=1e-10, max_steps=64)
    assert full.stats["steps"] > 16
    monkeypatch.setattr(single, "RECORD_NODES", 16)   # fewer nodes than the solve's steps
    r = dx.solve(model, integrator="Tsit5", rtol=1e-10, max_steps=64)
    assert any(key[1:] == ("Tsit5", 64, 256, 16) for key in core._CORES)  # it was tried first
    assert r.stats["steps"] == full.stats["steps"]
    for name in METRICS:
        assert np.array_equal(getattr(r, name), getattr(full, name)), name
    assert np.array_equal(r.v, full.v) and np.array_equal(r.t, full.t)


@pytest.mark.parametrize("integrator", dx.INTEGRATORS)
def test_every_integrator_reaches_its_tolerance(integrator):
    model = _model(two_cars(1500.0, 900.0, 4.0, 0.0, {"stiffness": 30000.0}, {"restitution": 0.6}))
    r = dx.solve(model, integrator=integrator, rtol=1e-9)
    exact = closed_form.metrics(1500.0, 900.0, 4.0, 0.0, 30000.0, 0.6)
    assert r.method == f"diffrax-{integrator}"
    for name in METRICS:
        assert _rel(getattr(r, name), exact[name]) < 1e-7, name


def test_lsc_solve_dispatch_t_end_and_errors():
    scene = two_cars(1500.0, 900.0, 4.0, 0.0, {"stiffness": 30000.0}, {"restitution": 0.6})
    r = lsc.solve(scene, method="diffrax", t_end=1.0)
    assert r.t[-1] == pytest.approx(1.0)
    assert r.v[-1] == pytest.approx(r.v_final, rel=1e-12)
    with pytest.raises(lsc.SimulationError, match="before the crash is over"):
        lsc.solve(scene, method="diffrax", t_end=0.01)
    with pytest.raises(lsc.SceneError, match="integrator"):
        lsc.solve(scene, method="diffrax", integrator="RK45")
    short = two_cars(1500.0, 1500.0, 10.0, 0.0, {"table": [[0, 0], [0.05, 3000]]},
                     {"restitution": 0.5})
    with pytest.raises(lsc.SimulationError, match="ends before the vehicles reach a common"):
        lsc.solve(short, method="diffrax")


def test_batch_equals_single_solves():
    scene = two_cars(1600.0, 1200.0, 6.0, 0.0, NONLINEAR, {"restitution": 0.5})
    model = _model(scene)
    v = np.array([0.5, 2.0, 4.0, 6.0, 30.0])  # 30 m/s runs off the end of the table
    e = np.array([0.0, 1.0, 0.3, 0.6, 0.5])
    pb = dict(model.params)
    pb["v0"] = np.stack([v, np.zeros_like(v)], axis=1)
    pb["contacts"] = [dict(model.params["contacts"][0], e=e)]
    res = dx.solve_params(model, pb, rtol=1e-11)
    assert list(res["status"]) == [0, 0, 0, 0, 1]
    assert "ends before" in res["message"][-1] and np.isnan(res["delta_v"][-1]).all()
    for j in range(4):
        one = dx.solve(_model(two_cars(1600.0, 1200.0, float(v[j]), 0.0, NONLINEAR,
                                       {"restitution": float(e[j])})), rtol=1e-11)
        for name in dx.BATCH_METRICS:
            assert np.allclose(res[name][j], getattr(one, name), rtol=1e-9, atol=0,
                               equal_nan=True), name


def _effect_scenes():
    kelvin = {"units": "SI",
              "vehicles": [{"mass": 1400.0, "speed": 3.0}, {"mass": 1000.0, "speed": 0.0}],
              "contacts": [{"law": "kelvin", "stiffness": 2.0e5, "restitution": 0.451}]}
    braked = {"units": "SI", "g": 9.81,
              "vehicles": [{"mass": 1400.0, "speed": 3.0, "brake": {"mu": 0.7}},
                           {"mass": 1000.0, "speed": 0.0, "brake": {"mu": 0.7}}],
              "contacts": [{"loading": {"table": [[0, 0], [0.01, 500], [0.05, 8000], [0.3, 9e4]]},
                            "unloading": {"restitution": 0.4}, "failure": {"force": 12000.0}}]}
    return {"kelvin": (kelvin, {}), "braked+failure": (braked, {"t_end": 2.0})}


@pytest.mark.parametrize("name", ["kelvin", "braked+failure"])
def test_effects_match_scipy_and_batch_peaks_between_events(name):
    scene, opts = _effect_scenes()[name]
    model = _model(scene)
    r = dx.solve(model, rtol=1e-12, **opts)
    sp = scipy_ode.solve(model, rtol=1e-12, **opts)
    assert [(ev.kind, ev.index) for ev in r.events] == [(ev.kind, ev.index) for ev in sp.events]
    for q in METRICS + ("v_final", "restitution", "energy_absorbed", "energy_returned"):
        assert _rel(getattr(r, q), getattr(sp, q)) < 1e-9, q
    assert np.array_equal(np.isnan(r.failure_time), np.isnan(sp.failure_time))
    assert np.nan_to_num(_rel(r.failure_time, sp.failure_time)) < 1e-9
    if name == "braked+failure":
        assert np.all(np.abs(r.v[-1]) < 1e-12) and r.v_final[1] > 0  # stopped; post-crash speed
        assert r.failed[0] and "failure" in [ev.kind for ev in r.events]
    # the metrics solve finds the peaks between events (Kelvin: before the max deformation) at
    # least as high as the sampled series, and within the series' sampling error
    batch = dx.solve_params(model, {**model.params, "v0": np.asarray(model.params["v0"])[None]},
                            rtol=1e-12, **opts)
    assert batch["status"][0] == 0
    for q in ("delta_v", "duration", "max_deformation", "energy_absorbed", "failure_time"):
        assert np.allclose(batch[q][0], getattr(r, q), rtol=1e-12, atol=0, equal_nan=True), q
    assert np.all(batch["peak_force"][0] >= r.peak_force * (1 - 1e-12))
    assert _rel(batch["peak_force"][0], r.peak_force) < 1e-5
    assert _rel(batch["peak_acceleration"][0], r.peak_acceleration) < 1e-5


def test_import_lsc_does_not_import_jax():
    code = "import sys, lsc; sys.exit(any(m in sys.modules for m in ('jax', 'diffrax')))"
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def _single_metrics(scene, values, j, **opts):
    """Member ``j`` of ``values`` solved alone by ``lsc.solve``: its metrics, or the
    ``"SimulationError: ..."`` status the batch must give it."""
    member = Scene.load(scene).with_values({p: float(v[j]) for p, v in values.items()})
    try:
        r = lsc.solve(member, method="diffrax", **opts)
    except lsc.SimulationError as exc:
        return None, f"SimulationError: {exc}"
    return {name: getattr(r, name) for name in RESULT_METRICS}, "ok"


def _assert_batch_is_single_solves(scene, values, batch, **opts):
    n = len(next(iter(values.values())))
    assert set(batch["metrics"]) == set(RESULT_METRICS)
    for j in range(n):
        single, status = _single_metrics(scene, values, j, **opts)
        assert batch["status"][j] == status, j
        for name, arr in batch["metrics"].items():
            assert arr.shape[0] == n
            if single is None:
                assert np.all(np.isnan(arr[j])), (j, name)
            else:
                assert np.allclose(arr[j], single[name], rtol=1e-9, atol=0, equal_nan=True), \
                    (j, name)


def test_solve_batch_through_the_contract_equals_single_solves():
    # chunks of 2 run in 2 threads, in the work order (by kinetic energy over the table's
    # capacity): each member's metrics must still land on that member; 30 m/s runs off the
    # end of the table and gets the single solve's error
    scene = two_cars(1600.0, 1200.0, 6.0, 0.0, NONLINEAR, {"restitution": 0.5})
    values = {"vehicles.0.speed": np.array([6.0, 30.0, 0.5, 4.0, 2.0]),
              "contacts.0.unloading.restitution": np.array([0.6, 0.5, 0.0, 0.3, 1.0])}
    done = []
    batch = lsc.solvers.backend("diffrax").solve_batch(
        _model(scene), values, rtol=1e-11, chunk=2, workers=2, progress=done.append)
    assert batch["status"][0] == "ok"
    assert batch["status"][1].startswith("SimulationError: contact 0 at t = ")
    assert "ends before the vehicles reach a common" in batch["status"][1]
    assert sum(done) == 5
    _assert_batch_is_single_solves(scene, values, batch, rtol=1e-11)


def test_solve_batch_reloads_paths_the_parameters_cannot_set():
    # a Kelvin restitution sets the damping ratio through the loader (no parameter setter):
    # each member is re-loaded, and still solved in one batch
    scene = _effect_scenes()["kelvin"][0]
    values = {"contacts.0.restitution": np.array([0.2, 0.451, 0.8]),
              "vehicles.0.speed": np.array([3.0, 5.0, 2.0])}
    batch = lsc.solvers.backend("diffrax").solve_batch(_model(scene), values, rtol=1e-12)
    assert list(batch["status"]) == ["ok"] * 3
    _assert_batch_is_single_solves(scene, values, batch, rtol=1e-12)


def test_the_declaration_imports_no_jax():
    code = ("import sys, lsc.solvers, lsc.solvers.diffrax_ode as d; "
            "b = lsc.solvers.backend('diffrax'); assert b.module == d.__name__ + '.api'; "
            "sys.exit(any(m in sys.modules for m in ('jax', 'diffrax')))")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0
