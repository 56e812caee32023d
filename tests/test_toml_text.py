"""The one TOML writer (lsc.toml_text) behind lsc.report.to_toml (the scene as given, in a
report) and lsc.analysis.scene_toml (a fitted scene): what it writes reads back as the same
table, NumPy numbers as the numbers they are."""

import datetime
import math
import tomllib

import numpy as np
import pytest

import lsc
from lsc.analysis import scene_toml
from lsc.report import to_toml
from lsc.toml_text import to_toml as toml_text

SOURCE = {
    "name": "Zürich \"rear\" test",
    "units": "SI",
    "tested": datetime.date(2024, 5, 17),
    "vehicles": [{"name": "bullet", "mass": np.float64(1500.0), "speed": np.float32(4.5)},
                 {"name": "target", "mass": np.int64(1200), "speed": 0, "braked": np.bool_(True)}],
    "contacts": [{"loading": {"table": np.array([[0.0, 0.0], [0.05, 2.0e4]])},
                  "unloading": {"restitution": 0.4}, "gap": -0.0}],
    "solver": {"method": "scipy", "rtol": 1e-10, "limit": math.inf},
    "weird key": {"a.b": 1},
}


def _plain(node):
    """``node`` with NumPy numbers and arrays as the Python numbers and lists they hold."""
    if isinstance(node, dict):
        return {k: _plain(v) for k, v in node.items()}
    if isinstance(node, (list, tuple, np.ndarray)):
        return [_plain(v) for v in node]
    return node.item() if isinstance(node, np.generic) else node


@pytest.mark.parametrize("write", [to_toml, toml_text])
def test_numpy_numbers_read_back_as_the_same_numbers(write):
    back = tomllib.loads(write(SOURCE))
    assert back == _plain(SOURCE)
    assert type(back["vehicles"][1]["mass"]) is int and type(back["vehicles"][0]["mass"]) is float
    assert back["vehicles"][1]["braked"] is True


def test_a_value_toml_cannot_hold_is_refused_or_written_by_default():
    with pytest.raises(lsc.SceneError, match=r"^cannot write builtin_function_or_method <built-in "
                                             r"function print> as TOML$"):
        toml_text({"f": print})
    assert toml_text({"f": print}, default=lambda v: "printed") == 'f = "printed"\n'
    # the report names a Python function of an [uncertainty] table by "module:name"
    assert tomllib.loads(to_toml({"f": print})) == {"f": "builtins:print"}


def test_a_fitted_scene_with_numpy_values_loads_back_as_the_same_scene(tmp_path):
    scene = lsc.Scene.load({
        "units": "SI",
        "vehicles": [{"mass": np.float64(1500.0), "speed": np.float64(4.5)},
                     {"mass": np.int64(1200), "speed": 0}],
        "contacts": [{"loading": {"stiffness": np.float64(3.0e5)},
                      "unloading": {"restitution": np.float64(0.4)}}]})
    again = lsc.Scene.load(tomllib.loads(scene_toml(scene, tmp_path / "s.toml")))
    assert lsc.solve(again).delta_v.tolist() == lsc.solve(scene).delta_v.tolist()
    assert tomllib.loads((tmp_path / "s.toml").read_text(encoding="utf-8")) == \
        _plain(scene.source)
