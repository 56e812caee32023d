"""lsc.analysis.global_sensitivity: Sobol' indices of the closed form's ΔV against an independent
pick-freeze estimate, zero indices for an input the metric does not depend on, the table, the
chart, the CSV and ``lsc sensitivity --global``."""

import subprocess
import sys

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd
import pytest

import lsc
import lsc.cli
from conftest import paper_scene
from lsc.analysis import global_sensitivity
from lsc.analysis.cli import load_with_uncertainty

G = 32.2  # the paper scene's g [ft/s²]
E = 0.4   # its restitution
INPUTS = {"vehicles.0.speed": {"uniform": [4, 8]},              # ft/s
          "vehicles.0.weight": {"uniform": [3000, 4000]},       # lbf
          "vehicles.1.weight": {"normal": [3500, 400]},         # lbf
          "contacts.0.loading.stiffness": {"uniform": [20000, 30000]}}  # lbf/ft: no effect on ΔV


def _delta_v_target(x):
    """The closed form ΔV2 = (1+e) m1 v0 / (m1+m2) [ft/s] of columns (v0, W1, W2, k)."""
    v0, w1, w2 = x[:, 0], x[:, 1], x[:, 2]
    return (1 + E) * (w1 / G) * v0 / ((w1 + w2) / G)


def _pick_freeze(f, draw, n, rng):
    """Sobol' S1 (Saltelli 2010) and ST (Jansen) of ``f`` by plain Monte Carlo: two independent
    samples A, B (n, d) and, per input i, A with column i taken from B."""
    a, b = draw(rng, n), draw(rng, n)
    fa, fb = f(a), f(b)
    var = np.var(np.concatenate([fa, fb]))
    s1, st = [], []
    for i in range(a.shape[1]):
        ab = a.copy()
        ab[:, i] = b[:, i]
        fab = f(ab)
        s1.append(np.mean(fb * (fab - fa)) / var)
        st.append(0.5 * np.mean((fa - fab) ** 2) / var)
    return np.array(s1), np.array(st)


def _draw(rng, n):
    return np.column_stack([rng.uniform(4, 8, n), rng.uniform(3000, 4000, n),
                            rng.normal(3500, 400, n), rng.uniform(20000, 30000, n)])


@pytest.fixture(scope="module")
def gsa():
    return global_sensitivity(paper_scene(), INPUTS, metrics=["delta_v", "duration"], n=2048,
                              seed=0)


def test_indices_of_delta_v_match_an_independent_pick_freeze_estimate(gsa):
    """10^6-member pick-freeze estimates (standard error ~1e-3) of ΔV2's indices lie within the
    SALib bootstrap intervals (plus that error) of the lsc result."""
    s1, st = _pick_freeze(_delta_v_target, _draw, 1_000_000, np.random.default_rng(1))
    rows = gsa.table[gsa.table["metric"] == "delta_v[target]"]
    assert list(rows["input"]) == list(INPUTS)
    assert np.all(np.abs(rows["S1"].to_numpy() - s1) <= rows["S1_conf"].to_numpy() + 3e-3)
    assert np.all(np.abs(rows["ST"].to_numpy() - st) <= rows["ST_conf"].to_numpy() + 3e-3)
    assert s1[0] > 0.8 and s1[1] > 0.02 and s1[2] > 0.02  # (every input but k matters)


def test_an_input_the_metric_does_not_depend_on_gets_zero_indices(gsa):
    """ΔV does not depend on the stiffness; the duration π/(2ω)(1+e) does not depend on the
    speed: both indices are zero within their intervals."""
    for metric, path in (("delta_v[target]", "contacts.0.loading.stiffness"),
                         ("delta_v[bullet]", "contacts.0.loading.stiffness"),
                         ("duration", "vehicles.0.speed")):
        row = gsa.table[(gsa.table["metric"] == metric) & (gsa.table["input"] == path)].iloc[0]
        assert abs(row.S1) <= row.S1_conf + 1e-12 and abs(row.ST) <= row.ST_conf + 1e-12
    dur = gsa.table[gsa.table["metric"] == "duration"]
    assert dur["ST"].max() == dur.set_index("input")["ST"]["contacts.0.loading.stiffness"]


def test_table_summary_and_reproducibility(gsa):
    assert list(gsa.table.columns) == ["input", "metric", "S1", "S1_conf", "ST", "ST_conf"]
    assert gsa.metrics == ["delta_v[bullet]", "delta_v[target]", "duration"]
    assert gsa.sweep.status.size == 2048 * (4 + 2) and gsa.sweep.method == "closed-form"
    again = global_sensitivity(paper_scene(), INPUTS, metrics=["delta_v", "duration"], n=2048,
                               seed=0)
    pd.testing.assert_frame_equal(gsa.table, again.table)  # (seed 0 included: bootstrap too)
    text = gsa.summary()
    assert "2048 base samples x (4 inputs + 2) = 12288 solves (seed 0)" in text


def test_csv_round_trip_and_refusal(gsa, tmp_path):
    f = gsa.to_csv(tmp_path / "sobol.csv")
    pd.testing.assert_frame_equal(pd.read_csv(f), gsa.table)
    with pytest.raises(lsc.outputs.OutputExistsError):
        gsa.to_csv(f)


def test_plot_draws_both_indices_with_their_intervals(gsa, tmp_path):
    fig = gsa.plot()
    assert len(fig.axes) == len(gsa.metrics)
    fig = gsa.plot("duration")
    bars = [p.get_width() for p in fig.axes[0].patches]
    rows = gsa.table[gsa.table["metric"] == "duration"]
    np.testing.assert_array_equal(bars, [*rows["S1"], *rows["ST"]])
    assert gsa.plot(file=tmp_path / "s.png").stat().st_size > 1000


def test_correlated_inputs_are_refused():
    d = {"vehicles.0.speed": {"uniform": [4, 8]}, "vehicles.1.weight": {"uniform": [3000, 4000]},
         "correlation": [[1, 0.5], [0.5, 1]]}
    with pytest.raises(lsc.SceneError) as e:
        global_sensitivity(paper_scene(), d, n=16, seed=0)
    assert e.value.path == "uncertainty.correlation"
    assert "independent inputs" in str(e.value)


def test_failed_members_raise_instead_of_being_dropped():
    with pytest.raises(lsc.SimulationError, match=r"members of the Sobol' design could not be "
                                                  r"solved .*the indices need every member"):
        global_sensitivity(paper_scene(), {"contacts.0.unloading.restitution":
                                           {"normal": [0.9, 0.2]}}, n=64, seed=0)


@pytest.mark.parametrize("metrics, message", [
    (["delta_vee"], "metrics: unknown metric 'delta_vee'; accepted: "),
    (["duration"], "metrics: duration is the same for every member (no variance to apportion): "
                   "leave it out"),
])
def test_bad_or_constant_metric_is_refused(metrics, message):
    with pytest.raises(lsc.SceneError) as e:
        global_sensitivity(paper_scene(), {"vehicles.0.speed": {"uniform": [4, 8]}},
                           metrics=metrics, n=16, seed=0)
    assert str(e.value).startswith(message)


def test_sobol_count_not_a_power_of_two_warns():
    with pytest.warns(UserWarning, match="n = 100 is not a power of two"):
        g = global_sensitivity(paper_scene(), {"vehicles.0.speed": {"uniform": [4, 8]},
                                               "vehicles.1.weight": {"uniform": [3000, 4000]}},
                               metrics=["delta_v"], n=100, seed=0)
    assert g.sweep.status.size == 100 * 4


def test_import_lsc_does_not_import_salib():
    code = "import lsc, lsc.analysis, sys; print('SALib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


SCENE = """
name = "gsa"
units = "US"
g = "32.2 ft/s^2"
[[vehicles]]
name = "bullet"
weight = 3500
speed = 5
[[vehicles]]
name = "target"
weight = 3500
speed = 0
[[contacts]]
loading = { stiffness = 24000 }
unloading = { restitution = 0.4 }
[uncertainty]
"vehicles.0.speed" = { uniform = ["4 ft/s", "8 ft/s"] }
"contacts.0.loading.stiffness" = { uniform = [20000, 30000] }
"""


def test_cli_global_writes_the_table_and_the_chart(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(SCENE)
    out = tmp_path / "out"
    assert lsc.cli.main(["sensitivity", str(f), "--global", "--samples", "64", "--metrics",
                         "delta_v", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "64 base samples x (2 inputs + 2) = 256 solves (seed 0)" in text
    table = pd.read_csv(out / "sobol.csv")
    scene, dists = load_with_uncertainty(str(f))
    expected = global_sensitivity(scene, dists, metrics=["delta_v"], n=64, seed=0).table
    pd.testing.assert_frame_equal(table, expected)
    assert (out / "sobol.png").stat().st_size > 1000
    assert lsc.cli.main(["sensitivity", str(f), "--global", "--samples", "64", "--out",
                         str(out)]) == 2  # the files exist: refused without --overwrite


@pytest.mark.parametrize("argv, message", [
    (["--global", "--json", "x.json"], "json: --json is an option of the derivative sensitivity"),
    (["--global", "--params", "vehicles.0.speed"], "params: --params is an option of the "
                                                   "derivative sensitivity"),
    (["--samples", "64"], "samples: --samples is an option of --global"),
    (["--out", "d"], "out: --out is an option of --global"),
    (["--no-plots"], "no-plots: --no-plots is an option of --global"),
])
def test_cli_options_of_the_other_analysis_are_refused(tmp_path, capsys, argv, message):
    f = tmp_path / "s.toml"
    f.write_text(SCENE)
    assert lsc.cli.main(["sensitivity", str(f), *argv]) == 2
    assert message in capsys.readouterr().err
