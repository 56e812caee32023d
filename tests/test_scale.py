"""Studies at any size (issue 16): chunks, Parquet, executors, Dask.

Every member's numbers must be the same, bit for bit, whatever the chunking, the executor
(this process, a process pool, a Dask cluster) and whether the study is held in memory or
written to Parquet; a chunk whose worker dies is recomputed, not lost.
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import lsc
from lsc.analysis import monte_carlo
from lsc.outputs import OutputExistsError
from lsc.result import METRICS

from conftest import PAPER

pytest.importorskip("pyarrow")

SPEED = "vehicles.0.speed"
E = "contacts.0.unloading.restitution"
UNCERTAIN = {SPEED: {"uniform": ["1 ft/s", "9 ft/s"]},
             E: {"normal": [0.4, 0.1], "min": 0.05, "max": 0.9}}


def _members(n, seed=7):
    """Speeds from -1 ft/s (some members do not close: invalid, with the loader's message)."""
    rng = np.random.default_rng(seed)
    return {SPEED: rng.uniform(-1.0, 9.0, n), E: rng.uniform(0.05, 0.95, n)}


def assert_same_members(a, b, names=None):
    """Every member of two studies has the same status and, bit for bit, the same metrics."""
    np.testing.assert_array_equal(np.asarray(a.status, str), np.asarray(b.status, str))
    for name in names or METRICS:
        np.testing.assert_array_equal(a.metrics[name], b.metrics[name], err_msg=name)


@pytest.fixture(scope="module")
def reference():
    """The study held in memory in one task: what every other way of running it must give."""
    params = _members(600)
    return params, lsc.sweep(PAPER, params, method="exact", progress=False, task_size=600)


# --------------------------------------------------------------------------- chunks
@pytest.mark.parametrize("method", ["exact", "closed-form"])
def test_members_do_not_depend_on_the_chunking(method):
    params = _members(500)
    whole = lsc.sweep(PAPER, params, method=method, progress=False, task_size=500)
    assert not whole.ok.all() and whole.ok.any()   # both kinds of member are in the study
    for size in (1, 37, 128):
        assert_same_members(lsc.sweep(PAPER, params, method=method, progress=False,
                                      task_size=size), whole)


def test_member_loop_in_chunks_matches_single_solves():
    params = {k: v[:12] for k, v in _members(12).items()}
    s = lsc.sweep(PAPER, params, method="scipy", rtol=1e-10, progress=False, task_size=5)
    for j in range(12):
        member = {p: float(v[j]) for p, v in params.items()}
        try:
            r = lsc.solve(lsc.Scene.load(PAPER).with_values(member), method="scipy", rtol=1e-10)
        except lsc.SceneError as e:
            assert s.status[j] == f"SceneError: {e}"
            continue
        assert s.status[j] == "ok"
        np.testing.assert_array_equal(s.delta_v[j], r.delta_v)


def test_a_grid_built_per_chunk_is_the_meshgrid():
    speeds, es = np.linspace(2.0, 8.0, 7), np.array([0.1, 0.4, 0.7])
    s = lsc.sweep(PAPER, {SPEED: speeds, E: es}, grid=True, method="closed-form",
                  progress=False, task_size=4)
    mesh = np.meshgrid(speeds, es, indexing="ij")
    np.testing.assert_array_equal(s.params[SPEED], mesh[0].ravel())
    np.testing.assert_array_equal(s.params[E], mesh[1].ravel())
    m1, m2 = 3500 / 32.2, 3500 / 32.2   # the paper's cars: closed form dV2 = (1+e) m1 v0/(m1+m2)
    dv2 = (1 + mesh[1]) * m1 * mesh[0] / (m1 + m2)
    np.testing.assert_allclose(s.delta_v.reshape(7, 3, 2)[..., 1], dv2, rtol=1e-12)


def test_metrics_keeps_only_those_named():
    s = lsc.sweep(PAPER, {SPEED: [4.0, 6.0]}, method="closed-form", progress=False,
                  metrics=["duration", "delta_v"])
    assert set(s.metrics) == {"delta_v", "duration"}
    assert [c for c in s.columns() if not c.startswith(SPEED)] == [
        "delta_v[bullet] (ft/s)", "delta_v[target] (ft/s)", "duration (s)", "status", "warnings"]


def test_bad_study_settings_are_refused_by_name():
    cases = [({"metrics": ["delta_v", "speed"]},
              "metrics: unknown metric 'speed'; the metrics are " + ", ".join(METRICS)),
             ({"executor": 4}, "executor: executor must be a concurrent.futures.Executor (a "
                               "ProcessPoolExecutor, a dask.distributed.Client: anything with "
                               "submit), or None; got int"),
             ({"task_size": 0}, "task_size: task_size must be a positive integer, got 0")]
    for kw, message in cases:
        with pytest.raises(lsc.SceneError) as e:
            lsc.sweep(PAPER, {SPEED: [4.0]}, progress=False, **kw)
        assert str(e.value) == message


# --------------------------------------------------------------------------- Parquet
def test_parquet_out_holds_every_member_one_row_group_per_chunk(tmp_path, reference):
    import pyarrow.parquet as pq

    params, whole = reference
    f = lsc.sweep(PAPER, params, method="exact", progress=False, task_size=250,
                  out=tmp_path / "s.parquet")
    assert pq.ParquetFile(f.path).metadata.num_row_groups == 3          # 250 + 250 + 100
    assert_same_members(f, whole)
    assert f.stats["members"] == 600 and f.stats["failed"] == int(np.sum(~whole.ok))
    assert sum(f.reasons.values()) == f.stats["failed"]
    df = f.to_dataframe()
    assert list(df.index) == list(range(600))
    np.testing.assert_array_equal(df[f"{SPEED} (ft/s)"], params[SPEED])
    assert df.attrs["method"] == "exact" and df.attrs["shape"] == [600]


def test_parquet_out_refuses_an_existing_file_and_is_written_whole(tmp_path):
    out = tmp_path / "s.parquet"
    out.write_text("an earlier run")
    with pytest.raises(OutputExistsError):
        lsc.sweep(PAPER, {SPEED: [4.0, 5.0]}, method="exact", progress=False, out=out)
    assert out.read_text() == "an earlier run"

    class Broken:                       # an executor whose second chunk fails
        def __init__(self):
            self.calls = 0

        def submit(self, fn, *args):
            from concurrent.futures import Future
            self.calls += 1
            future = Future()
            if self.calls == 2:
                future.set_exception(OSError("worker lost"))
            else:
                future.set_result(fn(*args))
            return future

    with pytest.raises(OSError, match="worker lost"):
        lsc.sweep(PAPER, {SPEED: [4.0, 5.0, 6.0]}, method="exact", progress=False, out=out,
                  overwrite=True, executor=Broken(), task_size=1)
    assert out.read_text() == "an earlier run"               # nothing half-written
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.parquet"]
    f = lsc.sweep(PAPER, {SPEED: [4.0, 5.0]}, method="exact", progress=False, out=out,
                  overwrite=True)
    assert f.stats["members"] == 2 and f.ok.all()


# --------------------------------------------------------------------------- executors
def test_process_pool_gives_the_in_process_members(reference):
    params, whole = reference
    with ProcessPoolExecutor(2) as pool:
        s = lsc.sweep(PAPER, params, method="exact", progress=False, executor=pool,
                      task_size=97)
    assert_same_members(s, whole)


def _die_once(marker: str, fn, *args):
    """Run ``fn(*args)``, except the first time (no ``marker`` file yet): kill this worker."""
    if not os.path.exists(marker):
        Path(marker).touch()
        os._exit(1)
    return fn(*args)


class DieOnce:
    """A Dask client whose first task kills the worker process it runs on."""

    def __init__(self, client, marker):
        self.client, self.marker = client, str(marker)

    def submit(self, fn, *args, **kwargs):
        return self.client.submit(_die_once, self.marker, fn, *args, **kwargs)

    def __getattr__(self, name):
        return getattr(self.client, name)


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("distributed")
    import cloudpickle
    import sys

    cloudpickle.register_pickle_by_value(sys.modules[__name__])   # _die_once on the workers
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        yield client


def test_dask_cluster_gives_the_in_process_members(dask_client, reference):
    params, whole = reference
    s = lsc.sweep(PAPER, params, method="exact", progress=False, executor=dask_client,
                  task_size=61)
    assert_same_members(s, whole)


def test_a_chunk_whose_worker_dies_is_recomputed(dask_client, reference, tmp_path):
    params, whole = reference
    marker = tmp_path / "died"
    s = lsc.sweep(PAPER, params, method="exact", progress=False, task_size=150,
                  executor=DieOnce(dask_client, marker), out=tmp_path / "s.parquet")
    assert marker.exists()              # a worker did die, and its chunk was solved again
    assert_same_members(s, whole)


# --------------------------------------------------------------------------- Monte Carlo
def test_streamed_monte_carlo_does_not_depend_on_chunks_or_executor(tmp_path):
    kw = dict(seed=11, method="exact", progress=False)
    one = monte_carlo(PAPER, UNCERTAIN, 9000, out=tmp_path / "a.parquet", task_size=9000, **kw)
    with ProcessPoolExecutor(2) as pool:
        many = monte_carlo(PAPER, UNCERTAIN, 9000, out=tmp_path / "b.parquet", task_size=1000,
                           executor=pool, **kw)
    for path in UNCERTAIN:
        np.testing.assert_array_equal(one.samples[path], many.samples[path])
    assert_same_members(one.sweep, many.sweep, names=one.sweep.names)
    for name, p in one.percentiles.items():
        np.testing.assert_array_equal(p, many.percentiles[name])
    # exact percentiles: those of every solved member's values
    dv = one.sweep.metrics["delta_v"][one.ok]
    np.testing.assert_array_equal(one.percentiles["delta_v"], np.percentile(dv, one.q, axis=0))
    # the samples follow their distributions (9000 members: 3 standard errors)
    speeds = one.samples[SPEED]
    assert abs(speeds.mean() - 5.0) < 3 * (8 / np.sqrt(12)) / np.sqrt(9000)


@pytest.mark.parametrize("sampling, seed, n, method, task_size",
                         [("sobol", 5, 4096, "exact", 1000), ("lhs", 8, 5000, "closed-form", 999)])
def test_streamed_designs_are_the_in_memory_ones(tmp_path, sampling, seed, n, method, task_size):
    kw = dict(seed=seed, sampling=sampling, method=method, progress=False)
    held = monte_carlo(PAPER, UNCERTAIN, n, **kw)
    streamed = monte_carlo(PAPER, UNCERTAIN, n, out=tmp_path / "m.parquet", task_size=task_size,
                           **kw)
    for path in UNCERTAIN:
        np.testing.assert_array_equal(streamed.samples[path], held.samples[path])
    for name, p in held.percentiles.items():
        np.testing.assert_array_equal(streamed.percentiles[name], p)
    if sampling == "sobol":
        assert streamed.summary() == held.summary()


def test_in_memory_monte_carlo_keeps_the_samples_of_sample(reference):
    from lsc.analysis import sample

    with ProcessPoolExecutor(2) as pool:
        mc = monte_carlo(PAPER, UNCERTAIN, 3000, seed=2, method="exact", progress=False,
                         executor=pool)
    drawn = sample(PAPER, UNCERTAIN, 3000, seed=2)
    for path in UNCERTAIN:
        np.testing.assert_array_equal(mc.samples[path], drawn[path])
    ref = lsc.sweep(PAPER, drawn, method="exact", progress=False)
    assert_same_members(mc.sweep, ref)


# --------------------------------------------------------------------------- the CLI
def test_cli_mc_streams_to_parquet_on_worker_processes(tmp_path, capsys):
    import lsc.cli
    import pandas as pd

    u = tmp_path / "u.toml"
    u.write_text('"vehicles.0.speed" = { uniform = ["1 ft/s", "9 ft/s"] }\n')
    out = tmp_path / "mc.parquet"
    argv = ["mc", "default", "--uncertainty", str(u), "--n", "5000", "--method", "exact",
            "--no-progress", "--out", str(out), "--workers", "2", "--metrics", "delta_v"]
    assert lsc.cli.main(argv) == 0
    printed = capsys.readouterr().out
    api = monte_carlo(lsc.cli.resolve_scene("default"), {SPEED: {"uniform": ["1 ft/s", "9 ft/s"]}}, 5000, seed=0,
                      method="exact", progress=False, out=tmp_path / "api.parquet",
                      metrics=["delta_v"])
    assert printed == api.summary() + f"\n\nwritten to {out}\n"
    pd.testing.assert_frame_equal(pd.read_parquet(out), api.sweep.to_dataframe())
    assert lsc.cli.main(argv) == 2                               # an earlier run's file
    assert "already exists" in capsys.readouterr().err


def test_cli_refuses_study_options_that_do_not_fit(tmp_path, capsys):
    import lsc.cli

    base = ["sweep", "--param", "vehicles.0.speed=2:8:3", "--out", str(tmp_path / "d")]
    assert lsc.cli.main(base + ["--metrics", "delta_v"]) == 2
    assert capsys.readouterr().err.strip() == (
        "lsc: error: --metrics: --metrics selects the columns of --out FILE.parquet; give one "
        "(or leave --metrics out)")
    assert lsc.cli.main(base + ["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "a running cluster (--scheduler) has the workers it was started with" in \
        capsys.readouterr().err
    assert not (tmp_path / "d").exists()
