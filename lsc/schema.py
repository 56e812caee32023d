"""A JSON Schema (draft 2020-12) of the scene format, generated from the loader's own tables.

:func:`scene_schema` builds it from the key tables of :mod:`lsc.scene` (the same tuples the loader
checks a scene against), the declarations of the contact laws (:mod:`lsc.laws`) and effects
(:mod:`lsc.effects`) the loader reads them by, the solver options' ranges of :mod:`lsc.solvers`
and the speed units of :mod:`lsc.display`, so the two cannot drift apart. The package ships it as
``lsc/data/scene.schema.json`` (regenerate with ``python -m lsc schema --out
lsc/data/scene.schema.json``; a test checks that the file equals :func:`scene_schema`).

The schema checks the shape of a scene: its keys, their types, the one-of choices (``weight`` or
``mass``, one loading kind, one unloading kind, ``damping`` or ``restitution``) and the ranges of
plain numbers. What needs the physics or the units (a quantity's dimension, the closing speeds,
the gap against the crush, a table's shape, CSV files) only the loader checks.
"""

from __future__ import annotations

import json
from importlib import resources

from .display import SPEED_UNITS
from .effects import FailureEffect, vehicle_effect_classes
from .laws import REQUIRED, aliases, law_class, laws
from .scene import _parts, _scene, _tables
from .solvers import ALL_OPTIONS, MAX_SAMPLES, METHODS
from .units import _NUMBER_TEXT, UNITS

__all__ = ["scene_schema", "schema_text", "SCHEMA_ID", "shipped_schema"]

#: The schema's ``$id``.
SCHEMA_ID = "https://lsc.invalid/scene.schema.json"

#: A quantity given as text: a number, optionally followed by a unit (``"10 mph"``, ``"3500 lbf"``).
QUANTITY_PATTERN = rf"^\s*{_NUMBER_TEXT}\s*(?:[^\s0-9].*)?$"


def _name_pattern(names) -> str:
    """A pattern matching ``names`` as the loader normalises them: any case, ``-`` written as
    ``-``, ``_`` or a space, blanks around (ECMAScript regex: no inline flags)."""
    def one(name: str) -> str:
        return "".join("[-_ ]" if c == "-" else (f"[{c.lower()}{c.upper()}]" if c.isalpha()
                                                 else "\\" + c if not c.isalnum() else c)
                       for c in name)
    return r"^\s*(?:" + "|".join(one(n) for n in names) + r")\s*$"


def _name(names, description: str) -> dict:
    return {"type": "string", "pattern": _name_pattern(names), "description": description}


def _quantity(kind: str, description: str, minimum: float | None = None,
              exclusive: bool = True, maximum: float | None = None) -> dict:
    """A number in the scene's unit of ``kind``, or a string "number unit"."""
    number: dict = {"type": "number"}
    if minimum is not None:
        number["exclusiveMinimum" if exclusive else "minimum"] = minimum
    if maximum is not None:
        number["maximum"] = maximum
    return {"description": f"{description} [{kind}: a number in the scene's unit, or text "
                           f"\"<number> <unit>\"]",
            "anyOf": [number, {"$ref": "#/$defs/quantity_text"}]}


def _object(keys, properties: dict, description: str, required=()) -> dict:
    """A table holding only ``keys`` (in the loader's order)."""
    missing = set(keys) - set(properties)
    assert not missing, f"no schema for keys {missing}"
    out = {"type": "object", "description": description,
           "properties": {k: properties[k] for k in keys}, "additionalProperties": False}
    if required:
        out["required"] = list(required)
    return out


def _one_of(kinds) -> list[dict]:
    return [{"required": [k]} for k in kinds]


def _loading() -> dict:
    pair = {"type": "array", "minItems": 2, "maxItems": 2,
            "prefixItems": [_quantity("length", "deformation"), _quantity("force", "force")],
            "items": False}
    props = {
        "stiffness": _quantity("stiffness", "a straight loading line F = k D", 0),
        "table": {"type": "array", "minItems": 2, "items": pair,
                  "description": "[deformation, force] pairs, from the origin"},
        "csv": {"type": "string", "minLength": 1,
                "description": "a CSV file of two columns (deformation, force); a relative path "
                               "is taken from the scene file's folder"},
        "series": {"type": "array", "minItems": 2, "maxItems": 2,
                   "items": {"$ref": "#/$defs/loading"},
                   "description": "two loading curves in series (springs one after the other)"},
        "scale": _quantity("dimensionless", "a factor on the curve's forces", 0),
        "deformation": {"type": "string", "description": "the unit of a table's or csv's "
                                                         "deformation column"},
        "force": {"type": "string", "description": "the unit of a table's or csv's force column"},
    }
    out = _object(_tables._LOADING_KEYS, props, "a loading curve: exactly one of "
                  + ", ".join(_tables._LOADING_KINDS))
    out["oneOf"] = _one_of(_tables._LOADING_KINDS)
    out["allOf"] = [_columns_only_with_tables(_tables._LOADING_KINDS)]
    return out


def _columns_only_with_tables(kinds) -> dict:
    """Column units (``deformation``, ``force``) only beside a ``table`` or a ``csv``."""
    others = [k for k in kinds if k not in ("table", "csv")]
    return {"if": {"anyOf": _one_of(_tables._COLUMN_KEYS)},
            "then": {"not": {"anyOf": _one_of(others)}}}


def _unloading() -> dict:
    loading = _loading()["properties"]
    props = dict(loading, restitution=_quantity(
        "dimensionless", "the coefficient of restitution e: a straight line returning e² of the "
        "absorbed energy", 0, exclusive=False, maximum=1),
        stiffness=_quantity("stiffness", "a straight unloading line of this slope from the peak", 0),
        table=dict(loading["table"], description="[deformation, force] pairs of the rebound, "
                   "in time order, ending at force 0"))
    out = _object(_tables._UNLOADING_KEYS, props, "the unloading branch: exactly one of "
                  + ", ".join(_tables._UNLOADING_KINDS))
    out["oneOf"] = _one_of(_tables._UNLOADING_KINDS)
    out["allOf"] = [_columns_only_with_tables(_tables._UNLOADING_KINDS)]
    return out


def _param(param, params=()) -> dict:
    """The schema of a declared key (:class:`lsc.laws.Param`); a unit kind that depends on other
    keys is taken at their defaults."""
    kind = param.kind
    if callable(kind):
        kind = kind({p.key: p.default for p in params})
    low, exclusive, high = param.bounds
    return _quantity(kind, param.doc, low, exclusive=exclusive, maximum=high)


#: The contact keys every law takes, and the IF-D law's tables.
_CONTACT_PROPS = {
    "gap": _quantity("length", "the initial gap between the two bumpers", 0, exclusive=False),
    "failure": {"$ref": "#/$defs/failure"},
    "loading": {"$ref": "#/$defs/loading"},
    "unloading": {"$ref": "#/$defs/unloading"},
}


def _contact_law(law: str, names) -> dict:
    """The contact table of one law: its declared keys, with ``law`` naming it."""
    cls = law_class(law)
    declared = () if getattr(cls, "table_keys", None) else cls.params_declared
    props = dict(_CONTACT_PROPS, law=_name(names, f"the contact law: {law}"))
    props.update({p.key: _param(p, declared) for p in declared})
    out = _object(_parts._CONTACT_COMMON_KEYS + _parts.law_keys(law), props,
                  f"a contact with the {law} law")
    if not declared:
        out["required"] = list(cls.table_keys)
    else:
        out["required"] = ["law"] + [p.key for p in declared if p.default is REQUIRED]
        choice, _ = cls.choice
        if choice:
            out["oneOf"] = _one_of(choice)
    return out


def _contact() -> dict:
    alias = aliases()
    laws_ = [_contact_law(law, [law] + [a for a, b in alias.items() if b == law]) for law in laws()]
    return {"description": "a contact between vehicles[k] (rear) and vehicles[k+1]: the IF-D "
                           "law (\"hysteresis\", the default) or a damping law",
            "oneOf": laws_}


def _effect(cls, description: str, extra=None) -> dict:
    """The table of an effect: its declared keys (and ``extra`` ones)."""
    props = {p.key: _param(p, cls.params_declared) for p in cls.params_declared}
    props.update(extra or {})
    keys = getattr(cls, "table_keys", None) or cls.keys()
    return _object(keys, props, description,
                   required=[p.key for p in cls.params_declared if p.default is REQUIRED])


def _solver() -> dict:
    assert set(_parts._SOLVER_KEYS) - {"method"} <= ALL_OPTIONS
    props = {"method": _name(METHODS + tuple(_parts._METHOD_ALIASES),
                             "the backend: " + ", ".join(METHODS)),
             "rtol": _quantity("dimensionless", "relative tolerance, in (0, 1)", 0),
             "atol": _quantity("dimensionless", "absolute tolerance", 0),
             "integrator": {"type": "string", "pattern": r"\S",
                            "description": "the integrator's name (e.g. \"DOP853\")"}}
    props["rtol"]["anyOf"][0]["exclusiveMaximum"] = 1
    for key in _parts._SOLVER_TIMES:
        props[key] = _quantity("time", {"dt": "the fixed step", "t_end": "the end time"}[key], 0)
    for key in _parts._SOLVER_COUNTS:
        count = {"type": "integer", "minimum": 1}
        if key == "n_samples":
            count["maximum"] = MAX_SAMPLES
        props[key] = {"description": f"{key}: a whole number >= 1", "anyOf": [
            count, {"$ref": "#/$defs/quantity_text"}]}
    return _object(_parts._SOLVER_KEYS, props, "the solver: method and options")


def _vehicle() -> dict:
    props = {
        "name": {"type": "string"},
        "weight": _quantity("force", "the vehicle's weight (mass = weight / g)", 0),
        "mass": _quantity("mass", "the vehicle's mass", 0),
        "speed": _quantity("velocity", "the initial speed (vehicles rear to front)")}
    props.update({table: _effect(cls, cls.summary) for table, cls in
                  vehicle_effect_classes().items()})
    out = _object(_parts.vehicle_keys(), props, "a rigid vehicle", required=["speed"])
    out["oneOf"] = _one_of(("weight", "mass"))
    return out


def scene_schema() -> dict:
    """The JSON Schema (draft 2020-12) of a scene, as a dict (see the module's docstring)."""
    units = sorted(UNITS)
    top = {
        "name": {"type": "string", "description": "the scene's name (default: the file's stem)"},
        "units": _name(units, "the unit system of bare numbers and results: "
                       + " or ".join(f"{u} ({UNITS[u]['length']}, s, {UNITS[u]['mass']}, "
                                     f"{UNITS[u]['force']})" for u in units)
                       + "; default SI"),
        "g": _quantity("acceleration", "the local acceleration of gravity (weight → mass)", 0),
        "vehicles": {"type": "array", "minItems": 2, "items": {"$ref": "#/$defs/vehicle"},
                     "description": "the vehicles, rear to front"},
        "contacts": {"type": "array", "minItems": 1, "items": {"$ref": "#/$defs/contact"},
                     "description": "contacts[k] joins vehicles[k] and vehicles[k+1]"},
        "solver": {"$ref": "#/$defs/solver"},
        "uncertainty": {"type": "object", "description": "dotted scene paths to distributions "
                        "(lsc mc)"},
        "display": _object(_scene._DISPLAY_KEYS, {"speed_unit": {
            "enum": list(SPEED_UNITS), "description": "the unit speeds and ΔV are printed in"}},
            "how results are shown"),
    }
    schema = {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": SCHEMA_ID,
              "title": "lsc scene",
              **_object(_scene._TOP_KEYS, top, "A low-speed collinear crash scene (lsc), generated "
                        "from the loader's key tables by lsc.schema.scene_schema(); the loader "
                        "checks more (the dimensions of quantities, the physics).",
                        required=["vehicles", "contacts"])}
    schema["$defs"] = {
        "quantity_text": {"type": "string", "pattern": QUANTITY_PATTERN,
                          "description": "a number and a unit, e.g. \"10 mph\" or \"3500 lbf\""},
        "vehicle": _vehicle(), "contact": _contact(), "loading": _loading(),
        "unloading": _unloading(), "solver": _solver(),
        "failure": _effect(FailureEffect, "bumper failure",
                           {"post_failure": {"$ref": "#/$defs/loading"}}),
    }
    return schema


def schema_text() -> str:
    """:func:`scene_schema` as JSON text (indent 2, a final newline), as shipped."""
    return json.dumps(scene_schema(), indent=2, ensure_ascii=False) + "\n"


def shipped_schema() -> dict:
    """The schema file shipped in the package (``lsc/data/scene.schema.json``)."""
    return json.loads(resources.files("lsc.data").joinpath("scene.schema.json").read_text("utf-8"))
