"""Display units and the layout of the printed summaries: ``--speed-unit`` / ``summary(speed_unit=)``
(exact conversions of the printed digits), the bound printed in the unit of its step, aligned
tables for any vehicle names, the bullet's peak acceleration signed alike by ``lsc run`` and
``lsc bound``, and the folder printed once with one slash."""

import json
import re
from fractions import Fraction

import pytest

import lsc
from lsc.analysis.bounds import max_closing_speed
from lsc.cli import main

from helpers import paper_scene, summary_row as _row
from test_analysis_bounds import table3_scene
from test_impacts import RATTLE

# exact factors from the definitions: 1 mile = 5280 ft, 1 ft = 0.3048 m
FT_S_TO_MPH = Fraction(3600, 5280)              # 10 ft/s = 6.8181... mph
M_S_TO_KMH = Fraction(36, 10)
FT_S_TO_KMH = Fraction(3048, 10000) * M_S_TO_KMH   # 1.09728


@pytest.fixture(scope="module")
def default_result():
    return lsc.solve(paper_scene(), method="exact")


@pytest.mark.parametrize("unit, factor, v0, dv", [
    ("mph", FT_S_TO_MPH, "6.818", "4.7727"),     # 10 ft/s = 6.8181... mph, 7 ft/s = 4.77272... mph
    ("km/h", FT_S_TO_KMH, "10.97", "7.6810"),    # 10 ft/s = 10.9728 km/h
    ("ft/s", Fraction(1), "10", "7.0000")])
def test_summary_speeds_in_the_display_unit_are_exact_conversions(default_result, unit, factor,
                                                                  v0, dv):
    r = default_result
    text = r.summary(speed_unit=unit)
    assert text.splitlines()[0].split("(")[0].rstrip().endswith(f"speeds in {unit}")
    for i, name in enumerate(("bullet", "target")):
        row_v0, v_final, row_dv, a, a_g = _row(text, name)[1:6]
        assert row_v0 == f"{float(Fraction(r.scene.vehicles[i].speed) * factor):.4g}"
        assert v_final == f"{float(Fraction(float(r.v_final[i])) * factor):.4f}"
        assert row_dv == f"{float(Fraction(float(r.delta_v[i])) * factor):.4f}"
        # accelerations stay in the scene's unit, with g beside them
        assert a == f"{r.peak_acceleration[i]:.4g}" and a_g == f"{r.peak_acceleration_g[i]:.3f}"
    assert _row(text, "bullet")[1] == v0 and _row(text, "target")[3] == dv
    units_line = text.splitlines()[3].split()
    assert units_line[:3] == [unit] * 3 and units_line[3] == r.units["peak_acceleration"]


def test_si_scene_in_km_h(default_result):
    r = lsc.solve({**RATTLE, "vehicles": RATTLE["vehicles"][:2], "contacts": RATTLE["contacts"][:1]},
                  method="exact")
    dv = _row(r.summary(speed_unit="km/h"), "vehicle 1")[4]
    assert dv == f"{float(Fraction(float(r.delta_v[0])) * M_S_TO_KMH):.4f}"


def test_impacts_table_in_the_display_unit_with_g():
    r = lsc.solve(RATTLE, method="scipy")
    text = r.summary(speed_unit="km/h")
    lines = text.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("impact "))
    assert lines[head + 1].split()[2:5] == ["km/h"] * 3
    first = lines[head + 2].split(") ", 1)[1].split()  # after the label
    m = r.impacts[0]
    assert first[2] == f"{float(Fraction(m.closing_speed) * M_S_TO_KMH):.4f}"
    assert first[3] == f"{float(Fraction(float(m.delta_v[0])) * M_S_TO_KMH):+.4f}"
    assert first[5] == f"{m.peak_acceleration[0]:.4g}"                 # m/s^2
    assert first[7] == f"{m.peak_acceleration[0] / r.scene.g:.3f}"     # and g beside it


def test_bad_speed_unit_is_a_scene_error_naming_the_accepted_ones(default_result, tmp_path,
                                                                  capsys):
    with pytest.raises(lsc.SceneError) as e:
        default_result.summary(speed_unit="furlong/fortnight")
    assert e.value.path == "speed_unit"
    assert "mph, km/h, ft/s, m/s" in e.value.message
    out = tmp_path / "out"
    assert main(["run", "--speed-unit", "knots", "--out", str(out)]) == 2
    cap = capsys.readouterr()
    assert cap.err == ("lsc: error: --speed-unit: unknown speed unit 'knots'; accepted: "
                       "mph, km/h, ft/s, m/s\n")
    assert not out.exists()  # refused before the solve


def test_run_speed_unit_prints_mph_and_files_keep_scene_units(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", "--speed-unit", "mph", "--no-plots", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert _row(text, "bullet")[1] == "6.818"
    d = json.loads((out / "summary.json").read_text())
    assert d["unit_system"] == "US" and d["units"]["delta_v"] == "ft/s"
    assert d["metrics"]["delta_v"][1] == pytest.approx(7.0, abs=1e-9)
    header = (out / "series.csv").read_text().splitlines()[0]
    assert "v[bullet] (ft/s)" in header and "mph" not in header


# ------------------------------------------------------------------ the bound in the step's unit
@pytest.fixture(scope="module")
def bound_mph():
    return max_closing_speed(table3_scene(), "5000 lbf", step="1 mph")


def test_bound_with_a_step_in_mph_prints_its_rows_in_mph(bound_mph):
    b = bound_mph
    text = b.summary()
    lines = text.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["speed", "peak"])
    assert lines[head + 1].split()[:4] == ["mph", "lbf", "mph", "mph"]
    rows = [line.split() for line in lines[head + 2:head + 2 + len(b.rows)]]
    assert [row[0] for row in rows] == ["3", "4", "5"]  # whole mph
    for row, (v, rr) in zip(rows, b.rows):
        assert float(Fraction(v) * FT_S_TO_MPH) == pytest.approx(float(row[0]), rel=1e-12)
        assert row[2] == f"{float(Fraction(float(rr.delta_v[0])) * FT_S_TO_MPH):.3f}"
    assert f"= {float(Fraction(b.speed) * FT_S_TO_MPH):.6f} mph" in text
    assert "<= 5 mph" in text
    # an explicit unit wins; the JSON keeps the scene's units and says which
    assert "<= 7.33333 ft/s" in b.summary(speed_unit="ft/s")
    d = b.to_dict()
    assert d["units"]["velocity"] == "ft/s" and d["bound_speed"] == pytest.approx(5 * 22 / 15)


def test_bound_cli_step_in_mph(capsys):
    assert main(["bound", "table3", "--failure-force", "5000 lbf", "--step", "1 mph"]) == 0
    assert "conservative upper limit: vehicles.0.speed <= 5 mph" in capsys.readouterr().out


def _g_column(text: str, name: str) -> float:
    return float(_row(text, name)[5])


def test_bullet_peak_acceleration_has_the_same_sign_in_run_and_bound():
    b = max_closing_speed(table3_scene(), "5000 lbf")
    lines = b.summary().splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:2] == ["speed", "peak"])
    for line, (v, rr) in zip(lines[head + 2:], b.rows):
        a_bullet, a_target = map(float, line.split()[4:6])
        assert a_bullet == _g_column(rr.summary(), "bullet") < 0
        assert a_target == _g_column(rr.summary(), "target") > 0
    m = re.search(r"peak acceleration bullet ([-+\d.]+) g", b.summary())
    assert float(m.group(1)) == _g_column(b.result.summary(), "bullet")


# ------------------------------------------------------------------ alignment
def _table(text: str, first: str) -> list[str]:
    lines = text.splitlines()
    i = next(i for i, line in enumerate(lines) if line.startswith(first + " "))
    j = next(j for j in range(i, len(lines)) if not lines[j].strip())
    return [line for line in lines[i:j] if not line.startswith("(")]


def _column_ends(line: str, label_width: int) -> set[int]:
    """Where each field right of the label column ends."""
    return {m.end() for m in re.finditer(r"\S+", line) if m.start() >= label_width}


@pytest.mark.parametrize("names", [("a", "b"), ("the bullet vehicle, a 2004 Kia Sportage",
                                                "the target, a 2007 Ford Edge SEL AWD")])
def test_every_row_of_each_table_has_the_same_column_positions(names):
    scene = lsc.Scene.load(paper_scene(**{"vehicles.0.name": names[0], "vehicles.1.name": names[1]}))
    text = lsc.solve(scene, method="exact").summary()
    label = max(len(f"0 ({names[0]}-{names[1]})"), *map(len, names))
    for first in ("vehicle", "contact"):
        header, units, *rows = _table(text, first)
        ends = [_column_ends(row, label) for row in rows]
        assert len(ends[0]) >= 5 and all(e == ends[0] for e in ends)
        # each field ends where its header and unit end (right-aligned columns)
        assert ends[0] <= _column_ends(header, label), (header, rows)
        assert _column_ends(units, label) <= ends[0], (units, rows)


def test_scene_display_speed_unit_is_the_summarys_default_and_the_cli_overrides_it(capsys,
                                                                                   tmp_path):
    """``[display] speed_unit`` prints the summary in that unit (results keep scene units);
    ``--speed-unit`` overrides it; a unit not accepted is a SceneError naming the key."""
    scene = {**paper_scene(), "display": {"speed_unit": "mph"}}
    r = lsc.solve(scene, method="exact")
    assert r.scene.speed_unit == "mph" and r.delta_v[1] == pytest.approx(7.0, rel=1e-12)
    assert r.summary() == r.summary(speed_unit="mph") != r.summary(speed_unit="ft/s")
    file = tmp_path / "crash.toml"
    file.write_text('units = "US"\ng = "32.2 ft/s^2"\n[display]\nspeed_unit = "km/h"\n'
                    '[[vehicles]]\nweight = 3500\nspeed = 10\n[[vehicles]]\nweight = 3500\n'
                    'speed = 0\n[[contacts]]\nloading = { stiffness = 24000 }\n'
                    'unloading = { restitution = 0.4 }\n')
    assert main(["run", str(file), "--no-plots", "--out", str(tmp_path / "a")]) == 0
    assert "speeds in km/h" in capsys.readouterr().out
    assert main(["run", str(file), "--no-plots", "--out", str(tmp_path / "b"),
                 "--speed-unit", "mph"]) == 0
    assert "speeds in mph" in capsys.readouterr().out
    with pytest.raises(lsc.SceneError) as e:
        lsc.Scene.load({**paper_scene(), "display": {"speed_unit": "knots"}})
    assert str(e.value) == ("display.speed_unit: unknown speed unit 'knots'; accepted: mph, km/h, "
                            "ft/s, m/s")
