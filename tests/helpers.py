"""Helpers shared by the test modules, each defined once here: the hard-mode switch, scene
builders (plain dicts in the scene format of DESIGN.md §4), the relative-error measure and the
small helpers of the command-line tests. Import them with ``from helpers import ...`` (tests/ is
on ``sys.path`` under pytest, for tests/hard too).
"""

from __future__ import annotations

import copy
import os
from pathlib import Path

import numpy as np

__all__ = ["ROOT", "hard_mode", "HARD", "have_diffrax", "PAPER", "paper_scene", "with_changes", "two_cars",
           "chain", "NONLINEAR", "max_rel_error", "subprocess_env", "files_in", "no_space",
           "summary_row"]

#: The repository's root folder.
ROOT = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- hard mode
def hard_mode() -> bool:
    """Hard-case mode: ``LSC_HARD`` set to anything but ``""``, ``0``, ``false``, ``no``
    (``pytest --hard`` sets it, in tests/conftest.py)."""
    return os.environ.get("LSC_HARD", "").strip().lower() not in ("", "0", "false", "no")


def __getattr__(name: str):
    # ``HARD`` is read when a test module imports it, after pytest_configure has turned --hard
    # into LSC_HARD (conftest.py imports this module earlier than that).
    if name == "HARD":
        return hard_mode()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def have_diffrax() -> bool:
    """Whether the ``[jax]`` extra (JAX and diffrax) is installed."""
    try:
        import diffrax  # noqa: F401
        import jax  # noqa: F401
    except ImportError:
        return False
    return True


# --------------------------------------------------------------------------- scenes
#: The paper's two-car scene (parametric study 1, e = 0.4; US units, g = 32.2 ft/s²).
PAPER = {
    "name": "paper",
    "units": "US",
    "g": "32.2 ft/s^2",
    "vehicles": [
        {"name": "bullet", "weight": 3500, "speed": 10},
        {"name": "target", "weight": 3500, "speed": 0},
    ],
    "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}],
}


def paper_scene(**changes) -> dict:
    """The paper's two-car scene with dotted-path changes, e.g. ``paper_scene(**{"vehicles.0.speed": 5})``."""
    return with_changes(PAPER, **changes)


def with_changes(scene: dict, **changes) -> dict:
    """A copy of the scene dict ``scene`` with each dotted path of ``changes`` set to its value."""
    s = copy.deepcopy(scene)
    for path, value in changes.items():
        *head, last = path.split(".")
        node = s
        for key in head:
            node = node[int(key)] if key.isdigit() else node[key]
        node[int(last) if last.isdigit() else last] = value
    return s


def two_cars(m1, m2, v1, v2, loading, unloading, gap=0.0, units="SI", **contact) -> dict:
    """A two-vehicle scene dict with masses (not weights) and speeds in ``units``, and one
    hysteresis contact (``contact``: more of its keys, e.g. ``failure``)."""
    return {
        "units": units,
        "vehicles": [{"mass": m1, "speed": v1}, {"mass": m2, "speed": v2}],
        "contacts": [{"loading": loading, "unloading": unloading, "gap": gap, **contact}],
    }


def chain(masses, speeds, contacts, units="SI") -> dict:
    """A chain of vehicles (masses, speeds, rear to front, in ``units``) and its contacts."""
    return {"units": units, "vehicles": [{"mass": m, "speed": v} for m, v in zip(masses, speeds)],
            "contacts": list(contacts)}


#: A measured-like loading table (m, N): plateau, dip and a stiff end.
NONLINEAR = {"table": [[0, 0], [0.02, 3000], [0.1, 25000], [0.15, 40000], [0.2, 40000],
                       [0.25, 35000], [0.4, 120000]]}


# --------------------------------------------------------------------------- comparisons
def max_rel_error(a, b) -> float:
    """The largest relative difference of ``a`` from the reference ``b`` (element-wise)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300)))


# --------------------------------------------------------------------------- command line
def subprocess_env(**variables) -> dict:
    """The environment for a child Python that must import this checkout's lsc: this one's,
    the repository first on ``PYTHONPATH``, and ``variables`` set."""
    paths = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *paths]), **variables}


def files_in(folder: Path) -> dict:
    """Every entry of ``folder`` (hidden ones too) → its bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def no_space(*args, **kwargs):
    """A stand-in for a file write on a full disk."""
    raise OSError(28, "No space left on device")


def summary_row(text: str, name: str) -> list[str]:
    """The words of the first line of ``text`` that starts with ``name`` and a space."""
    return next(line.split() for line in text.splitlines() if line.startswith(name + " "))
