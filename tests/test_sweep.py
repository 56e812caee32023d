"""lsc.sweep: per-member results equal single solves; failures are reported per member."""

import subprocess
import sys

import numpy as np
import pytest

import lsc
from helpers import NONLINEAR, PAPER, subprocess_env, two_cars


def _members(n, seed=1):
    rng = np.random.default_rng(seed)
    return {"vehicles.0.speed": rng.uniform(0.5, 30, n),
            "contacts.0.unloading.restitution": rng.uniform(0, 1, n)}


def test_closed_form_sweep_equals_single_solves():
    params = _members(1000)
    s = lsc.sweep(PAPER, params)
    assert s.method == "closed-form" and np.all(s.ok)
    # durations differ widely? (they do not for a linear scene: they depend on e only)
    for j in range(0, 1000, 97):
        r = lsc.solve(lsc.Scene.load(PAPER).with_values(
            {p: float(v[j]) for p, v in params.items()}), method="closed-form")
        for name in ("delta_v", "duration", "peak_force", "max_deformation", "restitution"):
            assert np.allclose(getattr(s, name)[j], getattr(r, name), rtol=1e-12, atol=0), name


def test_looped_sweep_equals_single_solves_with_very_different_end_times():
    base = two_cars(1600.0, 1200.0, 6.0, 0.0, NONLINEAR, {"restitution": 0.5})
    rng = np.random.default_rng(7)
    n = 40
    params = {"vehicles.0.speed": rng.uniform(0.5, 9.0, n),
              "contacts.0.unloading.restitution": rng.uniform(0, 1, n)}
    params["contacts.0.unloading.restitution"][:2] = [0.0, 1.0]
    s = lsc.sweep(base, params, method="scipy", rtol=1e-11)
    assert s.method == "scipy"
    assert np.ptp(s.duration[s.ok]) > 0.01, "members must end at very different times"
    for j in range(n):
        member = lsc.Scene.load(base).with_values({p: float(v[j]) for p, v in params.items()})
        try:
            r = lsc.solve(member, method="scipy", rtol=1e-11)
        except lsc.SimulationError as e:
            assert s.status[j] == f"SimulationError: {e}"
            continue
        assert s.status[j] == "ok"
        for name in ("delta_v", "duration", "peak_force", "max_deformation"):
            assert np.allclose(getattr(s, name)[j], getattr(r, name), rtol=1e-9, atol=0), name


def test_invalid_members_are_reported_and_the_rest_returned():
    s = lsc.sweep(PAPER, {"contacts.0.unloading.restitution": [0.2, 1.5, -0.1, 0.8, np.nan]})
    assert list(s.ok) == [True, False, False, True, False]
    assert "contacts[0].unloading.restitution" in s.status[1] and "1.5" in s.status[1]
    assert s.status[1].startswith("SceneError:")
    assert np.isnan(s.delta_v[1]).all() and np.isfinite(s.delta_v[0]).all()
    assert s.delta_v[3] == pytest.approx([-9.0, 9.0])
    assert s.stats["failed"] == 3


def test_not_closing_members_are_flagged():
    s = lsc.sweep(PAPER, {"vehicles.0.speed": [5.0, 0.0, -2.0, 1.0]})
    assert list(s.ok) == [True, False, False, True]
    assert "not closing" in s.status[1]


def test_grid_and_units():
    g = lsc.sweep(PAPER, {"vehicles.0.speed": [5, 10, "20 km/h"],
                          "contacts.0.loading.stiffness": [12000, 24000]}, grid=True)
    assert g.shape == (3, 2) and g.delta_v.shape == (6, 2)
    assert g.params["vehicles.0.speed"][4] == pytest.approx(20 / 3.6 / 0.3048)
    mu = 3500 / 32.2 / 2
    F = g.params["vehicles.0.speed"] * np.sqrt(g.params["contacts.0.loading.stiffness"] * mu)
    assert g.peak_force[:, 0] == pytest.approx(F, rel=1e-12)


def test_sweep_rejects_bad_params():
    with pytest.raises(lsc.SceneError, match="equal lengths"):
        lsc.sweep(PAPER, {"vehicles.0.speed": [1, 2], "vehicles.1.speed": [0, 0, 0]})
    with pytest.raises(lsc.SceneError) as e:
        lsc.sweep(PAPER, {"vehicles.0.sped": [1, 2]})
    assert e.value.path == "vehicles.0.sped"


def test_sweep_csv(tmp_path):
    s = lsc.sweep(PAPER, {"vehicles.0.speed": [4.0, 6.0]})
    f = tmp_path / "s.csv"
    s.to_csv(f)
    text = f.read_text().splitlines()
    assert text[0].startswith("vehicles.0.speed,delta_v[bullet] (ft/s)")
    assert text[0].endswith(",status,warnings")
    assert len(text) == 3 and text[1].endswith(",ok,")   # (no warning)


def test_sweep_over_solver_settings_uses_each_members_own():
    from lsc import data

    s = lsc.sweep(data.load("table1"), {"solver.dt": [1e-3, 1e-5]})
    assert s.method == "reference"
    assert [f"{v:.3f}" for v in s.v_final[:, 0]] == ["-0.082", "-0.001"]  # Table 1 rows


def test_method_override_drops_the_scenes_own_options():
    from lsc import data

    r = lsc.solve(data.load("table1"), method="scipy")  # the scene's dt is for its reference
    assert r.method.startswith("scipy") and "dt" not in r.tolerances
    with pytest.raises(lsc.SceneError) as e:
        lsc.solve(data.load("table1"), method="scipy", dt=1e-5)  # asked for explicitly
    assert e.value.path == "solver.dt"


def test_cli_sweep_writes_table_and_plot(tmp_path, capsys):
    from lsc.cli import main

    code = main(["sweep", "--param", "vehicles.0.speed=2:12:6",
                 "--param", "contacts.0.unloading.restitution=0.2,0.8", "--grid",
                 "--metric", "delta_v", "--out", str(tmp_path)])
    assert code == 0
    assert "12 members by closed-form" in capsys.readouterr().out
    rows = (tmp_path / "sweep.csv").read_text().splitlines()
    assert len(rows) == 13
    head = rows[0].split(",")
    last = dict(zip(head, rows[-1].split(",")))
    assert float(last["vehicles.0.speed"]) == 12.0
    assert float(last["delta_v[target] (ft/s)"]) == pytest.approx(1.8 * 6.0)
    assert (tmp_path / "sweep.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_sweep_bad_param_is_one_line_exit_2(tmp_path, capsys):
    from lsc.cli import main

    code = main(["sweep", "--param", "vehicles.0.sped=1,2", "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "vehicles.0.sped" in err[0]


def test_table_sweep_runs_as_one_exact_batch_equal_to_single_solves():
    base = two_cars(1500.0, 1000.0, 3.0, 0.0, NONLINEAR, {"restitution": 0.5})
    rng = np.random.default_rng(3)
    n = 400
    params = {"vehicles.0.speed": rng.uniform(1, 8, n),
              "contacts.0.unloading.restitution": rng.uniform(0, 1, n),
              "vehicles.1.mass": rng.uniform(800, 2500, n),
              "contacts.0.loading.scale": rng.uniform(0.8, 1.25, n)}
    s = lsc.sweep(base, params)
    assert s.method == "exact"
    assert 0 < np.sum(~s.ok) < n  # some members end their table too soon: reported, not lost
    sc = lsc.Scene.load(base)
    for j in range(0, n, 37):
        member = sc.with_values({p: float(v[j]) for p, v in params.items()})
        try:
            r = lsc.solve(member, method="exact")
        except lsc.SimulationError as e:
            assert "SimulationError" in s.status[j]
            assert str(e).split(": ", 1)[1] in s.status[j]
            continue
        for name in ("delta_v", "duration", "peak_force", "max_deformation", "restitution"):
            assert np.allclose(getattr(s, name)[j], getattr(r, name), rtol=1e-12, atol=1e-300), name


# ---------------------------------------------------------------------------------- diffrax
# US units: a measured-like table long enough for 30 ft/s (soft start, plateau, dip, stiff end)
LONG_TABLE = {"table": [[0, 0], [0.05, 500], [0.15, 2500], [0.3, 6000], [0.4, 6000],
                        [0.5, 5500], [0.8, 12000], [2.0, 60000]]}
US_BASE = {"units": "US",
           "vehicles": [{"weight": 3500, "speed": 10}, {"weight": 3000, "speed": 0}],
           "contacts": [{"loading": LONG_TABLE, "unloading": {"restitution": 0.5}}]}
SWEEP_METRICS = ("delta_v", "v_final", "duration", "peak_force", "peak_acceleration",
                 "max_deformation", "permanent_deformation", "restitution",
                 "restitution_energy", "energy_absorbed", "energy_returned")


def test_diffrax_sweep_of_1000_equals_single_solves_and_the_exact_backend():
    pytest.importorskip("diffrax")
    rng = np.random.default_rng(11)
    n = 1000
    params = {"vehicles.0.speed": rng.uniform(0.5, 30.0, n),
              "contacts.0.unloading.restitution": rng.uniform(0.0, 1.0, n)}
    params["vehicles.0.speed"][:4] = [0.5, 30.0, 0.5, 30.0]
    params["contacts.0.unloading.restitution"][:4] = [0.0, 0.0, 1.0, 1.0]
    s = lsc.sweep(US_BASE, params, method="diffrax", rtol=1e-11)
    assert s.method == "diffrax"
    # members end at very different times (e = 0 at the max crush, e = 1 after a full
    # rebound; few or all of the breakpoints crossed), after different numbers of events
    assert np.nanmax(s.duration) > 2.5 * np.nanmin(s.duration)
    assert np.ptp(s.max_deformation[s.ok]) > 1.0
    # a unit restitution on this table asks for a negative permanent set: reported, not lost
    assert 0 < np.sum(~s.ok) < n // 2
    base = lsc.Scene.load(US_BASE)
    for j in range(n):
        member = base.with_values({p: float(v[j]) for p, v in params.items()})
        try:
            r = lsc.solve(member, method="diffrax", rtol=1e-11, n_samples=2)
        except lsc.SimulationError as e:
            assert s.status[j] == f"SimulationError: {e}", j
            assert np.isnan(s.delta_v[j]).all()
            continue
        assert s.status[j] == "ok", (j, s.status[j])
        for name in SWEEP_METRICS:
            # (a restitution is a ΔV over the closing speed: within 1e-12 of it, absolute; a
            # near-plastic one, e = 6e-4, differs by 1e-9 of itself between the batched and the
            # single compiled programs, which round differently, each as close to the exact one)
            atol = 1e-12 if name == "restitution" else 0.0
            assert np.allclose(getattr(s, name)[j], getattr(r, name), rtol=1e-9, atol=atol), \
                (j, name)
    # and each member is right, not only equal to its single solve: the exact backend
    ex = lsc.sweep(US_BASE, params, method="exact")
    assert np.array_equal(ex.ok, s.ok)
    for name in ("delta_v", "duration", "peak_force", "max_deformation", "energy_returned"):
        a, b = getattr(s, name)[s.ok], getattr(ex, name)[s.ok]
        assert np.allclose(a, b, rtol=1e-9, atol=1e-12 * np.max(np.abs(b))), name


def test_diffrax_sweep_reports_failing_members_and_returns_the_rest():
    pytest.importorskip("diffrax")
    short = {"units": "US",
             "vehicles": [{"weight": 3500, "speed": 5}, {"weight": 3500, "speed": 0}],
             "contacts": [{"loading": {"table": [[0, 0], [0.1, 2000], [0.3, 9000]]},
                           "unloading": {"restitution": 0.4}}]}
    speeds = [2.0, 60.0, 1.5, 4.0]  # 60 ft/s runs off the end of the table
    es = [0.3, 0.3, 1.5, 0.5]       # 1.5 is no restitution
    s = lsc.sweep(short, {"vehicles.0.speed": speeds, "contacts.0.unloading.restitution": es},
                  method="diffrax")
    assert list(s.ok) == [True, False, False, True]
    assert s.status[1].startswith("SimulationError: contact 0 at t = ")
    assert "loading table ends before the vehicles reach a common velocity" in s.status[1]
    assert s.status[2].startswith("SceneError:") and "restitution" in s.status[2]
    assert np.isnan(s.delta_v[1:3]).all() and s.stats["failed"] == 2
    for j in (0, 3):
        member = lsc.Scene.load(short).with_values({"vehicles.0.speed": speeds[j],
                                                    "contacts.0.unloading.restitution": es[j]})
        r = lsc.solve(member, method="exact")
        assert np.allclose(s.delta_v[j], r.delta_v, rtol=1e-9)
    with pytest.raises(lsc.SimulationError) as e:
        lsc.solve(lsc.Scene.load(short).with_values({"vehicles.0.speed": 60.0,
                                                     "contacts.0.unloading.restitution": 0.3}),
                  method="diffrax")
    assert s.status[1] == f"SimulationError: {e.value}"


def test_diffrax_sweep_chunks_and_workers_do_not_change_the_answer():
    pytest.importorskip("diffrax")
    rng = np.random.default_rng(5)
    params = {"vehicles.0.speed": rng.uniform(1, 20, 300),
              "contacts.0.unloading.restitution": rng.uniform(0.1, 0.9, 300),
              "vehicles.1.weight": rng.uniform(2500, 4500, 300)}
    one = lsc.sweep(US_BASE, params, method="diffrax", chunk=1024, workers=1)
    many = lsc.sweep(US_BASE, params, method="diffrax", chunk=64, workers=2)
    assert np.array_equal(one.status, many.status)
    for name in SWEEP_METRICS:
        assert np.allclose(getattr(one, name), getattr(many, name), rtol=1e-12, atol=0,
                           equal_nan=True), name


def test_exact_chain_sweep_workers_spread_the_batch_over_processes(monkeypatch):
    """``workers=2`` on a backend whose batch path takes no ``workers`` (exact-chain): the
    chunks go to its batch on a pool of two processes (it solved them one by one in this
    process), with the numbers and statuses of ``workers=1``, bit for bit; beside an
    ``executor`` it is refused."""
    from concurrent.futures import ProcessPoolExecutor

    from lsc import chunks
    from test_exact_chain_batch import random_chains

    scene, values = random_chains(3, 200, 11, 0.05)
    submitted = []
    submit = chunks._submit

    def spy(executor, task):
        submitted.append((type(executor), task.batch, len(task)))
        return submit(executor, task)

    monkeypatch.setattr(chunks, "_submit", spy)
    one = lsc.sweep(scene, values, method="exact-chain", workers=1, progress=False)
    assert submitted == []
    two = lsc.sweep(scene, values, method="exact-chain", workers=2, progress=False)
    assert submitted == [(ProcessPoolExecutor, True, 100)] * 2
    assert one.method == two.method == "exact-chain" and one.ok.sum() > 190
    assert np.array_equal(one.status, two.status)
    for name in SWEEP_METRICS:
        assert np.array_equal(getattr(one, name), getattr(two, name), equal_nan=True), name
    with ProcessPoolExecutor(1) as pool, pytest.raises(lsc.SceneError) as e:
        lsc.sweep(scene, values, method="exact-chain", workers=2, executor=pool)
    assert str(e.value) == ("workers: workers sets the processes of this machine that solve the "
                            "chunks (exact-chain); an executor runs them on the workers it has: "
                            "give one or the other")


def test_worker_pools_are_not_forked_from_a_process_running_jax(monkeypatch):
    """``workers=`` (and the CLI's ``--workers``) forks its processes, the cheapest start, but
    not once JAX is imported: a forked child of a process with JAX's threads can deadlock
    (Python warns of it), so the pool then starts from a fork server. (JAX's presence is what
    ``sys.modules`` says: set and unset here, not imported.)"""
    import types

    from lsc.chunks import executor_from

    def method():
        with executor_from(2) as pool:
            return pool._mp_context.get_start_method()

    monkeypatch.delitem(sys.modules, "jax", raising=False)
    assert method() == "fork"
    monkeypatch.setitem(sys.modules, "jax", types.ModuleType("jax"))
    assert method() == "forkserver"


def test_cli_sweep_with_diffrax(tmp_path, capsys):
    pytest.importorskip("diffrax")
    from lsc.cli import main

    code = main(["sweep", "--param", "vehicles.0.speed=2:12:6", "--method", "diffrax",
                 "--rtol", "1e-11", "--metric", "delta_v", "--out", str(tmp_path)])
    assert code == 0
    assert "6 members by diffrax" in capsys.readouterr().out
    rows = (tmp_path / "sweep.csv").read_text().splitlines()
    head = rows[0].split(",")
    for row in rows[1:]:
        rec = dict(zip(head, row.split(",")))
        v = float(rec["vehicles.0.speed"])
        # the default scene: the paper's, e = 0.4, equal masses
        assert float(rec["delta_v[target] (ft/s)"]) == pytest.approx(0.7 * v, rel=1e-9)
        assert rec["status"] == "ok"
    assert (tmp_path / "sweep.png").read_bytes()[:4] == b"\x89PNG"


def test_braked_scene_sweep_equals_single_solves():
    """A braked scene is not sent to the vectorised exact stepper (which has no friction): each
    member equals its own solve, friction included."""
    sc = {"units": "US", "g": "32.2 ft/s^2",
          "vehicles": [{"weight": 3500, "speed": 10},
                       {"weight": 3500, "speed": 0, "brake": {"mu": 0.7, "mu_static": 0.8}}],
          "contacts": [{"loading": {"table": [[0, 0], [0.1, 3000], [0.5, 12000], [2, 40000]]},
                        "unloading": {"restitution": 0.4}}]}
    speeds = [4.0, 8.0]
    s = lsc.sweep(sc, {"vehicles.0.speed": speeds})
    for j, v in enumerate(speeds):
        one = lsc.solve(lsc.Scene.load(sc).with_values({"vehicles.0.speed": v}))
        np.testing.assert_allclose(s.metrics["delta_v"][j], one.delta_v, rtol=1e-12, atol=1e-12)
    # at 4 ft/s the target breaks away (peak force above mu_s W), stops, and is struck again:
    # its headline ΔV is over the first impact, its total over the run is zero (at rest again)
    one = lsc.solve(lsc.Scene.load(sc).with_values({"vehicles.0.speed": speeds[0]}))
    assert len(one.impacts) >= 2 and one.delta_v[1] > 0
    assert one.delta_v_total[1] == 0.0


SPEED = "vehicles.0.speed"


@pytest.mark.parametrize("values, message", [
    ([True, False], "sweep values must be numbers (or strings with units), got True"),
    (np.array([1.0, 2.0]) > 1.5, "sweep values must be numbers (or strings with units), got False"),
    ([5.0, None], "sweep values must be numbers (or strings with units), got None"),
    ([5.0, 1j], "sweep values must be numbers (or strings with units), got 1j"),
    ((v for v in [5.0, 6.0]), "sweep values must be a list, tuple or 1-D array of numbers (or "
                              "strings with units), got a generator (make it a list first: "
                              "list(...))"),
    ({5.0, 6.0}, "sweep values must be a list, tuple or 1-D array of numbers (or strings with "
                 "units), got a set"),
    (5.0, "sweep values must be a list, tuple or 1-D array of numbers (or strings with units), "
          "got a float"),
])
def test_sweep_values_that_are_not_numbers_are_refused(values, message):
    # (booleans used to be swept as 1 and 0, None as NaN; a generator raised a TypeError)
    with pytest.raises(lsc.SceneError) as e:
        lsc.sweep(PAPER, {SPEED: values})
    assert e.value.path == SPEED and str(e.value) == f"{SPEED}: {message}"


def test_sweep_accepts_lists_tuples_ranges_and_numpy_numbers():
    for values in ([4, 6.0], (4, 6.0), range(4, 7, 2), np.array([4, 6]), [np.float32(4), "6 ft/s"]):
        s = lsc.sweep(PAPER, {SPEED: values})
        assert list(s.params[SPEED]) == [4.0, 6.0] and np.all(s.ok)


def test_huge_grid_is_refused_up_front():
    axis = np.linspace(1.0, 2.0, 100_000)
    with pytest.raises(lsc.SceneError) as e:
        lsc.sweep(PAPER, {SPEED: axis, "contacts.0.unloading.restitution": axis / 2}, grid=True)
    assert str(e.value) == ("params: 10000000000 members are more than the 10000000 one study "
                            "solves (every member's metrics are held in memory at once): split "
                            "it into smaller ones")


def test_unknown_keyword_and_bad_sweep_settings_are_refused():
    with pytest.raises(lsc.SceneError) as e:
        lsc.sweep(PAPER, {SPEED: [4.0]}, rtoll=1e-13)
    assert str(e.value) == ("rtoll: sweep() got an unknown keyword 'rtoll'; it accepts method, "
                            "grid, progress, chunk, workers, metrics, out, overwrite, executor, "
                            "task_size and the solver options atol, dt, "
                            "first_step, integrator, max_events, max_steps, n_samples, rtol, t_end")
    for kw, message in [({"chunk": 0}, "chunk: chunk must be a positive integer, got 0"),
                        ({"workers": 1.5}, "workers: workers must be a positive integer, got 1.5"),
                        ({"grid": 1}, "grid: grid must be True or False, got 1")]:
        with pytest.raises(lsc.SceneError) as e:
            lsc.sweep(PAPER, {SPEED: [4.0]}, **kw)
        assert str(e.value) == message


def test_exact_sweep_without_a_bar_imports_no_integrator_and_no_tqdm():
    """A fresh process's exact sweep with ``progress=False`` loads only what its path needs: not
    SciPy's integrators (other backends' declarations) nor tqdm (the bar it does not show);
    together they tripled the first sweep's wall time."""
    code = ("import sys, numpy as np, lsc; "
            "scene = {'vehicles': [{'mass': 1000, 'speed': 3}, {'mass': 1200, 'speed': 0}], "
            "'contacts': [{'loading': {'stiffness': 1e5}, 'unloading': {'restitution': 0.5}}]}; "
            "s = lsc.sweep(scene, {'vehicles.0.speed': np.linspace(1, 5, 10)}, method='exact', "
            "progress=False); "
            "assert s.method == 'exact' and s.ok.all(); "
            "print(' '.join(m for m in ('scipy.integrate', 'tqdm') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=subprocess_env())
    assert out.stdout.strip() == ""
