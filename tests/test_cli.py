"""The ``lsc`` command line: outputs of ``lsc run`` checked against independently computed
physics, exit statuses and the one-line error contract."""

import contextlib
import io
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import lsc
import lsc.plots
from lsc.cli import main
from helpers import (files_in as _files, no_space as _no_space, subprocess_env as _env,
                     summary_row as _row)

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

# The packaged default scene, by hand: the paper's study 1 at e = 0.4 (US units, g = 32.2).
G, W, V0, E, K = 32.2, 3500.0, 10.0, 0.4, 24000.0
M = W / G
DV2 = (1 + E) * M * V0 / (M + M)            # ΔV = (1+e) m v0 / (m1+m2): 7.0 ft/s
DV1 = -DV2
MU = M * M / (M + M)
DURATION = np.pi / 2 * np.sqrt(MU / K) * (1 + E)   # π/(2ω)(1+e) = 0.10465 s
F_PEAK = V0 * np.sqrt(K * MU)


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    """``lsc run --out DIR`` once for the module: (exit status, stdout, stderr, out dir)."""
    out = tmp_path_factory.mktemp("run") / "out"
    so, se = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(so), contextlib.redirect_stderr(se):
        rc = main(["run", "--out", str(out)])
    return rc, so.getvalue(), se.getvalue(), out


def test_run_default_exits_0_and_prints_delta_v(default_run):
    rc, stdout, stderr, _ = default_run
    assert rc == 0
    assert stderr == ""
    assert DV1 == pytest.approx(-7.0) and DV2 == pytest.approx(7.0)
    bullet, target = _row(stdout, "bullet"), _row(stdout, "target")
    # columns: name, v0, v_final, delta_v, peak a, peak a [g]
    assert float(bullet[3]) == pytest.approx(DV1, abs=5e-5)
    assert float(target[3]) == pytest.approx(DV2, abs=5e-5)
    assert f"{DV1:.4f}" in bullet and f"{DV2:.4f}" in target
    assert "Paper, parametric study 1, e = 0.4" in stdout


def test_run_series_csv(default_run):
    _, _, _, out = default_run
    text = (out / "series.csv").read_text().splitlines()
    header = text[0].split(",")
    assert header[0] == "t (s)"
    for col in ("v[bullet] (ft/s)", "v[target] (ft/s)", "a[target] (ft/s^2)",
                "deformation[0] (ft)", "force[0] (lbf)"):
        assert col in header
    data = np.loadtxt(out / "series.csv", delimiter=",", skiprows=1)
    assert data.shape[1] == len(header) and data.shape[0] > 100
    t = data[:, header.index("t (s)")]
    assert np.all(np.diff(t) >= 0)
    v_last = data[-1, [header.index("v[bullet] (ft/s)"), header.index("v[target] (ft/s)")]]
    assert v_last == pytest.approx([V0 + DV1, DV2], abs=1e-9)
    assert t[-1] == pytest.approx(DURATION, rel=1e-9)
    assert data[:, header.index("force[0] (lbf)")].max() == pytest.approx(F_PEAK, rel=1e-6)


def test_run_summary_json(default_run):
    _, _, _, out = default_run
    js = json.loads((out / "summary.json").read_text())
    m = js["metrics"]
    assert m["delta_v"] == pytest.approx([DV1, DV2], abs=1e-9)
    assert m["v_final"] == pytest.approx([V0 + DV1, DV2], abs=1e-9)
    assert m["duration"] == pytest.approx(DURATION, rel=1e-9)
    assert m["peak_force"] == pytest.approx([F_PEAK], rel=1e-9)
    assert m["restitution"] == pytest.approx([E], abs=1e-9)
    assert js["units"]["delta_v"] == "ft/s" and js["units"]["peak_force"] == "lbf"
    assert js["vehicles"] == ["bullet", "target"]
    assert js["input"] == "default" and js["lsc_version"] == lsc.__version__
    assert [e["kind"] for e in js["events"]][-1] == "separation"


@pytest.mark.parametrize("name", ["acceleration.png", "velocity.png", "ifd.png"])
def test_run_writes_png(default_run, name):
    _, _, _, out = default_run
    f = out / name
    assert f.is_file() and f.stat().st_size > 1000
    assert f.read_bytes()[:8] == PNG_MAGIC


def _run(args, capsys):
    rc = main(args)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


BAD_SCENE = """\
units = "US"
[[vehicles]]
weight = 3500
speed  = 10
[[vehicles]]
{field} = {value}
speed  = 0
[[contacts]]
loading   = {{ stiffness = 24000 }}
unloading = {{ restitution = 0.4 }}
"""


@pytest.mark.parametrize("field, value, path", [
    ("weight", '"heavy"', "vehicles[1].weight"),
    ("weight", '"10 ft"', "vehicles[1].weight"),      # wrong dimension
    ("wieght", "3500", "vehicles[1]"),                 # misspelt key
])
def test_bad_scene_exits_2_with_one_line(tmp_path, capsys, field, value, path):
    f = tmp_path / "bad.toml"
    f.write_text(BAD_SCENE.format(field=field, value=value))
    rc, out, err = _run(["run", str(f), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2
    assert out == ""
    assert err.count("\n") == 1 and err.endswith("\n")
    assert err.startswith(f"lsc: error: {path}")
    assert not (tmp_path / "o").exists(), "nothing is written for a bad scene"


def test_missing_file_and_unknown_name_exit_2(tmp_path, capsys):
    rc, _, err = _run(["run", str(tmp_path / "nope.toml")], capsys)
    assert rc == 2 and err.count("\n") == 1 and "nope.toml" in err
    rc, _, err = _run(["run", "tabel1", "--out", str(tmp_path)], capsys)
    assert rc == 2 and err.count("\n") == 1 and "'table1'" in err  # did you mean


def test_bad_option_exits_2(tmp_path, capsys):
    rc, _, err = _run(["run", "table1", "--rtol", "1e-9", "--out", str(tmp_path)], capsys)
    assert rc == 2 and err.count("\n") == 1 and err.startswith("lsc: error: solver.rtol")
    assert main(["run", "--dt", "-1"]) == 2  # argparse rejects it before any solve


def test_simulation_error_exits_1(tmp_path, capsys):
    # a table that ends before the common velocity (the paper's unscaled crash-test curves)
    f = tmp_path / "short.toml"
    f.write_text(BAD_SCENE.format(field="weight", value="3500").replace(
        "{ stiffness = 24000 }", "{ table = [[0, 0], [0.1, 1000]] }"))
    rc, out, err = _run(["run", str(f), "--out", str(tmp_path / "o")], capsys)
    assert rc == 1
    assert err.count("\n") == 1 and err.startswith("lsc: error: ")
    assert "common velocity" in err


def test_method_and_options_pass_through(tmp_path, capsys):
    out = tmp_path / "o"
    rc, stdout, _ = _run(["run", "default", "--method", "reference", "--dt", "1e-4",
                          "--no-plots", "--out", str(out)], capsys)
    assert rc == 0
    js = json.loads((out / "summary.json").read_text())
    assert js["method"] == "reference" and js["tolerances"]["dt"] == 1e-4
    # the paper's first-order algorithm: ΔV off by about 1e-3 relative at dt = 1e-4, not exact
    err = abs(js["metrics"]["delta_v"][1] - DV2) / DV2
    assert 1e-4 < err < 1e-2
    assert sorted(p.name for p in out.iterdir()) == ["series.csv", "summary.json"]


def test_run_table1_reproduces_the_paper_row(tmp_path, capsys):
    """Table 1, dt = 1e-5: duration 0.1495 s, V1* = -0.001, V2* = 10.001 ft/s."""
    out = tmp_path / "t1"
    rc, stdout, _ = _run(["run", "table1", "--no-plots", "--out", str(out)], capsys)
    assert rc == 0
    js = json.loads((out / "summary.json").read_text())
    assert js["method"] == "reference" and js["tolerances"]["dt"] == 1e-5
    m = js["metrics"]
    assert f"{m['duration']:.4f}" == "0.1495"
    assert f"{m['v_final'][0]:.3f}" == "-0.001"
    assert f"{m['v_final'][1]:.3f}" == "10.001"
    assert "pulse duration 0.1495 s" in stdout


def test_scenes_lists_the_packaged_scenes(capsys):
    rc, out, _ = _run(["scenes"], capsys)
    assert rc == 0
    listed = [line.split()[0] for line in out.splitlines()]
    assert listed == lsc.data.names()
    assert {"default", "table1", "table3", "study1_restitution", "study2_stiffness",
            "study3_speed"} <= set(listed)


def test_packaged_scenes_match_the_paper():
    """Each packaged scene's base and swept values give the paper's numbers."""
    from lsc import data
    s = data.load("default")
    assert s.units == "US" and s.g == 32.2 and list(s.masses) == pytest.approx([M, M])
    assert data.load("table3").contacts[0].law.loading.stiffness == pytest.approx(
        1 / (1 / 48000 + 1 / 30000))
    forces = [lsc.solve(data.paper_scene("table3", v)).peak_force[0]
              for v in data.STUDIES["table3"]["vehicles.0.speed"]]
    assert forces == pytest.approx([4007, 5009, 6011], abs=2)
    d0, d1 = (lsc.solve(data.paper_scene("study1_restitution", e)).duration for e in (0.0, 1.0))
    assert d0 == pytest.approx(DURATION / (1 + E), rel=1e-9)  # π/(2ω): the paper's 0.0748 s
    assert f"{d1:.4f}" == "0.1495"


def test_python_dash_m_lsc(tmp_path):
    env = _env()
    p = subprocess.run([sys.executable, "-m", "lsc", "run", "--no-plots"], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert f"{DV2:.4f}" in _row(p.stdout, "target")
    js = json.loads((tmp_path / "lsc-out" / "summary.json").read_text())  # default --out
    assert js["metrics"]["delta_v"] == pytest.approx([DV1, DV2], abs=1e-9)
    p = subprocess.run([sys.executable, "-m", "lsc", "run", "nosuchscene"], cwd=tmp_path,
                       env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 2 and p.stderr.count("\n") == 1


# --------------------------------------------------------------------------- output files
def _exists_error(*paths) -> str:
    return (f"lsc: error: {', '.join(map(str, paths))} already exist"
            f"{'s' if len(paths) == 1 else ''} (the results of an earlier run): pass "
            "--overwrite to replace them, or write elsewhere\n")


def test_a_second_run_is_refused_before_solving_and_overwrite_replaces(tmp_path, capsys):
    out = tmp_path / "o"
    assert _run(["run", "default", "--no-plots", "--out", str(out)], capsys)[0] == 0
    first = _files(out)
    assert sorted(first) == ["series.csv", "summary.json"]
    rc, stdout, err = _run(["run", "table3", "--no-plots", "--out", str(out)], capsys)
    assert (rc, stdout) == (2, "")  # refused before the solve: no summary printed
    assert err == _exists_error(out / "series.csv", out / "summary.json")
    assert _files(out) == first
    rc, stdout, _ = _run(["run", "table3", "--no-plots", "--out", str(out), "--overwrite"], capsys)
    assert rc == 0 and f"written to {out}/: series.csv, summary.json" in stdout
    assert sorted(_files(out)) == ["series.csv", "summary.json"]
    js, js0 = json.loads((out / "summary.json").read_text()), json.loads(first["summary.json"])
    assert js0["input"] == "default" and js["input"] == "table3"
    assert js["metrics"]["peak_force"] != js0["metrics"]["peak_force"]
    assert (out / "series.csv").read_bytes() != first["series.csv"]


def test_a_failing_figure_leaves_the_earlier_run_intact(tmp_path, capsys, monkeypatch):
    """The last file fails: none of the new ones is written, the earlier ones stay byte for byte;
    a --no-plots run with --overwrite then removes the earlier figures (no mixed folder)."""
    out = tmp_path / "o"
    assert _run(["run", "default", "--out", str(out)], capsys)[0] == 0
    first = _files(out)
    assert sorted(first) == ["acceleration.png", "ifd.png", "series.csv", "summary.json",
                             "velocity.png"]
    monkeypatch.setattr(lsc.plots, "ifd_loop", _no_space)
    rc, _, err = _run(["run", "table3", "--out", str(out), "--overwrite"], capsys)
    assert rc == 1
    assert err == f"lsc: error: cannot write {out / 'ifd.png'}: No space left on device; " \
                  "nothing was written\n"
    assert _files(out) == first
    rc, _, err = _run(["run", "table3", "--out", str(tmp_path / "new" / "o")], capsys)
    assert rc == 1 and not (tmp_path / "new").exists(), "no folder left behind"
    monkeypatch.undo()
    rc, _, err = _run(["run", "default", "--no-plots", "--out", str(out)], capsys)
    assert rc == 2 and err == _exists_error(out / "series.csv", out / "summary.json",
                                            out / "acceleration.png", out / "velocity.png",
                                            out / "ifd.png")
    assert _run(["run", "table3", "--no-plots", "--out", str(out), "--overwrite"], capsys)[0] == 0
    assert sorted(_files(out)) == ["series.csv", "summary.json"]


def test_a_folder_in_place_of_an_output_file_is_refused(tmp_path, capsys):
    (tmp_path / "series.csv").mkdir()
    rc, stdout, err = _run(["run", "--no-plots", "--out", str(tmp_path), "--overwrite"], capsys)
    assert (rc, stdout) == (1, "")
    assert err == (f"lsc: error: cannot write {tmp_path / 'series.csv'}: a folder is in the way "
                   "of the output file; nothing was written\n")
    assert [p.name for p in tmp_path.iterdir()] == ["series.csv"]


def test_sweep_outputs_all_or_none_and_never_over_an_earlier_sweep(tmp_path, capsys, monkeypatch):
    out = tmp_path / "s"
    sweep = ["sweep", "default", "--param", "vehicles.0.speed=2:12:3", "--out", str(out)]
    assert _run(sweep, capsys)[0] == 0
    first = _files(out)
    assert sorted(first) == ["sweep.csv", "sweep.png"]
    rc, stdout, err = _run(sweep[:3] + ["vehicles.0.speed=2:12:4"] + sweep[4:], capsys)
    assert (rc, stdout) == (2, "") and err == _exists_error(out / "sweep.csv", out / "sweep.png")
    assert _files(out) == first
    monkeypatch.setattr(lsc.plots, "sweep_metric", _no_space)
    rc, _, err = _run(sweep[:3] + ["vehicles.0.speed=2:12:4", "--overwrite"] + sweep[4:], capsys)
    assert rc == 1 and err.startswith(f"lsc: error: cannot write {out / 'sweep.png'}: No space")
    assert _files(out) == first
    monkeypatch.undo()
    assert _run(sweep[:3] + ["vehicles.0.speed=2:12:4", "--overwrite", "--no-plots"]
                + sweep[4:], capsys)[0] == 0
    assert sorted(_files(out)) == ["sweep.csv"]
    assert (out / "sweep.csv").read_text().count("\n") == 5  # header + 4 members


# --------------------------------------------------------------------------- lsc ... | head
@pytest.mark.parametrize("unbuffered", ["1", ""], ids=["unbuffered", "buffered"])
@pytest.mark.parametrize("args", [["run", "--no-plots", "--out", "o"], ["scenes"],
                                  ["bound", "table3", "--failure-force", "5000 lbf"]],
                         ids=["run", "scenes", "bound"])
def test_a_reader_that_stops_early_gets_no_traceback(tmp_path, args, unbuffered):
    """``lsc run | head``: stdout is a pipe whose reader has gone (here closed before lsc
    prints anything, so that every write fails, buffered or not): exit 1, nothing on stderr,
    no partial output."""
    env = _env()
    env["PYTHONUNBUFFERED"] = unbuffered
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        p = subprocess.run([sys.executable, "-m", "lsc", *args], cwd=tmp_path, env=env,
                           stdout=write_end, stderr=subprocess.PIPE, text=True, timeout=300)
    finally:
        os.close(write_end)
    assert p.stderr == ""
    assert p.returncode == 1
    if args[0] == "run" and (tmp_path / "o").exists():
        assert sorted(_files(tmp_path / "o")) == ["series.csv", "summary.json"]


def test_sweep_parquet_is_the_sweeps_table(tmp_path, capsys):
    """``lsc sweep --parquet`` also writes sweep.parquet: the sweep's DataFrame, read back equal."""
    import pandas as pd
    pytest.importorskip("pyarrow")
    out = tmp_path / "s"
    assert lsc.cli.main(["sweep", "--param", "vehicles.0.speed=2:6:3", "--no-plots", "--parquet",
                         "--out", str(out)]) == 0
    table = pd.read_parquet(out / "sweep.parquet")
    expected = lsc.sweep(lsc.data.load("default"), {"vehicles.0.speed": [2.0, 4.0, 6.0]})
    pd.testing.assert_frame_equal(table, expected.to_dataframe(), check_like=True)
    assert "sweep.parquet" in capsys.readouterr().out


@pytest.mark.parametrize("cmd", [["run", "--no-plots"],
                                 ["sweep", "--param", "vehicles.0.speed=5,6", "--no-plots"]])
def test_out_with_a_trailing_slash_is_printed_with_one_slash(tmp_path, capsys, cmd):
    out = f"{tmp_path / 'results'}/"
    rc, stdout, _ = _run([*cmd, "--out", out], capsys)
    assert rc == 0
    assert f"written to {out}: " in stdout and "//" not in stdout
    rc, stdout, _ = _run([*cmd, "--out", out.rstrip("/"), "--overwrite"], capsys)
    assert f"written to {out}: " in stdout
