"""A scene's source table as TOML text, for the report and for fitted scenes: top-level keys, then
each table and array of tables; deeper tables inline. ``tomllib`` reads it back to the same
table (NumPy numbers are written as the Python numbers they are; ``inf`` and ``nan`` as TOML
spells them).
"""

from __future__ import annotations

import datetime
import json
import re

import numpy as np

from .errors import SceneError

__all__ = ["to_toml"]

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def to_toml(source: dict, *, default=None) -> str:
    """``source`` (a scene's table) as TOML text. ``default(value)``: what to write for a value
    TOML has no type for (as a string); without it such a value raises :class:`lsc.SceneError`."""
    def is_tables(v):
        return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)

    def assignments(table):
        return [f"{_key(k)} = {_value(v, default)}" for k, v in table.items()]

    lines = assignments({k: v for k, v in source.items()
                         if not isinstance(v, dict) and not is_tables(v)})
    for k, v in source.items():
        if isinstance(v, dict):
            lines += ["", f"[{_key(k)}]", *assignments(v)]
        elif is_tables(v):
            for item in v:
                lines += ["", f"[[{_key(k)}]]", *assignments(item)]
    return "\n".join(lines) + "\n"


def _key(key) -> str:
    key = str(key)
    return key if _BARE_KEY.fullmatch(key) else json.dumps(key, ensure_ascii=False)


def _value(value, default) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))  # inf, -inf and nan are spelled as TOML spells them
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(v, default)}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_value(v, default) for v in value) + "]"
    if isinstance(value, (datetime.date, datetime.time)):
        return value.isoformat()
    if default is None:
        raise SceneError("", f"cannot write {type(value).__name__} {value!r} as TOML")
    return json.dumps(str(default(value)), ensure_ascii=False)
