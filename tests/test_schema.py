"""The scene schema (lsc.schema): generated from the loader, shipped, printed by `lsc schema`;
every packaged and docs scene validates, and the malformed scenes it can see fail it."""

import json
import re
import tomllib

import pytest

jsonschema = pytest.importorskip("jsonschema", reason="jsonschema (the [test] extra) validates "
                                 "scenes against the schema")

from lsc import Scene, SceneError, cli, data  # noqa: E402
from lsc.schema import scene_schema, shipped_schema  # noqa: E402
from test_scene import BAD, S  # noqa: E402
from helpers import ROOT  # noqa: E402
VALIDATOR = jsonschema.Draft202012Validator(scene_schema())


def test_schema_is_valid_draft_2020_12():
    jsonschema.Draft202012Validator.check_schema(scene_schema())
    assert scene_schema()["$schema"] == "https://json-schema.org/draft/2020-12/schema"


def test_shipped_file_equals_the_generated_schema():
    """A change of the loader's tables not regenerated into the shipped file fails here:
    regenerate with `python -m lsc schema --out lsc/data/scene.schema.json --overwrite`."""
    assert shipped_schema() == scene_schema()


def test_cli_prints_the_schema(capsys):
    assert cli.main(["schema"]) == 0
    assert json.loads(capsys.readouterr().out) == scene_schema()


def test_cli_writes_the_schema_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert cli.main(["schema", "--out", str(out)]) == 0
    assert json.loads(out.read_text("utf-8")) == scene_schema()
    assert cli.main(["schema", "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err


def _docs_blocks():
    """The TOML code blocks of docs/scenes.rst, each laid over the default scene (a block's
    top-level keys replace the scene's: a ``[[contacts]]`` block becomes its one contact)."""
    text = (ROOT / "docs" / "scenes.rst").read_text("utf-8")
    blocks = re.findall(r"\.\. code-block:: toml\n\n((?:(?:   .*)?\n)+)", text)
    base = tomllib.loads(data.path("default").read_text("utf-8"))
    return [{**base, **tomllib.loads("\n".join(line[3:] for line in b.splitlines()))}
            for b in blocks]


SCENES = ([(f"lsc.data:{n}", tomllib.loads(data.path(n).read_text("utf-8"))) for n in data.names()]
          + [(f"docs/examples/{p.name}", tomllib.loads(p.read_text("utf-8")))
             for p in sorted((ROOT / "docs" / "examples").glob("*.toml"))]
          + [(f"docs/scenes.rst block {i}", b) for i, b in enumerate(_docs_blocks())])


@pytest.mark.parametrize("name, scene", SCENES, ids=[s[0] for s in SCENES])
def test_good_scenes_validate(name, scene):
    errors = [f"{'/'.join(map(str, e.absolute_path))}: {e.message}" for e in VALIDATOR.iter_errors(scene)]
    assert errors == []
    Scene.load(scene, base_dir=ROOT / "docs" / "examples")  # and the loader accepts it


def test_every_docs_block_is_checked():
    text = (ROOT / "docs" / "scenes.rst").read_text("utf-8")
    assert len(_docs_blocks()) == text.count(".. code-block:: toml") >= 6


def test_every_packaged_scene_is_checked():
    assert {s[0] for s in SCENES} >= {f"lsc.data:{n}" for n in data.names()}
    assert len(data.names()) >= 6


# The malformed scenes of tests/test_scene.py the schema must refuse: unknown keys, wrong types,
# missing or doubled keys, one-of choices, names (method, units, law) and the ranges of plain
# numbers. The rest of that catalogue is beyond a schema: a quantity's dimension ("10 lbf" as a
# speed), units pint must parse, non-finite values, a table's order and shape (increasing, from
# zero, ending at zero force), series that never share a force, an unloading softer than its
# loading, cross-field counts (contacts = vehicles - 1), closing speeds and vehicle order,
# mu_static >= mu, and the range of a value given with a unit ("-1 in", "0 lbf").
SCHEMA_CATCHES = [
    "negative mass", "zero mass", "mass and weight", "neither", "missing speed", "unknown key",
    "unknown top key", "unknown key, no match", "bool as number", "bool in table",
    "unparseable text", "None", "restitution 1.5", "restitution -0.1", "table row not a pair",
    "table not a list", "column unit not text", "column unit on stiffness", "two loading kinds",
    "no loading kind", "loading missing", "loading not a table", "zero stiffness", "zero scale",
    "series of three", "series inner error", "unloading missing", "unloading two kinds",
    "failure without force", "damping law with IF-D keys", "kelvin without damping",
    "kelvin e = 0", "brach without c2", "unknown law", "contacts missing", "contact not a table",
    "one vehicle", "vehicle not a table", "vehicle name", "brake mu zero", "unknown method",
    "method typo", "negative dt", "zero rtol", "negative rtol", "zero max_events",
    "fractional max_steps", "fractional max_events", "empty integrator", "unknown units",
    "units typo", "g zero", "name not text", "table with one point", "unloading table one point",
]
_BAD = {b[0]: b[1] for b in BAD}
VEHICLES = S()["vehicles"]
MORE_BAD = [  # beyond the loader's catalogue: the schema's own one-of and name checks
    ("vehicles missing", {k: v for k, v in S().items() if k != "vehicles"}),
    ("unloading with no kind", S(("set", "contacts.0.unloading", {}))),
    ("loading with csv and series", S(("set", "contacts.0.loading",
                                       {"csv": "a.csv", "series": [{"stiffness": 1}] * 2}))),
    ("kelvin with both", S(("set", "contacts.0", {"law": "kelvin", "stiffness": 1, "damping": 1,
                                                  "restitution": 0.5}))),
    ("hunt-crossley with c2", S(("set", "contacts.0", {"law": "hunt-crossley", "stiffness": 1,
                                                       "damping": 1, "damping_restitution": 1}))),
    ("bad speed unit", S(("set", "display", {"speed_unit": "knots"}))),
    ("n_samples too many", S(("set", "solver", {"n_samples": 10**7}))),
    ("rtol one", S(("set", "solver", {"rtol": 1}))),
    ("first_step in a scene", S(("set", "solver", {"first_step": 1e-6}))),
    ("uncertainty not a table", S(("set", "uncertainty", 3))),
]


@pytest.mark.parametrize("name", SCHEMA_CATCHES)
def test_catalogue_of_bad_scenes_fails_the_schema(name):
    scene = _BAD[name]
    with pytest.raises(SceneError):
        Scene.load(scene)  # the loader refuses it too
    assert not VALIDATOR.is_valid(scene)


@pytest.mark.parametrize("name, scene", MORE_BAD, ids=[b[0] for b in MORE_BAD])
def test_more_bad_scenes_fail_both(name, scene):
    with pytest.raises(SceneError):
        Scene.load(scene)
    assert not VALIDATOR.is_valid(scene)


def test_the_base_of_the_catalogue_is_valid():
    """Each bad scene is one change away from a scene the schema accepts."""
    assert VALIDATOR.is_valid(S())


def test_names_are_matched_as_the_loader_normalises_them():
    for scene in (S(("set", "units", " us ")), S(("set", "solver", {"method": "Closed_Form"})),
                  S(("set", "contacts.0.law", "IF-D")), S(("set", "vehicles.0.speed", "10 mph"))):
        Scene.load(scene)
        assert VALIDATOR.is_valid(scene)
