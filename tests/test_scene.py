"""Scene loading: accepted forms load to the right numbers; malformed scenes raise SceneError
with the exact path and a message that says what is wrong."""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from lsc.errors import SceneError
from lsc.scene import (STANDARD_G, Brake, Failure, Hysteresis, Restitution, Scene, UnloadingStiffness,
                       UnloadingTable, load_scene)
from helpers import HARD, paper_scene

FT = 0.3048          # m per ft
LBF = 4.4482216152605  # N per lbf
IN = 1.0 / 12.0      # ft per in


def paper() -> dict:
    """Paper, parametric study 1 (US units, g = 32.2 ft/s^2)."""
    return paper_scene(name="Paper, study 1")


def si() -> dict:
    return {
        "vehicles": [{"mass": 1500, "speed": "16 km/h"}, {"mass": 1200, "speed": 0}],
        "contacts": [{"loading": {"stiffness": "350 kN/m"}, "unloading": {"restitution": 0.3}}],
    }


@pytest.fixture
def edge_csv(tmp_path):
    """A crash-test curve in inches and lbf, with a header row."""
    p = tmp_path / "edge.csv"
    p.write_text("deformation (in), force (lbf)\n0, 0\n1.2, 3000\n2.4, 9000\n")
    return p


# ----------------------------------------------------------------- accepted forms
def test_paper_scene_numbers():
    s = Scene.load(paper())
    assert s.name == "Paper, study 1" and s.units == "US"
    assert s.g == pytest.approx(32.2, rel=1e-14)
    np.testing.assert_allclose(s.masses, [3500 / 32.2, 3500 / 32.2], rtol=1e-14)
    np.testing.assert_array_equal(s.speeds, [10.0, 0.0])
    c = s.contacts[0]
    assert isinstance(c.law, Hysteresis) and c.law.loading.is_linear
    assert c.law.loading.stiffness == 24000.0
    assert c.law.unloading == Restitution(0.4)
    assert c.gap == 0.0 and c.failure is None
    assert s.solver.method == "auto" and s.solver.options == {}
    assert [v.name for v in s.vehicles] == ["bullet", "target"]
    assert s.unit("stiffness") == "lbf/ft"


def test_si_defaults_and_unit_strings():
    s = Scene.load(si())
    assert s.units == "SI" and s.name == "scene" and s.g == STANDARD_G["SI"]
    assert s.vehicles[0].speed == pytest.approx(16 / 3.6, rel=1e-14)
    assert s.vehicles[0].speed == pytest.approx(4.4444, abs=1e-4)
    assert s.contacts[0].law.loading.stiffness == pytest.approx(350e3, rel=1e-14)
    assert [v.name for v in s.vehicles] == ["vehicle 1", "vehicle 2"]


def test_default_g_used_for_weight_and_units_lowercase():
    d = paper()
    del d["g"]
    d["units"] = "us"
    s = Scene.load(d)
    assert s.units == "US" and s.g == 32.174
    assert s.masses[0] == pytest.approx(3500 / 32.174, rel=1e-14)


def test_cross_system_quantities():
    d = si()
    d["vehicles"][0] = {"weight": "3500 lbf", "speed": "10 mph"}
    d["g"] = "32.2 ft/s^2"
    s = Scene.load(d)
    assert s.g == pytest.approx(32.2 * FT, rel=1e-12)
    assert s.masses[0] == pytest.approx(3500 * LBF / (32.2 * FT), rel=1e-12)
    assert s.speeds[0] == pytest.approx(10 * 1609.344 / 3600, rel=1e-12)
    d = paper()
    d["vehicles"][1] = {"mass": "1600 kg", "speed": "-1 ft/s"}
    s = Scene.load(d)
    assert s.masses[1] == pytest.approx(1600 / 14.59390293720636, rel=1e-9)
    assert s.speeds[1] == -1.0


def test_pound_mass_to_mass_key():
    d = paper()
    d["vehicles"][0] = {"mass": "3500 lb", "speed": 10}
    s = Scene.load(d)
    assert s.masses[0] == pytest.approx(3500 / 32.174048556, rel=1e-9)  # lb → slug by standard g


def test_table_bare_numbers_column_units_and_strings():
    d = paper()
    d["contacts"][0]["loading"] = {"table": [[0, 0], [0.1, 3000], [0.2, 9000]]}
    c = Scene.load(d).contacts[0].law.loading
    np.testing.assert_array_equal(c.d, [0, 0.1, 0.2])
    np.testing.assert_array_equal(c.f, [0, 3000, 9000])
    assert not c.extends
    d["contacts"][0]["loading"] = {"table": [[0, 0], [1.2, 3], [2.4, 9]], "deformation": "in", "force": "kip"}
    c = Scene.load(d).contacts[0].law.loading
    np.testing.assert_allclose(c.d, [0, 0.1, 0.2], rtol=1e-14)
    np.testing.assert_allclose(c.f, [0, 3000, 9000], rtol=1e-14)
    d["contacts"][0]["loading"] = {"table": [[0, 0], ["1.2 in", "13.3446648 kN"], ["2.4 in", "9000 lbf"]]}
    c = Scene.load(d).contacts[0].law.loading
    np.testing.assert_allclose(c.d, [0, 0.1, 0.2], rtol=1e-14)
    np.testing.assert_allclose(c.f, [0, 3000, 9000], rtol=1e-8)


def test_csv_inches_lbf_to_ft_lbf(edge_csv):
    d = paper()
    d["contacts"][0]["loading"] = {"csv": str(edge_csv), "deformation": "in", "force": "lbf"}
    c = Scene.load(d).contacts[0].law.loading
    np.testing.assert_allclose(c.d, [0, 0.1, 0.2], rtol=1e-14)
    np.testing.assert_array_equal(c.f, [0, 3000, 9000])
    # SI scene: the same file in m and N
    d = si()
    d["contacts"][0]["loading"] = {"csv": str(edge_csv), "deformation": "in", "force": "lbf"}
    c = Scene.load(d).contacts[0].law.loading
    np.testing.assert_allclose(c.d, [0, 1.2 * 0.0254, 2.4 * 0.0254], rtol=1e-14)
    np.testing.assert_allclose(c.f, [0, 3000 * LBF, 9000 * LBF], rtol=1e-12)


def test_csv_relative_to_base_dir_and_formats(tmp_path, monkeypatch):
    (tmp_path / "a.csv").write_text("0;0\n\n# comment\n0.5;100\n1;150;\n")
    d = paper()
    d["contacts"][0]["loading"] = {"csv": "a.csv"}
    c = Scene.load(d, base_dir=tmp_path).contacts[0].law.loading
    np.testing.assert_array_equal(c.d, [0, 0.5, 1])
    np.testing.assert_array_equal(c.f, [0, 100, 150])
    monkeypatch.chdir(tmp_path)
    (tmp_path / "b.csv").write_text("0 0\n0.5 100\n")
    d["contacts"][0]["loading"] = {"csv": "b.csv"}
    s = Scene.load(d)  # default: current directory
    np.testing.assert_array_equal(s.contacts[0].law.loading.f, [0, 100])
    assert s.base_dir == tmp_path.absolute()


def test_series_of_two_lines():
    d = paper()
    d["contacts"][0]["loading"] = {"series": [{"stiffness": 48000}, {"stiffness": "30000 lbf/ft"}]}
    c = Scene.load(d).contacts[0].law.loading
    assert c.is_linear
    assert c.stiffness == pytest.approx(18461.538461538461, rel=1e-14)


def test_series_table_and_line_and_scale():
    d = paper()
    d["contacts"][0]["loading"] = {
        "series": [{"table": [[0, 0], [0.1, 1000], [0.3, 3000]]}, {"stiffness": 20000}], "scale": 2}
    c = Scene.load(d).contacts[0].law.loading
    # at equal force the deformations add; then every force is doubled
    assert c.deformation_at(2 * 3000) == pytest.approx(0.3 + 3000 / 20000, rel=1e-12)
    assert c.f_top == pytest.approx(6000)
    d["contacts"][0]["loading"] = {"stiffness": 24000, "scale": "1.5"}
    assert Scene.load(d).contacts[0].law.loading.stiffness == 36000


def test_unloading_forms():
    d = paper()
    d["contacts"][0]["unloading"] = {"stiffness": 24000}
    assert Scene.load(d).contacts[0].law.unloading == UnloadingStiffness(24000.0)
    d["contacts"][0]["unloading"] = {"table": [[2.4, 9], [2.0, 4], [1.8, 0]], "deformation": "in",
                                     "force": "kip"}
    u = Scene.load(d).contacts[0].law.unloading
    assert isinstance(u, UnloadingTable)
    np.testing.assert_allclose(u.d, [0.2, 2.0 / 12, 0.15], rtol=1e-14)
    np.testing.assert_allclose(u.f, [9000, 4000, 0], rtol=1e-14)
    assert not u.d.flags.writeable
    d["contacts"][0]["unloading"] = {"restitution": 0}
    assert Scene.load(d).contacts[0].law.unloading.e == 0.0
    d["contacts"][0]["unloading"] = {"restitution": "100 %"}
    assert Scene.load(d).contacts[0].law.unloading.e == 1.0


def test_gap_failure_brake_law_alias():
    d = paper()
    c = d["contacts"][0]
    c.update(law="IF-D", gap="1.2 in",
             failure={"force": "5 kip", "post_failure": {"table": [[0, 0], [0.5, 1000]]}})
    d["vehicles"][1]["brake"] = {"mu": 0.7}
    d["vehicles"][0]["brake"] = {"mu": 0.6, "mu_static": 0.8}
    s = Scene.load(d)
    con = s.contacts[0]
    assert con.gap == pytest.approx(0.1, rel=1e-14)
    assert isinstance(con.failure, Failure) and con.failure.force == pytest.approx(5000)
    np.testing.assert_array_equal(con.failure.post_failure.f, [0, 1000])
    assert s.vehicles[1].brake == Brake(0.7, 0.7)
    assert s.vehicles[0].brake == Brake(0.6, 0.8)


def test_solver_settings():
    d = paper()
    d["solver"] = {"method": "closed_form", "rtol": 1e-10, "atol": 1e-12, "dt": "0.1 ms",
                   "integrator": "DOP853", "t_end": 1, "max_events": 50.0}
    s = Scene.load(d).solver
    assert s.method == "closed-form"
    assert s.options == {"rtol": 1e-10, "atol": 1e-12, "dt": pytest.approx(1e-4, rel=1e-12),
                         "integrator": "DOP853", "t_end": 1.0, "max_events": 50}
    assert type(s.options["max_events"]) is int and type(s.options["dt"]) is float
    for m in ("auto", "exact", "scipy", "diffrax", "reference", "Closed-Form"):
        d["solver"] = {"method": m}
        assert Scene.load(d).solver.method == m.lower()


def test_chain_of_three():
    d = paper()
    d["vehicles"].append({"weight": 3000, "speed": 0})
    d["contacts"].append({"loading": {"stiffness": 20000}, "unloading": {"restitution": 0.2}, "gap": 0.5})
    s = Scene.load(d)
    assert s.n_vehicles == 3 and len(s.contacts) == 2
    assert s.contacts[1].gap == 0.5
    # only the second pair closes: still a valid scene
    d["vehicles"][0]["speed"] = 0
    d["vehicles"][1]["speed"] = 5
    assert Scene.load(d).speeds[1] == 5


def test_braked_scene_need_not_be_closing():
    d = paper()
    d["vehicles"][0]["speed"] = 5
    d["vehicles"][1]["speed"] = 10
    d["vehicles"][1]["brake"] = {"mu": 0.7}
    assert Scene.load(d).speeds[1] == 10


def test_numpy_and_tuple_inputs():
    d = paper()
    d["vehicles"] = tuple(d["vehicles"])
    d["vehicles"][0]["speed"] = np.float64(12.5)
    d["vehicles"][1]["weight"] = np.int64(3000)
    d["contacts"][0]["loading"] = {"table": np.array([[0, 0], [0.1, 1000.0]])}
    s = Scene.load(d)
    assert s.speeds[0] == 12.5 and s.masses[1] == pytest.approx(3000 / 32.2)
    assert isinstance(s.source["vehicles"], list)
    assert s.source["contacts"][0]["loading"]["table"] == [[0.0, 0.0], [0.1, 1000.0]]


def test_source_is_a_deep_copy():
    d = paper()
    s = Scene.load(d)
    d["vehicles"][0]["speed"] = 99
    assert s.source["vehicles"][0]["speed"] == 10
    assert s.source == paper()


def test_toml_file(tmp_path, edge_csv):
    sub = tmp_path / "scenes"
    sub.mkdir()
    (sub / "edge.csv").write_text(edge_csv.read_text())
    p = sub / "study1.toml"
    p.write_text(textwrap.dedent("""
        units = "US"
        g     = "32.2 ft/s^2"

        [[vehicles]]
        weight = 3500
        speed  = "10 ft/s"

        [[vehicles]]
        weight = 3500
        speed  = 0

        [[contacts]]
        loading   = { csv = "edge.csv", deformation = "in", force = "lbf" }
        unloading = { restitution = 0.4 }

        [solver]
        method = "reference"
        dt = 1e-5
    """))
    for arg in (p, str(p)):
        s = load_scene(arg)
        assert s.name == "study1" and s.base_dir == sub.absolute()
        np.testing.assert_allclose(s.contacts[0].law.loading.d, [0, 0.1, 0.2], rtol=1e-14)
        assert s.solver.method == "reference" and s.solver.options == {"dt": 1e-5}
        assert s.source["vehicles"][0]["speed"] == "10 ft/s"
        assert "name" not in s.source
    assert Scene.load(s) is s
    # with_values keeps the TOML folder for the CSV and the file's name
    s2 = s.with_values({"vehicles.0.speed": 8})
    assert s2.name == "study1" and s2.speeds[0] == 8
    np.testing.assert_allclose(s2.contacts[0].law.loading.d, [0, 0.1, 0.2], rtol=1e-14)


def test_with_values():
    s = Scene.load(paper())
    s2 = s.with_values({"vehicles.0.speed": 5.0, "contacts.0.unloading.restitution": 0.3})
    assert s2.speeds[0] == 5.0 and s2.contacts[0].law.unloading.e == 0.3
    assert s.speeds[0] == 10.0 and s.contacts[0].law.unloading.e == 0.4  # original unchanged
    assert s.source == paper()
    s3 = s.with_values({"vehicles[1].speed": "-2 ft/s", "g": "9.80665 m/s^2", "name": "x"})
    assert s3.speeds[1] == -2 and s3.g == pytest.approx(32.174048556, rel=1e-9) and s3.name == "x"
    # exclusive keys replace each other
    s4 = s.with_values({"vehicles.0.mass": 100, "contacts.0.unloading.stiffness": 30000,
                        "contacts.0.loading.table": [[0, 0], [1, 100]]})
    assert s4.masses[0] == 100 and s4.masses[1] == pytest.approx(3500 / 32.2)
    assert s4.contacts[0].law.unloading == UnloadingStiffness(30000.0)
    assert not s4.contacts[0].law.loading.extends
    # optional sub-tables are created
    s5 = s.with_values({"vehicles.1.brake.mu": 0.5, "solver.method": "scipy", "contacts.0.gap": 0.1})
    assert s5.vehicles[1].brake == Brake(0.5, 0.5) and s5.solver.method == "scipy"
    assert s5.contacts[0].gap == 0.1


@pytest.mark.parametrize("values, path, phrase", [
    ({"vehicles.2.speed": 1}, "vehicles.2.speed", "list of 2"),
    ({"vehicles.x.speed": 1}, "vehicles.x.speed", "index it with 0..1"),
    ({"vehicle.0.speed": 1}, "vehicle.0.speed", 'has no "vehicle"'),
    ({"vehicles.0.speed.x": 1}, "vehicles.0.speed.x", "is a value"),
    ({"vehicles..speed": 1}, "vehicles..speed", "index it with"),
    ({"solver..method": 1}, "solver..method", "empty name"),
    ({"vehicles.0.sped": 1}, "vehicles[0].sped", 'did you mean "speed"'),
    ({"vehicles.0.speed": "10 lbf"}, "vehicles[0].speed", "is a force, expected a velocity"),
    ({"contacts.0.unloading.restitution": 2}, "contacts[0].unloading.restitution", "between 0"),
])
def test_with_values_errors(values, path, phrase):
    s = Scene.load(paper())
    with pytest.raises(SceneError) as ei:
        s.with_values(values)
    assert ei.value.path == path
    assert phrase in str(ei.value)


def test_lazy_registry():
    code = ("import sys, lsc.scene, lsc.units; "
            "assert 'pint' not in sys.modules and lsc.units._REGISTRY is None; "
            "lsc.scene.Scene.load({'vehicles': [{'mass': 1, 'speed': 1}, {'mass': 1, 'speed': 0}], "
            "'contacts': [{'loading': {'stiffness': 1}, 'unloading': {'restitution': 0.5}}]}); "
            "assert 'pint' not in sys.modules")  # bare numbers need no registry
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run([sys.executable, "-c", code], check=True, cwd=root)


# ----------------------------------------------------------------- malformed scenes
def _set(d, dotted, value):
    *head, last = dotted.split(".")
    node = d
    for p in head:
        node = node[int(p)] if isinstance(node, list) else node[p]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value


def _del(d, dotted):
    *head, last = dotted.split(".")
    node = d
    for p in head:
        node = node[int(p)] if isinstance(node, list) else node[p]
    del node[last]


def S(*ops):
    """A paper scene with ``ops``: ("set", path, value) / ("del", path)."""
    d = paper()
    for op in ops:
        if op[0] == "set":
            _set(d, op[1], op[2])
        else:
            _del(d, op[1])
    return d


def mass(v):
    return S(("del", "vehicles.0.weight"), ("set", "vehicles.0.mass", v))


LOAD = "contacts.0.loading"
UNLOAD = "contacts.0.unloading"
BAD = [
    ("negative mass", mass(-1), "vehicles[0].mass", "must be > 0"),
    ("zero mass", mass(0), "vehicles[0].mass", "must be > 0, got 0 slug"),
    ("zero weight", S(("set", "vehicles.1.weight", "0 lbf")), "vehicles[1].weight", "must be > 0"),
    ("mass and weight", S(("set", "vehicles.0.mass", 100)), "vehicles[0]", "not both"),
    ("neither", S(("del", "vehicles.1.weight")), "vehicles[1]", "needs its weight (or its mass)"),
    ("missing speed", S(("del", "vehicles.1.speed")), "vehicles[1].speed",
     'is required: expected a velocity (e.g. "10 ft/s"'),
    ("unknown key", S(("set", "vehicles.0.wieght", 1)), "vehicles[0].wieght",
     'unknown key "wieght"; did you mean "weight"? accepted keys: name, weight, mass, speed, brake'),
    ("unknown top key", S(("set", "contact", [])), "contact", 'did you mean "contacts"'),
    ("unknown key, no match", S(("set", "solver", {"xyzzy": 1})), "solver.xyzzy",
     "accepted keys: method, rtol"),
    ("force as speed", S(("set", "vehicles.0.speed", "10 lbf")), "vehicles[0].speed",
     '"10 lbf" is a force, expected a velocity (e.g. "10 ft/s", "16 km/h" or a bare number in ft/s)'),
    ("pound mass as weight", S(("set", "vehicles.0.weight", "3500 lb")), "vehicles[0].weight",
     'is a mass, expected a force'),
    ("nan speed", S(("set", "vehicles.0.speed", float("nan"))), "vehicles[0].speed",
     "not a finite number; expected a finite velocity"),
    ("inf weight", S(("set", "vehicles.1.weight", float("inf"))), "vehicles[1].weight",
     "not a finite number; expected a finite force"),
    ("nan string", S(("set", "vehicles.0.speed", "nan ft/s")), "vehicles[0].speed",
     "expected a finite velocity"),
    ("overflow", S(("set", "vehicles.0.speed", "1e308 mi/s")), "vehicles[0].speed",
     "too large; expected a finite velocity"),
    ("huge int", S(("set", "vehicles.0.speed", 10 ** 400)), "vehicles[0].speed",
     "too large; expected a finite velocity"),
    ("inf restitution", S(("set", UNLOAD + ".restitution", float("inf"))),
     "contacts[0].unloading.restitution", "expected a finite plain number"),
    ("nan in a table", S(("set", LOAD, {"table": [[0, 0], [float("nan"), 5]]})),
     "contacts[0].loading.table[1][0]", "expected a finite length"),
    ("repeated deformation", S(("set", LOAD, {"table": [[0, 0], [0.1, 5], [0.1, 8], [0.2, 9]]})),
     "contacts[0].loading.table", "deformations must be strictly increasing (point 2 has 0.1"),
    ("bool as number", S(("set", "vehicles.0.speed", True)), "vehicles[0].speed", "the boolean true is not"),
    ("bool in table", S(("set", LOAD, {"table": [[0, 0], [1, False]]})), "contacts[0].loading.table[1][1]",
     "boolean false"),
    ("unparseable text", S(("set", "vehicles.0.speed", "fast")), "vehicles[0].speed", 'could not read "fast"'),
    ("unknown unit", S(("set", "vehicles.0.speed", "10 furlongz/s")), "vehicles[0].speed",
     'unknown or unsupported unit "furlongz/s"'),
    ("runaway exponent", S(("set", "vehicles.0.speed", "1 ft^(9^9^9)")), "vehicles[0].speed",
     "unsupported unit"),
    ("None", S(("set", "vehicles.0.speed", None)), "vehicles[0].speed", "None"),
    ("restitution 1.5", S(("set", UNLOAD + ".restitution", 1.5)), "contacts[0].unloading.restitution",
     "between 0 (no rebound) and 1"),
    ("restitution -0.1", S(("set", UNLOAD + ".restitution", -0.1)), "contacts[0].unloading.restitution",
     "got -0.1"),
    ("restitution with unit", S(("set", UNLOAD + ".restitution", "0.4 ft")),
     "contacts[0].unloading.restitution", "is a length, expected a plain number"),
    ("table not increasing", S(("set", LOAD, {"table": [[0, 0], [0.2, 10], [0.1, 20]]})),
     "contacts[0].loading.table", "strictly increasing (point 2 has 0.1 after 0.2)"),
    ("table with one point", S(("set", LOAD, {"table": [[0, 0]]})), "contacts[0].loading.table",
     "at least two points, got 1"),
    ("table not from zero", S(("set", LOAD, {"table": [[0.1, 0], [0.2, 10]]})), "contacts[0].loading.table",
     "starts at zero deformation"),
    ("table negative force", S(("set", LOAD, {"table": [[0, 0], [0.2, -10]]})), "contacts[0].loading.table",
     "never pull"),
    ("table row not a pair", S(("set", LOAD, {"table": [[0, 0], [1, 2, 3]]})), "contacts[0].loading.table[1]",
     "[deformation, force] pair"),
    ("table not a list", S(("set", LOAD, {"table": 5})), "contacts[0].loading.table", "list of"),
    ("text cell with column unit", S(("set", LOAD, {"table": [[0, 0], ["1 in", 5]], "deformation": "in"})),
     "contacts[0].loading.table[1][0]", "give bare numbers"),
    ("column unit wrong kind", S(("set", LOAD, {"table": [[0, 0], [1, 5]], "deformation": "lbf"})),
     "contacts[0].loading.deformation", "is a force, expected a length"),
    ("column unit not text", S(("set", LOAD, {"table": [[0, 0], [1, 5]], "force": 3})),
     "contacts[0].loading.force", "column unit"),
    ("column unit on stiffness", S(("set", LOAD, {"stiffness": 1, "force": "lbf"})),
     "contacts[0].loading.force", "not to stiffness"),
    ("two loading kinds", S(("set", LOAD, {"stiffness": 1, "table": [[0, 0], [1, 1]]})),
     "contacts[0].loading", "only one of stiffness, table, csv or series, got stiffness and table"),
    ("no loading kind", S(("set", LOAD, {})), "contacts[0].loading", "needs one of"),
    ("loading missing", S(("del", LOAD)), "contacts[0].loading", "is required"),
    ("loading not a table", S(("set", LOAD, 24000)), "contacts[0].loading", "expected a table"),
    ("zero stiffness", S(("set", LOAD, {"stiffness": 0})), "contacts[0].loading.stiffness", "must be > 0"),
    ("zero scale", S(("set", LOAD + ".scale", 0)), "contacts[0].loading.scale", "must be > 0"),
    ("series never common force",
     S(("set", LOAD, {"series": [{"table": [[0, 0], [1, 0]]}, {"stiffness": 1000}]})),
     "contacts[0].loading.series", "each must reach a positive force that the other also reaches"),
    ("series falling", S(("set", LOAD, {"series": [{"table": [[0, 0], [1, 5], [2, 1]]}, {"stiffness": 1}]})),
     "contacts[0].loading.series", "non-decreasing"),
    ("series of three", S(("set", LOAD, {"series": [{"stiffness": 1}] * 3})), "contacts[0].loading.series",
     "exactly two loading curves"),
    ("series inner error", S(("set", LOAD, {"series": [{"stiffness": 1}, {"stifness": 1}]})),
     "contacts[0].loading.series[1].stifness", 'did you mean "stiffness"'),
    ("unloading missing", S(("del", UNLOAD)), "contacts[0].unloading", "is required"),
    ("unloading softer", S(("set", UNLOAD, {"stiffness": 20000})), "contacts[0].unloading.stiffness",
     "softer than the loading stiffness 24000 lbf/ft"),
    ("unloading table not ending at zero", S(("set", UNLOAD, {"table": [[1, 100], [0.8, 10]]})),
     "contacts[0].unloading.table", "force exactly 0"),
    ("unloading table increasing", S(("set", UNLOAD, {"table": [[1, 100], [1.2, 0]]})),
     "contacts[0].unloading.table", "strictly decrease"),
    ("unloading table zero start", S(("set", UNLOAD, {"table": [[1, 0], [0.8, 0]]})),
     "contacts[0].unloading.table", "force > 0"),
    ("unloading table one point", S(("set", UNLOAD, {"table": [[1, 0]]})),
     "contacts[0].unloading.table", "at least two points"),
    ("unloading two kinds", S(("set", UNLOAD + ".stiffness", 30000)), "contacts[0].unloading",
     "only one of"),
    ("negative gap", S(("set", "contacts.0.gap", "-1 in")), "contacts[0].gap", "must be >= 0"),
    ("failure without force", S(("set", "contacts.0.failure", {})), "contacts[0].failure.force",
     'is required: expected a force (e.g. "3500 lbf"'),
    ("damping law with IF-D keys", S(("set", "contacts.0.law", "kelvin")), "contacts[0].loading",
     'unknown key "loading"; accepted keys: law, gap, failure, stiffness, damping, restitution'),
    ("kelvin without damping", S(("set", "contacts.0", {"law": "kelvin", "stiffness": 1000})),
     "contacts[0]", "needs exactly one of damping or restitution"),
    ("kelvin e = 0", S(("set", "contacts.0", {"law": "kelvin", "stiffness": 1000,
                                               "restitution": 0})),
     "contacts[0].restitution", "e = 0 needs an infinite damping"),
    ("brach without c2", S(("set", "contacts.0", {"law": "brach", "stiffness": 1000,
                                                   "damping": 3})),
     "contacts[0]", "exactly one of damping_restitution (c2) or restitution"),
    ("unknown law", S(("set", "contacts.0.law", "hysterisis")), "contacts[0].law",
     'did you mean "hysteresis"'),
    ("contact count", S(("set", "contacts", paper()["contacts"] * 2)), "contacts",
     "2 vehicles need 1 contact"),
    ("contacts missing", S(("del", "contacts")), "contacts", "is required"),
    ("contact not a table", S(("set", "contacts", [5])), "contacts[0]", "expected a table"),
    ("one vehicle", S(("set", "vehicles", paper()["vehicles"][:1])), "vehicles", "at least two vehicles"),
    ("vehicle not a table", S(("set", "vehicles.1", "car")), "vehicles[1]", "expected a table"),
    ("vehicle name", S(("set", "vehicles.0.name", 3)), "vehicles[0].name", "text"),
    ("not closing", S(("set", "vehicles.0.speed", 0)), "vehicles[0].speed",
     "not closing and never will: vehicle 1 (bullet, 0 ft/s) is the rear one and must be faster"),
    ("wrong order", S(("set", "vehicles.1.speed", 12)), "vehicles[0].speed", "rear to front"),
    ("brake mu zero", S(("set", "vehicles.0.brake", {"mu": 0})), "vehicles[0].brake.mu", "must be > 0"),
    ("brake static below", S(("set", "vehicles.0.brake", {"mu": 0.7, "mu_static": 0.5})),
     "vehicles[0].brake.mu_static", "must be >= mu"),
    ("unknown method", S(("set", "solver", {"method": "rk4"})), "solver.method",
     'unknown solver method "rk4"; accepted: auto, closed-form'),
    ("method typo", S(("set", "solver", {"method": "scpiy"})), "solver.method", 'did you mean "scipy"'),
    ("negative dt", S(("set", "solver", {"dt": -1e-5})), "solver.dt", "must be > 0"),
    ("dt not a time", S(("set", "solver", {"dt": "1 ft"})), "solver.dt", "expected a time"),
    ("zero rtol", S(("set", "solver", {"rtol": 0})), "solver.rtol", "must be > 0"),
    ("negative rtol", S(("set", "solver", {"rtol": -1e-8})), "solver.rtol", "must be > 0"),
    ("zero max_events", S(("set", "solver", {"max_events": 0})), "solver.max_events", "must be > 0"),
    ("fractional max_steps", S(("set", "solver", {"max_steps": 1.5})), "solver.max_steps",
     "must be a whole number >= 1"),
    ("fractional max_events", S(("set", "solver", {"max_events": 2.5})), "solver.max_events", "whole number"),
    ("empty integrator", S(("set", "solver", {"integrator": ""})), "solver.integrator", "DOP853"),
    ("unknown units", S(("set", "units", "metric")), "units", 'unknown unit system "metric"'),
    ("units typo", S(("set", "units", "UK")), "units", 'did you mean "US"'),
    ("g a length", S(("set", "g", "9.81 m")), "g", "is a length, expected an acceleration"),
    ("g zero", S(("set", "g", 0)), "g", "must be > 0"),
    ("name not text", S(("set", "name", 1)), "name", "text"),
    ("non-text key", {**paper(), 1: 2}, "", "keys must be text"),
]


@pytest.mark.parametrize("scene, path, phrase", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_malformed(scene, path, phrase):
    with pytest.raises(SceneError) as ei:
        Scene.load(scene)
    assert ei.value.path == path
    assert phrase in ei.value.message
    assert str(ei.value).startswith(path + ": " if path else "")


def test_catalogue_covers_the_issue():
    """At least 40 malformed scenes, one per kind of mistake; each says what is accepted."""
    assert len(BAD) + len(CSV_BAD) + len(SOLVE_BAD) >= 40
    assert len({b[0] for b in BAD}) == len(BAD)


# CSV tables: (name, file text or None for a missing file, accepted-values phrase)
CSV_BAD = [
    ("csv missing", None, "expected a CSV file of two columns, deformation and force"),
    ("csv empty", "", "expected two columns: deformation, force"),
    ("csv header only", "D, F\n", "expected two columns: deformation, force"),
    ("csv non-numeric cell", "D,F\n0,0\n1,abc\n", "expected two numeric columns (deformation, force)"),
    ("csv three columns", "0,0\n1,2,3\n", "expected 2 columns (deformation, force)"),
    ("csv nan", "0,0\nnan,1\n", "expected two finite numeric columns"),
    ("csv not increasing", "0,0\n1,5\n0.5,6\n", "strictly increasing"),
    ("csv one row", "0,0\n", "at least two points"),
]


def _csv_message(tmp_path, text, name="c.csv"):
    """The SceneError message of the paper scene loading from CSV file ``name`` holding
    ``text`` (None: no file written); the error's path must be the csv field."""
    if text is not None:
        (tmp_path / name).write_text(text)
    d = paper()
    d["contacts"][0]["loading"] = {"csv": name}
    with pytest.raises(SceneError) as ei:
        Scene.load(d, base_dir=tmp_path)
    assert ei.value.path == "contacts[0].loading.csv"
    return ei.value.message


@pytest.mark.parametrize("text, phrase", [b[1:] for b in CSV_BAD], ids=[b[0] for b in CSV_BAD])
def test_malformed_csv(tmp_path, text, phrase):
    assert phrase in _csv_message(tmp_path, text, "missing.csv" if text is None else "c.csv")


# lsc.solve options: (name, options, path, accepted-values phrase)
SOLVE_BAD = [
    ("unknown method", {"method": "rk4"}, "solver.method", "accepted: 'auto', 'closed-form'"),
    ("negative dt", {"method": "reference", "dt": -1e-5}, "solver.dt",
     "dt must be a positive finite number"),
    ("negative rtol", {"method": "scipy", "rtol": -1e-8}, "solver.rtol",
     "rtol must be a positive finite number"),
    ("nan rtol", {"method": "scipy", "rtol": float("nan")}, "solver.rtol", "positive finite number"),
    ("rtol below 100 eps", {"method": "scipy", "rtol": 1e-16}, "solver.rtol",
     "accept rtol >= 100 machine epsilons"),
    ("unknown integrator", {"method": "scipy", "integrator": "RK4"}, "solver.integrator",
     "accepted: RK45, DOP853"),
    ("option of another method", {"method": "exact", "dt": 1e-5}, "solver.dt",
     "it accepts: max_events, n_samples, t_end"),
    ("zero max_steps", {"method": "scipy", "max_steps": 0}, "solver.max_steps",
     "max_steps must be a positive integer"),
    ("method that does not apply", {"method": "closed-form"}, "solver.method",
     "use method 'scipy' (or 'auto')"),
]


@pytest.mark.parametrize("options, path, phrase", [b[1:] for b in SOLVE_BAD],
                         ids=[b[0] for b in SOLVE_BAD])
def test_malformed_solve_options(options, path, phrase):
    import lsc

    scene = paper()
    if options.get("method") == "closed-form":
        scene["contacts"][0]["loading"] = {"table": [[0, 0], [1, 24000]]}
    with pytest.raises(SceneError) as ei:
        lsc.solve(scene, **options)
    assert ei.value.path == path
    assert phrase in ei.value.message


def _toml(obj, prefix="") -> str:
    """A scene dict as TOML (tables, arrays of tables, strings, numbers, booleans, lists)."""
    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (int, float)):
            return repr(v)
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {val(x)}" for k, x in v.items()) + " }"
        raise TypeError(type(v))
    lines, tables = [], []
    for k, v in obj.items():
        if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.append((k, v))
        elif isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {val(v)}")
    for k, v in tables:
        for item in (v if isinstance(v, list) else [v]):
            lines.append(f"[[{k}]]" if isinstance(v, list) else f"[{k}]")
            lines.extend(f"{kk} = {val(x)}" for kk, x in item.items())
    return "\n".join(lines) + "\n"


#: A sample of the catalogue that TOML can spell, through the command line.
CLI_SAMPLE = ["zero mass", "mass and weight", "missing speed", "unknown key", "force as speed",
              "restitution 1.5", "table not increasing", "repeated deformation",
              "table with one point", "series never common force", "contact count",
              "not closing", "unknown method", "negative dt", "zero rtol", "unknown units"]


@pytest.mark.parametrize("name", CLI_SAMPLE)
def test_cli_one_line_exit_2(tmp_path, capsys, name):
    from lsc.cli import main

    scene, path = next((b[1], b[2]) for b in BAD if b[0] == name)
    f = tmp_path / "bad.toml"
    f.write_text(_toml(scene))
    rc = main(["run", str(f), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith(f"lsc: error: {path}: "), err
    assert not (tmp_path / "o").exists()


def test_chain_not_closing():
    d = paper()
    d["vehicles"] = [{"weight": 3000, "speed": s} for s in (1, 2, 3)]
    d["contacts"] = [copy.deepcopy(d["contacts"][0]) for _ in range(2)]
    with pytest.raises(SceneError) as ei:
        Scene.load(d)
    assert ei.value.path == "vehicles[0].speed"
    assert "no vehicle is faster than the one in front" in ei.value.message


def test_csv_errors(tmp_path):
    def load(text, name="c.csv"):
        return _csv_message(tmp_path, text, name)

    assert "file not found" in load(None, "missing.csv") and "missing.csv" in load(None, "missing.csv")
    assert "no data rows" in load("")
    assert "no data rows" in load("D, F\n")
    assert 'line 3: "abc" is not a number' in load("D,F\n0,0\n1,abc\n")
    assert "c.csv, line 2: expected 2 columns" in load("0,0\n1,2,3\n")
    assert 'line 2: "nan" is not a finite number' in load("0,0\nnan,1\n")
    assert "strictly increasing" in load("0,0\n1,5\n0.5,6\n")
    assert "cannot read" in load(None, ".")  # a folder


def test_bad_inputs():
    with pytest.raises(SceneError, match="scene file not found"):
        Scene.load("/nonexistent/scene.toml")
    with pytest.raises(SceneError, match="dict, a TOML file path"):
        Scene.load(42)
    with pytest.raises(SceneError) as ei:
        Scene.load([1, 2])
    assert ei.value.path == ""
    with pytest.raises(SceneError, match="with_values needs a scene made by Scene.load"):
        Scene("x", "SI", 9.8, (), ()).with_values({"a": 1})


def test_invalid_toml(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("units = \n")
    with pytest.raises(SceneError, match="not valid TOML") as ei:
        Scene.load(p)
    assert ei.value.path == ""


def test_scene_error_is_value_error():
    with pytest.raises(ValueError):
        Scene.load(S(("set", "units", "metric")))


# ----------------------------------------------------------------- fuzz
UNIT_STRINGS = ["10 ft/s", "16 km/h", "3500 lbf", "3500 lb", "24000 lbf/ft", "1.2 in", "0 in", "-3 m",
                "32.2 ft/s^2", "nan", "inf lbf", "1e999 N", "10 lbf", "0.4", "40 %", "ft", "", " ", "1 s",
                "1 ft^(9^9^9)", "2 kg", "1e-300 N/m", "1e300 N/m", "5 mph", "1 degC", "auto", "US", "SI",
                "hysteresis", "kelvin", "scipy", "edge.csv", "missing.csv"]
SPECS = [{"stiffness": 1000}, {"restitution": 0.2}, {"table": [[0, 0], [0.1, 100]]},
         {"table": [[0.2, 100], [0.1, 0]]}, {"series": [{"stiffness": 1}, {"stiffness": 2}]},
         {"csv": "edge.csv", "deformation": "in"}, {"mu": 0.5}, {"force": 100}, {}, []]

leaf = st.one_of(
    st.none(), st.booleans(), st.integers(), st.floats(),
    st.floats(min_value=-1e4, max_value=1e4), st.text(max_size=12), st.sampled_from(UNIT_STRINGS))
values = st.recursive(
    st.one_of(leaf, st.sampled_from(SPECS).map(copy.deepcopy)),
    lambda inner: st.one_of(st.lists(inner, max_size=4),
                            st.dictionaries(st.one_of(st.text(max_size=8), st.sampled_from(
                                ["stiffness", "table", "mass", "speed", "restitution", "law", "gap"])),
                                inner, max_size=3)),
    max_leaves=8)


#: Values of every wrong kind, for any key: nothing, booleans, garbage text, numbers of every sign
#: and size, containers, quantities of the wrong unit, text after a quantity.
WRONG = [None, True, False, "", " ", "fast", "1_0", "0x10", "nan", "inf", "-inf", "1e999", "1e308",
         "1e-308", "5e-324", -1, 0, 0.0, -0.0, -1e-9, float("nan"), float("inf"), -float("inf"),
         1e308, -1e308, 1e-308, 5e-324, 10 ** 400, 1e100, 1e-100, [], [1, 2], [[0, 0]], {}, {"x": 1},
         "10 lbf", "10 ft/s", "3500 lb", "24000 lbf/ft", "1 s", "0.2 s/m", "300 N*s/m", "2 kg",
         "1 ft^(9^9^9)", "12 mph # 10 ft/s", "10 ft/s ± 1", "10 ft/s 5", "1 degC"]


def _derived(value) -> list:
    """Wrong values made from a key's own (right) value: trailing text, wrong unit, sign, scale."""
    if isinstance(value, bool) or value is None:
        return [not value]
    if isinstance(value, str):
        return [value + " # 10", value + " ± 1", value + " 5", value + " lbf", "-" + value, value + "_0"]
    if isinstance(value, int):
        return [-value, value * 10 ** 300, f"{value} furlong", f"{value} # note", f"{value} s",
                f"{value}_0", [value]]
    if isinstance(value, float):
        return [-value, value * 1e300, value * 1e-300, f"{value} furlong", f"{value} # note",
                f"{value} s", str(value).replace(".", "_"), [value]]
    if isinstance(value, list):
        return [value[:1], value * 3, [value], {"table": value}]
    return [list(value), {k: None for k in value}]


def _wrong(value):
    """A strategy for a wrong value in place of ``value``."""
    return st.one_of(st.sampled_from(WRONG).map(copy.deepcopy),
                     st.sampled_from(_derived(copy.deepcopy(value))).map(copy.deepcopy), values)


def _bases():
    """Scenes that hold every key of the scene format between them (each key at least once)."""
    chain = paper()
    chain["vehicles"].append({"mass": 50, "speed": -1, "brake": {"mu": 0.5, "mu_static": 0.6}})
    chain["contacts"].append({"loading": {"csv": "edge.csv", "deformation": "in", "force": "lbf"},
                              "unloading": {"table": [[0.3, 100], [0.2, 0]]}, "gap": "1 in",
                              "failure": {"force": "5 kip", "post_failure": {"stiffness": 100}}})
    chain["solver"] = {"method": "scipy", "rtol": 1e-8, "atol": 1e-9, "dt": "1 ms", "max_events": 10,
                       "integrator": "RK45", "t_end": "1 s", "max_steps": 10000, "n_samples": 50}
    series = si()
    series["contacts"][0]["loading"] = {"series": [{"table": [[0, 0], [0.1, 1000], [0.2, 1500]]},
                                                   {"stiffness": 2e5}], "scale": 1.1}
    series["contacts"][0]["unloading"] = {"stiffness": "1 MN/m"}
    tables = paper()
    tables["contacts"][0] = {"loading": {"table": [[0, 0], [1.2, 3000], [2.4, 9000]], "deformation": "in",
                                         "force": "lbf"},
                             "unloading": {"table": [[30, 9], [20, 0]], "deformation": "mm", "force": "kN"},
                             "failure": {"force": "8000 lbf"}}
    tables["uncertainty"] = {"vehicles.0.speed": {"uniform": ["4 ft/s", "7 ft/s"]}}
    tables["solver"] = {"method": "exact", "n_samples": 20, "max_events": 100, "t_end": 0.5}
    kelvin, hunt, brach = paper(), paper(), paper()
    kelvin["contacts"][0] = {"law": "kelvin", "stiffness": 24000, "damping": "300 lbf*s/ft", "gap": 0.1}
    hunt["contacts"][0] = {"law": "hunt-crossley", "stiffness": "60000 lbf/ft^1.5", "exponent": 1.5,
                           "restitution": 0.4}
    brach["contacts"][0] = {"law": "brach", "stiffness": 24000, "damping": "2000 lbf*s/ft^2",
                            "damping_restitution": 500, "failure": {"force": 1e5}}
    return [paper(), chain, series, tables, kelvin, hunt, brach]


#: Result fields that an accepted solve must hold finite (NaN-free), whatever the scene.
FINITE = ("t", "x", "v", "delta_v", "v_final", "duration", "peak_force", "max_deformation",
          "peak_acceleration")


def _slots(obj, out):
    """Every (container, key) in a nested scene."""
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for k, v in items:
        out.append((obj, k))
        _slots(v, out)
    return out


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    (d / "edge.csv").write_text("D,F\n0,0\n1.2,3000\n2.4,9000\n")
    return d


#: Loader fuzzing: 10,000 examples by default, 200,000 in hard mode (``pytest --hard`` /
#: LSC_HARD=1); ``LSC_FUZZ_EXAMPLES`` sets the count outright.
FUZZ_EXAMPLES = int(os.environ.get("LSC_FUZZ_EXAMPLES") or (200_000 if HARD else 10_000))


def _mutate(scene: dict, data) -> None:
    """Replace (with a wrong value, mostly), delete or add keys anywhere in ``scene``."""
    for _ in range(data.draw(st.integers(1, 3))):
        slots = _slots(scene, [(None, None)])
        parent, key = data.draw(st.sampled_from(slots))
        op = data.draw(st.sampled_from(["wrong", "wrong", "wrong", "replace", "delete", "add"]))
        if parent is None or op == "add":
            target = parent[key] if parent is not None else scene
            if isinstance(target, dict):
                target[data.draw(st.one_of(st.text(max_size=10), st.sampled_from(
                    ["mass", "weight", "brake", "failure", "law", "scale", "force", "deformation", "csv",
                     "exponent", "damping", "damping_restitution", "gap", "uncertainty", "solver"])))] = \
                    data.draw(values)
            elif isinstance(target, list):
                target.append(data.draw(values))
        elif op == "delete":
            del parent[key]
        elif op == "wrong":
            parent[key] = data.draw(_wrong(parent[key]))
        else:
            parent[key] = data.draw(values)


def _solve_cheaply(s: Scene, data):
    """Solve a loaded scene with the backend auto picks: every closed-form and exact one; one in
    twenty of those that need the integrator (at a loose tolerance), to keep the run short."""
    import lsc
    from lsc.solvers import pick

    if pick(s, "auto") == "scipy":
        if data.draw(st.integers(0, 19), label="solve with scipy") != 0:
            return None
        return lsc.solve(s, method="scipy", rtol=1e-6, n_samples=20, max_steps=20_000)
    return lsc.solve(s, method="auto", n_samples=20)


@settings(max_examples=FUZZ_EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(data=st.data())
def test_fuzz_only_scene_errors(data, fuzz_dir):
    """Any key of the scene format given a wrong value (of every kind), deleted or joined by an
    unknown one: loading, and solving what loads, ends in a finite Result or a SceneError or
    SimulationError, never another exception."""
    from lsc.errors import SimulationError

    scene = data.draw(st.sampled_from(_bases()))
    _mutate(scene, data)
    try:
        s = Scene.load(scene, base_dir=fuzz_dir)
    except SceneError as e:
        assert isinstance(e.path, str) and e.message
        event("SceneError")
        return
    event("loaded")
    assert isinstance(s, Scene)
    assert np.all(np.isfinite(s.masses)) and np.all(s.masses > 0) and np.all(np.isfinite(s.speeds))
    assert len(s.contacts) == s.n_vehicles - 1
    assert math.isfinite(s.g) and s.g > 0
    # a loaded scene re-loads from its own source to the same numbers
    s2 = s.with_values({})
    np.testing.assert_array_equal(s2.masses, s.masses)
    try:
        r = _solve_cheaply(s, data)
    except (SceneError, SimulationError) as e:
        event(type(e).__name__ + " on solving")
        return
    if r is None:
        return
    event("solved")
    for name in FINITE:
        assert np.all(np.isfinite(getattr(r, name))), (name, getattr(r, name))


def test_unloading_branch_from_a_csv_equals_the_same_table(tmp_path):
    """``unloading = { csv = ... }`` (with column units) is the unloading table it holds: the
    crash is the same to the last bit; its rows get the unloading table's checks."""
    import lsc
    table = [[3.6, 9000.0], [2.4, 4000.0], [1.44, 0.0]]   # deformation in inches
    (tmp_path / "rebound.csv").write_text("deformation [in],force [lbf]\n"
                                          + "".join(f"{d},{f}\n" for d, f in table))
    base = {"units": "US", "g": "32.2 ft/s^2",
            "vehicles": [{"weight": 3500, "speed": 10}, {"weight": 3500, "speed": 0}],
            "contacts": [{"loading": {"stiffness": 24000},
                          "unloading": {"table": table, "deformation": "in"}}]}
    from_csv = copy.deepcopy(base)
    from_csv["contacts"][0]["unloading"] = {"csv": "rebound.csv", "deformation": "in"}
    a = lsc.solve(base, method="exact")
    b = lsc.solve(lsc.Scene.load(from_csv, base_dir=tmp_path), method="exact")
    np.testing.assert_array_equal(a.delta_v, b.delta_v)
    np.testing.assert_array_equal(a.permanent_deformation, b.permanent_deformation)
    (tmp_path / "bad.csv").write_text("0.1,100\n0.2,0\n")
    from_csv["contacts"][0]["unloading"] = {"csv": "bad.csv"}
    with pytest.raises(lsc.SceneError) as e:
        lsc.Scene.load(from_csv, base_dir=tmp_path)
    assert str(e.value) == ("contacts[0].unloading.csv: deformation must strictly decrease along "
                            "the rebound (in time order); point 1 has 0.2 after 0.1")


# ----------------------------------------------------------------- import structure
def _lsc_imports() -> dict:
    """Module → the lsc modules it imports anywhere (module level or inside functions)."""
    import ast
    import pathlib

    import lsc

    root = pathlib.Path(lsc.__file__).parent
    graph = {}
    for file in root.rglob("*.py"):
        rel = file.relative_to(root.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        package = name if file.name == "__init__.py" else name.rsplit(".", 1)[0]
        out = set()
        for node in ast.walk(ast.parse(file.read_text("utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = package
                for _ in range(node.level - 1):
                    base = base.rsplit(".", 1)[0]
                target = (f"{base}.{node.module}" if node.module else base) if node.level \
                    else node.module or ""
                out.add(target)
            elif isinstance(node, ast.Import):
                out.update(alias.name for alias in node.names)
        graph[name] = {t for t in out if t.startswith("lsc")}
    return graph


def test_scene_units_laws_and_effects_are_in_no_import_circle():
    """The scene loader reads units, laws and effects; none of them (nor the display of
    speeds) imports the scene back, even inside a function."""
    graph = _lsc_imports()
    owners = sorted(m for m in graph if (m + ".").split(".")[1] in ("scene", "units", "laws", "effects",
                                                              "contact", "display"))

    def reaches(start, goal, seen):
        for nxt in graph.get(start, ()):
            nxt = nxt if nxt in graph else nxt.rsplit(".", 1)[0]
            if nxt == goal or (nxt not in seen and not seen.add(nxt)
                               and reaches(nxt, goal, seen)):
                return True
        return False
    circles = [m for m in owners if reaches(m, m, set())]
    assert circles == []
