"""``lsc bound`` and ``lsc mc`` (lsc.analysis.cli), hooked into lsc.cli as the wiring will do."""

import json

import pytest

import lsc.cli
from helpers import files_in as _files, no_space as _no_space

TABLE3 = """
name = "Table 3"
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
loading = { series = [{ stiffness = 48000 }, { stiffness = 30000 }] }
unloading = { restitution = 0.8 }
"""

UNCERTAINTY = """
[uncertainty]
"vehicles.0.speed" = { uniform = ["4 ft/s", "8 ft/s"] }
contacts.0.unloading.restitution = { normal = [0.5, 0.05], min = 0, max = 1 }
"""


@pytest.fixture
def main():
    return lsc.cli.main


def test_bound(main, tmp_path, capsys):
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    out = tmp_path / "b.json"
    assert main(["bound", str(f), "--failure-force", "5000 lbf", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "4.991660" in text and "conservative bound" in text
    d = json.loads(out.read_text())
    assert d["bound_speed"] == 6.0 and [r["speed"] for r in d["rows"]] == [4.0, 5.0, 6.0]
    assert abs(d["rows"][1]["peak_force"] - 5009) <= 2


def test_bound_errors(main, tmp_path, capsys):
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    assert main(["bound", str(f)]) == 2                       # no failure force anywhere
    assert "failure force" in capsys.readouterr().err
    assert main(["bound", str(f), "--failure-force", "5000 kg"]) == 2
    assert "lbf" in capsys.readouterr().err


def test_mc(main, tmp_path, capsys):
    f = tmp_path / "mc.toml"
    f.write_text(TABLE3 + UNCERTAINTY)
    out = tmp_path / "out"
    assert main(["mc", str(f), "--n", "2000", "--seed", "3", "--out", str(out), "--no-progress",
                 "--percentiles", "10,50,90"]) == 0
    text = capsys.readouterr().out
    assert "2000 samples (seed 3)" in text and "p90" in text
    assert (out / "mc.csv").read_text().count("\n") == 2001
    assert (out / "mc_delta_v.png").stat().st_size > 1000
    # the same seed prints the same table
    assert main(["mc", str(f), "--n", "2000", "--seed", "3", "--no-progress",
                 "--percentiles", "10,50,90"]) == 0
    again = capsys.readouterr().out.strip().split("\n")[4:]
    assert again == text.split("\n\nwritten")[0].strip().split("\n")[4:]


def test_mc_uncertainty_file_and_errors(main, tmp_path, capsys):
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    assert main(["mc", str(f), "--n", "10"]) == 2
    assert "no distributions" in capsys.readouterr().err
    u = tmp_path / "u.toml"
    u.write_text('"vehicles.0.speed" = { triangular = [3, 5, 9] }\n')
    assert main(["mc", str(f), "--n", "100", "--uncertainty", str(u), "--no-progress"]) == 0
    assert "vehicles.0.speed" in capsys.readouterr().out
    u.write_text('"vehicles.0.speed" = { uniform = [9, 3] }\n')
    assert main(["mc", str(f), "--n", "100", "--uncertainty", str(u)]) == 2


def test_sensitivity(main, tmp_path, capsys):
    pytest.importorskip("diffrax")
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    out, png = tmp_path / "s.json", tmp_path / "tornado.png"
    assert main(["sensitivity", str(f), "--json", str(out), "--plot", str(png),
                 "--plot-metric", "peak_acceleration"]) == 0
    text = capsys.readouterr().out
    assert "forward-mode autodiff" in text and "delta_v, target = 4.5 ft/s" in text
    assert "tornado chart written" in text and png.stat().st_size > 1000
    d = json.loads(out.read_text())
    j = d["params"].index("contacts.0.unloading.restitution")
    assert d["derivatives"]["delta_v"][1][j] == pytest.approx(2.5, rel=1e-10)   # v0 m1/(m1+m2)
    assert d["elasticities"]["duration"][d["params"].index("contacts.0.loading.scale")] == \
        pytest.approx(-0.5, rel=1e-9)
    # finite differences, a chosen parameter list and metric
    assert main(["sensitivity", str(f), "--derivative", "finite-difference", "--params",
                 "vehicles.0.speed,vehicles.1.weight", "--metrics", "peak_acceleration_g"]) == 0
    text = capsys.readouterr().out
    assert "closed-form" in text and "vehicles.1.weight" not in text and "target weight" in text


def test_sensitivity_errors(main, tmp_path, capsys):
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    assert main(["sensitivity", str(f), "--derivative", "finite-difference", "--params",
                 "vehicles.0.colour"]) == 2
    assert "not a differentiable parameter" in capsys.readouterr().err
    assert main(["sensitivity", str(f), "--derivative", "finite-difference", "--metrics", "duration",
                 "--plot", str(tmp_path / "x.png"), "--plot-metric", "delta_v"]) == 2
    assert "not among --metrics" in capsys.readouterr().err


def test_sensitivity_method_is_the_backend_as_for_every_command(main, tmp_path, capsys):
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    fd = ["sensitivity", str(f), "--derivative", "finite-difference", "--params",
          "vehicles.0.speed", "--metrics", "delta_v"]
    assert main(fd + ["--method", "scipy"]) == 0
    assert "scipy" in capsys.readouterr().out        # the backend of the solves
    assert main(fd + ["--method", "exact"]) == 0
    assert "exact" in capsys.readouterr().out
    # the old spellings: a clear error, not another meaning
    assert main(["sensitivity", str(f), "--method", "finite-difference"]) == 2
    err = capsys.readouterr().err
    assert "--method is the backend" in err and "--derivative finite-difference" in err
    assert main(fd + ["--backend", "scipy"]) == 2
    assert capsys.readouterr().err == (
        "lsc: error: backend: --backend is now --method (the backend of the solves, as for every "
        "command); the derivative technique is --derivative autodiff|finite-difference\n")
    assert main(["sensitivity", str(f), "--method", "scipy"]) == 2   # autodiff needs diffrax
    assert "autodiff differentiates through the diffrax solve, not scipy" in \
        capsys.readouterr().err


def test_run_prints_the_mer_cross_check(main, tmp_path, capsys):
    """`lsc run` sets the MER ΔVs beside the simulated ones (issue #5.3)."""
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    assert main(["run", str(f), "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    text = capsys.readouterr().out
    assert "MER cross-check" in text
    assert "target: delta_v +4.5 ft/s (MER), +4.5 ft/s (simulation)" in text


# --------------------------------------------------------------------------- output files
def test_mc_outputs_all_or_none_and_never_over_an_earlier_run(main, tmp_path, capsys,
                                                              monkeypatch):
    from lsc.analysis.uncertainty import MonteCarlo
    f = tmp_path / "mc.toml"
    f.write_text(TABLE3 + UNCERTAINTY)
    out = tmp_path / "out"
    mc = ["mc", str(f), "--n", "200", "--no-progress", "--out", str(out)]
    assert main(mc) == 0
    first = _files(out)
    names = ["mc.csv", "mc_delta_v.png", "mc_duration.png", "mc_peak_acceleration_g.png",
             "mc_peak_force.png"]
    assert sorted(first) == names
    capsys.readouterr()
    assert main(mc + ["--seed", "1"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""  # refused before sampling
    assert cap.err.startswith(f"lsc: error: {out / 'mc.csv'}, {out / 'mc_delta_v.png'}, ")
    assert cap.err.endswith(" already exist (the results of an earlier run): pass --overwrite to "
                            "replace them, or write elsewhere\n") and cap.err.count("\n") == 1
    assert _files(out) == first
    with monkeypatch.context() as m:  # the last histogram fails: nothing new, nothing lost
        m.setattr(MonteCarlo, "histogram", lambda self, metric, ax=None:
                  _no_space() if metric == "peak_force" else None)
        assert main(mc + ["--seed", "1", "--overwrite"]) == 1
    assert capsys.readouterr().err == (f"lsc: error: cannot write {out / 'mc_peak_force.png'}: "
                                       "No space left on device; nothing was written\n")
    assert _files(out) == first
    assert main(mc + ["--seed", "1", "--overwrite", "--no-plots"]) == 0
    assert sorted(_files(out)) == ["mc.csv"] and (out / "mc.csv").read_bytes() != first["mc.csv"]


def test_bound_json_is_not_written_over_an_earlier_one(main, tmp_path, capsys):
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    out = tmp_path / "b.json"
    bound = ["bound", str(f), "--json", str(out), "--failure-force"]
    assert main(bound + ["5000 lbf"]) == 0
    first = out.read_bytes()
    capsys.readouterr()
    assert main(bound + ["6000 lbf"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == (f"lsc: error: {out} already exists (the results of an "
                                         "earlier run): pass --overwrite to replace them, or "
                                         "write elsewhere\n")
    assert out.read_bytes() == first
    assert main(bound + ["6000 lbf", "--overwrite"]) == 0
    assert json.loads(out.read_text())["failure_force"] == 6000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.json", "t3.toml"]  # no debris


def test_sensitivity_files_all_or_none(main, tmp_path, capsys, monkeypatch):
    import lsc.plots
    f = tmp_path / "t3.toml"
    f.write_text(TABLE3)
    js, png = tmp_path / "s.json", tmp_path / "t.png"
    sens = ["sensitivity", str(f), "--derivative", "finite-difference", "--metrics", "delta_v",
            "--json", str(js), "--plot"]
    assert main(sens + [str(js)]) == 2
    assert capsys.readouterr().err == f"lsc: error: json: --plot and --json name the same file " \
                                      f"({js})\n"
    js.write_text("earlier")
    assert main(sens + [str(png)]) == 2
    assert capsys.readouterr().out == ""
    monkeypatch.setattr(lsc.plots, "tornado", _no_space)
    assert main(sens + [str(png), "--overwrite"]) == 1
    assert "cannot write" in capsys.readouterr().err
    assert js.read_text() == "earlier" and not png.exists()
    monkeypatch.undo()
    assert main(sens + [str(png), "--overwrite"]) == 0
    assert json.loads(js.read_text())["params"] and png.stat().st_size > 1000


def test_compare_prints_the_rating_and_writes_all_files_or_refuses(main, capsys, tmp_path):
    """``lsc compare`` of the default scene against the shipped synthetic test (made from that
    scene): per-vehicle rows equal to the API's comparison, ratings near 1, files written once and
    refused the second time (exit 2, files unchanged)."""
    from lsc import data
    from lsc.analysis import compare, read_channels
    test = data.path("default").parent / "synthetic_test.csv"
    out = tmp_path / "cmp"
    assert main(["compare", "default", str(test), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    expected = compare(lsc.solve(data.load("default")),
                       read_channels(test))
    for row in expected.rows():
        assert f"{row['simulated']:.5g}" in text and f"{row['measured']:.5g}" in text
    for ch, r in expected.iso18571.items():
        assert ch in text and f"{r.total:.4f}" in text and r.total > 0.95
    written = {f: (out / f).read_bytes() for f in ("comparison.csv", "comparison.json",
                                                    "comparison.png")}
    assert json.loads(written["comparison.json"])["iso18571"].keys() == expected.iso18571.keys()
    assert main(["compare", "default", str(test), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert {f: (out / f).read_bytes() for f in written} == written


def test_compare_refuses_a_missing_data_file(main, capsys, tmp_path):
    assert main(["compare", "default", str(tmp_path / "nope.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lsc: error: ") and "nope.csv" in err


def test_fit_recovers_the_synthetic_tests_stiffness_and_restitution(main, capsys, tmp_path):
    """``lsc fit`` on the shipped synthetic test (the default scene, k = 24000 lbf/ft, e = 0.4,
    plus filtered noise) from wrong starting values: the printed values are the API's fit, within
    their standard errors of the truth; the fitted scene is written as a TOML scene that loads."""
    from lsc import data
    from lsc.analysis import fit, read_channels
    test = data.path("default").parent / "synthetic_test.csv"
    params = ["contacts.0.loading.stiffness", "contacts.0.unloading.restitution"]
    start = {params[0]: 30000.0, params[1]: 0.25}
    out = tmp_path / "fit"
    argv = ["fit", "default", str(test), *(a for p in params for a in ("--param", p)),
            *(a for p, v in start.items() for a in ("--initial", f"{p}={v}")),
            "--out", str(out), "--no-plots"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    expected = fit(data.load("default"), read_channels(test), params, initial=start)
    for p, truth in zip(params, (24000.0, 0.4)):
        value, se = expected.values[p], expected.standard_errors[p]
        assert f"{p} = {value:.8g} ± " in text
        assert abs(value - truth) < 3 * se
    refit = lsc.solve(out / "fitted.toml")
    assert refit.restitution[0] == pytest.approx(expected.values[params[1]], rel=1e-12)
    assert sorted(f.name for f in out.iterdir()) == ["fit.json", "fitted.toml"]


def test_fit_jac_option_is_passed_on_and_refused_where_it_does_not_apply(main, capsys):
    """``--jac 3-point`` reaches the fit (its summary says so); ``--jac autodiff`` on the
    closed form is the fit's own SceneError, exit 2 with no traceback."""
    from lsc import data
    test = str(data.path("default").parent / "synthetic_test.csv")
    base = ["fit", "default", test, "--param", "contacts.0.unloading.restitution",
            "--initial", "contacts.0.unloading.restitution=0.3"]
    assert main([*base, "--jac", "3-point"]) == 0
    assert "Jacobian: finite differences (3-point) of lsc.solve" in capsys.readouterr().out
    assert main([*base, "--jac", "autodiff"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lsc: error: jac: ") and "autodiff needs method='diffrax'" in err


def test_fit_refuses_malformed_initial_values(main, capsys):
    assert main(["fit", "default", "x.csv", "--param", "vehicles.0.speed",
                 "--initial", "vehicles.0.speed"]) == 2
    assert capsys.readouterr().err == ("lsc: error: initial: expected PATH=NUMBER (e.g. "
                                       "contacts.0.loading.stiffness=30000), got "
                                       "'vehicles.0.speed'\n")
