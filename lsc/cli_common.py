"""Helpers shared by the subcommands of :mod:`lsc.cli` and :mod:`lsc.analysis.cli`: the scene
named on the command line, the options several subcommands declare (solver, ``--overwrite``,
``--speed-unit``) and the JSON / Parquet writers. Both import this module; neither imports the
other at import time (no import circle).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from .errors import SceneError

__all__ = ["DEFAULT_SCENE", "resolve_scene", "scene_file", "json_writer", "require_parquet",
           "parquet_writer", "add_overwrite_option", "add_solver_options", "solver_options",
           "add_speed_unit_option", "positive_float"]

DEFAULT_SCENE = "default"


def resolve_scene(text: str | None):
    """The :class:`lsc.Scene` named on the command line: a TOML path, or a packaged scene name
    (``None`` → the packaged default). A name with a folder separator or a ``.toml`` suffix is
    always a path. Raises :class:`lsc.SceneError`."""
    from .scene import Scene
    return Scene.load(scene_file(text))  # the loader says what is wrong with it


def scene_file(text: str | None) -> Path:
    """The TOML file of the scene named on the command line (see :func:`resolve_scene`); raises
    :class:`lsc.SceneError` for a name that is neither a file nor a packaged scene."""
    from . import data
    if text is None:
        return data.path(DEFAULT_SCENE)
    looks_like_path = any(c in text for c in "/\\") or text.lower().endswith(".toml")
    if not looks_like_path and text in data.names():
        return data.path(text)
    if looks_like_path or Path(text).expanduser().exists():
        return Path(text).expanduser()
    data.path(text)  # raises: neither a file nor a packaged scene (with a did-you-mean)
    raise AssertionError("unreachable")


def _finite(obj):
    """JSON-ready: numpy scalars to Python, non-finite floats to ``None`` (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _finite(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def json_writer(obj):
    """A writer (for :func:`lsc.outputs.write_files`) of ``obj`` as indented strict JSON:
    numpy values as Python ones, non-finite numbers as ``null``."""
    def write(file):
        with open(file, "w", encoding="utf-8") as fh:
            json.dump(_finite(obj), fh, indent=2, allow_nan=False, ensure_ascii=False)
            fh.write("\n")
    return write


def require_parquet(wanted: bool = True) -> None:
    """Raise :class:`lsc.SceneError` where Parquet is ``wanted`` and pyarrow (the ``[frames]``
    extra) is missing: called before a computation whose output is to be written as Parquet."""
    if not wanted:
        return
    try:
        import pyarrow  # noqa: F401  (pandas writes Parquet with it)
    except ModuleNotFoundError:
        raise SceneError("parquet", "writing Parquet needs pyarrow: pip install 'lsc[frames]'") \
            from None


def parquet_writer(sweep_result):
    """A writer of ``sweep_result`` as Parquet: one row per member (:meth:`SweepResult.to_dataframe`)."""
    require_parquet()
    return lambda file: sweep_result.to_dataframe().to_parquet(file)


def add_overwrite_option(p) -> None:
    """Declare ``--overwrite`` on the subcommand parser ``p`` (for commands that write files)."""
    p.add_argument("--overwrite", action="store_true",
                   help="replace the output files of an earlier run (default: refuse, exit 2)")


def solver_options(args) -> dict:
    """The solver options given on the command line (absent ones are left to the scene)."""
    names = ("rtol", "atol", "dt", "integrator")
    return {n: getattr(args, n) for n in names if getattr(args, n, None) is not None}


def add_solver_options(p) -> None:
    """Declare ``--method``, ``--rtol``, ``--atol``, ``--dt`` and ``--integrator`` on the
    subcommand parser ``p`` (read back by :func:`solver_options` and ``args.method``)."""
    from .scene import METHODS
    p.add_argument("--method", choices=METHODS, help="backend (overrides the scene's [solver])")
    p.add_argument("--rtol", type=positive_float, help="relative tolerance (scipy, diffrax)")
    p.add_argument("--atol", type=positive_float, help="absolute tolerance (scipy, diffrax)")
    p.add_argument("--dt", type=positive_float, help="time step [s] (reference)")
    p.add_argument("--integrator", help="integrator (scipy: DOP853, RK45, LSODA, Radau, ...)")


def add_speed_unit_option(p, what: str) -> None:
    """Declare ``--speed-unit`` (the display unit of ``what``) on the subcommand parser ``p``;
    checked by :func:`lsc.display.speed_display` (a :class:`lsc.SceneError` naming the accepted
    units), not by argparse."""
    from .display import SPEED_UNITS
    p.add_argument("--speed-unit", metavar="|".join(SPEED_UNITS),
                   help=f"print {what} in this unit (default: the scene's); the CSV and JSON "
                        "files keep the scene's units")


def positive_float(text: str) -> float:
    """An argparse ``type``: ``text`` as a finite positive number (else a usage error)."""
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return x


# ----------------------------------------------------------------- studies in chunks
def add_study_options(p) -> None:
    """Declare the options of a study in chunks (``lsc sweep``, ``lsc mc``): where the chunks
    run and which metrics are kept."""
    p.add_argument("--workers", type=_positive_int, metavar="N",
                   help="run the chunks on N worker processes of this machine (with --dask: "
                        "a local Dask cluster of N workers); default: this process")
    p.add_argument("--dask", action="store_true",
                   help="run the chunks on a new local Dask cluster (needs the [dask] extra)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run the chunks on the running Dask cluster of this scheduler")
    p.add_argument("--task-size", type=_positive_int, metavar="N",
                   help="members per chunk (default: chosen from the members and workers)")
    p.add_argument("--metrics", type=_metric_list, metavar="M,M,...",
                   help="with --out FILE.parquet: the metrics written (default: all for lsc "
                        "sweep, those reported for lsc mc)")


def study_settings(args) -> dict:
    """The keywords of :func:`lsc.sweep` / ``monte_carlo`` that :func:`add_study_options` set
    (the executor apart: :func:`lsc.chunks.executor_from`)."""
    streamed = is_parquet_file(args.out)
    if args.metrics is not None and not streamed:
        raise SceneError("--metrics", "--metrics selects the columns of --out FILE.parquet; "
                                      "give one (or leave --metrics out)")
    return {"task_size": args.task_size, "metrics": args.metrics}


def is_parquet_file(out) -> bool:
    """True when ``--out`` names a Parquet file (the study is streamed into it)."""
    return out is not None and str(out).lower().endswith(".parquet")


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return value


def _metric_list(text: str) -> list[str]:
    from .result import METRICS

    names = [t.strip() for t in text.split(",") if t.strip()]
    bad = [n for n in names if n not in METRICS]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"unknown metric {bad[0] if bad else text!r}; the "
                                         f"metrics are {', '.join(METRICS)}")
    return names
