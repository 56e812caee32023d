"""The ``lsc`` command line.

    lsc run [SCENE] [--method M] [--rtol R] [--atol A] [--dt DT] [--integrator I] [--out DIR]
            [--no-plots]
    lsc sweep [SCENE] --param PATH=VALUES [--param ...] [--grid] [--metric M]
              [--out DIR|FILE.parquet] [--workers N] [--dask] [--scheduler tcp://HOST:PORT]
              [--task-size N] [--metrics M,...]
    lsc scenes
    lsc report [SCENE] [--method M] [--rtol R] [--atol A] [--dt DT] [--integrator I] [--n N]
               [--seed S] [--out FILE]

``SCENE`` is a TOML file or the name of a packaged scene (``lsc scenes`` lists them); without it
``lsc run`` (and ``lsc report``) runs the packaged default. Exit status: 0 done, 1 the physics could not be completed
(:class:`lsc.SimulationError`), the output could not be written, or the reader of the output
went away (``lsc run | head``: stdout is a closed pipe, nothing more is printed and no traceback),
2 bad input (:class:`lsc.SceneError` or bad arguments, or output files of an earlier run in the
way without ``--overwrite``), with one line on stderr.

Output files are written all at once or not at all, and never over an earlier run's unless
``--overwrite`` is given (:mod:`lsc.outputs`).

Each subcommand is a pair of small functions, ``_add_<name>(subparsers)`` that declares it and
``_cmd_<name>(args)`` that runs it and returns the exit status; add new ones to ``COMMANDS``.
What the analyses' subcommands (:mod:`lsc.analysis.cli`) share with these (the scene named on
the command line, the common options, the JSON and Parquet writers) is in :mod:`lsc.cli_common`.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
from pathlib import Path

import numpy as np

from . import __version__
from .cli_common import (DEFAULT_SCENE, add_overwrite_option, add_solver_options,  # noqa: F401
                         add_speed_unit_option, add_study_options, is_parquet_file, json_writer,
                         parquet_writer, positive_float, require_parquet, resolve_scene,
                         scene_file, solver_options, study_settings)
from .errors import SceneError, SimulationError
from .outputs import OutputError, OutputExistsError, refuse_existing, write_files

__all__ = ["main", "resolve_scene", "write_outputs", "json_writer"]

DEFAULT_OUT = "lsc-out"


# --------------------------------------------------------------------------- lsc run's files
def write_series_csv(result, file) -> None:
    """``result.series_columns()`` as CSV: one header row (names with units), shortest
    round-trip decimal for every value."""
    cols = result.series_columns()
    data = np.column_stack([np.asarray(c, float) for c in cols.values()])
    with open(file, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(cols.keys())
        w.writerows([repr(float(x)) for x in row] for row in data)


def run_files(out_dir) -> list[Path]:
    """Every file ``lsc run`` may write into ``out_dir`` (the figures too): an earlier run's
    files that are in the way, or that a ``--no-plots`` run with ``--overwrite`` removes."""
    from .plots import FILES
    out = Path(out_dir)
    return [out / "series.csv", out / "summary.json", *(out / f for f in FILES)]


def write_outputs(result, out_dir, plots: bool = True, extra: dict | None = None, *,
                  overwrite: bool = False) -> list[Path]:
    """Write ``series.csv``, ``summary.json`` (``result.to_dict()`` plus ``extra``) and, with
    ``plots``, the three PNG figures into ``out_dir``, all or none; returns the paths written.
    Refuses to replace an earlier run's files (:class:`lsc.outputs.OutputExistsError`) unless
    ``overwrite``, which also removes the figures of an earlier run when ``plots`` is false."""
    out = Path(out_dir)
    writers = {out / "series.csv": lambda file: write_series_csv(result, file),
               out / "summary.json": json_writer({**result.to_dict(), **(extra or {})})}
    if plots:
        from .plots import figure_writers
        writers.update({out / f: w for f, w in figure_writers(result).items()})
    return write_files(writers, overwrite=overwrite, replaces=run_files(out))


# --------------------------------------------------------------------------- lsc run
def _add_run(sub) -> None:
    p = sub.add_parser("run", help="simulate one scene: summary, CSV, JSON and plots",
                       description="Simulate one crash. Prints the summary table and writes "
                       "series.csv, summary.json, acceleration.png, velocity.png and ifd.png.")
    p.add_argument("scene", nargs="?", metavar="SCENE",
                   help="a scene TOML file or a packaged scene name (default: the packaged "
                        "'default', the paper's parametric study 1 with e = 0.4)")
    add_solver_options(p)
    p.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                   help=f"output folder (default: {DEFAULT_OUT}/)")
    p.add_argument("--no-plots", action="store_true", help="do not draw the PNG figures")
    add_speed_unit_option(p, "the speeds and delta-Vs of the summary")
    add_overwrite_option(p)
    p.set_defaults(func=_cmd_run)


def _cmd_run(args) -> int:
    from .api import solve
    from .display import speed_display
    scene = resolve_scene(args.scene)
    speed_display(args.speed_unit, scene.units, "--speed-unit")  # before the solve, not after
    refuse_existing(run_files(args.out), args.overwrite)
    result = solve(scene, method=args.method, **solver_options(args))
    print(result.summary(speed_unit=args.speed_unit))
    from .analysis.mer import format_mer
    mer = format_mer(result)
    if mer:
        print("\n" + mer if isinstance(mer, str) else "\n" + "\n".join(mer))
    written = write_outputs(result, args.out, plots=not args.no_plots, overwrite=args.overwrite,
                            extra={"input": args.scene or DEFAULT_SCENE, "lsc_version": __version__})
    print(f"\nwritten to {folder(args.out)}: " + ", ".join(p.name for p in written))
    return 0


def folder(out) -> str:
    """``out`` as printed before the names of the files written into it: one trailing slash
    (``results/`` and ``results`` both print ``results/``)."""
    text = str(out)
    return text if text.endswith(("/", os.sep)) else text + "/"


# --------------------------------------------------------------------------- lsc sweep
def _sweep_values(text: str):
    """``PATH=VALUES``: ``start:stop:num`` (evenly spaced numbers in scene units) or a comma
    list (numbers, or quantities with units such as ``5 mph``)."""
    if "=" not in text:
        raise SceneError("--param", f"expected PATH=VALUES (e.g. vehicles.0.speed=2:12:11), got "
                         f"{text!r}")
    path, values = (part.strip() for part in text.split("=", 1))
    if values.count(":") == 2 and "," not in values:
        try:
            a, b, n = values.split(":")
            num = int(n)
            if num < 1:
                raise ValueError
            return path, np.linspace(float(a), float(b), num)
        except ValueError:
            raise SceneError(path, f"start:stop:num needs two numbers and a count >= 1, got "
                             f"{values!r}") from None
    items = [v.strip() for v in values.split(",") if v.strip()]
    if not items:
        raise SceneError(path, "no values given")
    out = []
    for v in items:
        try:
            out.append(float(v))
        except ValueError:
            out.append(v)  # a quantity with units, converted by the loader
    return path, out


def _add_sweep(sub) -> None:
    from .result import METRICS
    from .scene import METHODS
    p = sub.add_parser("sweep", help="solve a scene over swept parameters: CSV table and a plot",
                       description="Sweep scene parameters (dotted paths) and write every "
                       "metric of every member to sweep.csv, with a plot of one metric.")
    p.add_argument("scene", nargs="?", metavar="SCENE", help="a scene TOML file or packaged name")
    p.add_argument("--param", action="append", required=True, metavar="PATH=VALUES",
                   help="a swept field, e.g. vehicles.0.speed=2:12:11 or "
                        "contacts.0.unloading.restitution=0.2,0.4,0.6 (repeatable)")
    p.add_argument("--grid", action="store_true", help="sweep the product of the parameters")
    p.add_argument("--method", choices=METHODS, help="backend (default: the scene's)")
    p.add_argument("--rtol", type=positive_float, help="relative tolerance (scipy, diffrax)")
    p.add_argument("--dt", type=positive_float, help="time step [s] (reference)")
    p.add_argument("--metric", default="delta_v", choices=sorted(METRICS),
                   help="the metric to plot (default delta_v)")
    p.add_argument("--index", type=int, default=None,
                   help="which vehicle/contact of a per-vehicle/contact metric to plot "
                        "(default: the last vehicle, the first contact)")
    p.add_argument("--out", default=DEFAULT_OUT, metavar="DIR|FILE.parquet",
                   help=f"output folder (default: {DEFAULT_OUT}/); a FILE.parquet streams every "
                        "member into that one file as it is solved (no CSV, no plot; memory "
                        "bounded whatever the number of members)")
    p.add_argument("--no-plots", action="store_true", help="do not draw the PNG figure")
    p.add_argument("--parquet", action="store_true",
                   help="also write sweep.parquet (the same table; needs the [frames] extra)")
    add_study_options(p)
    add_overwrite_option(p)
    p.set_defaults(func=_cmd_sweep)


def _cmd_sweep(args) -> int:
    from .chunks import executor_from
    from .sweep import sweep
    scene = resolve_scene(args.scene)
    params = dict(_sweep_values(t) for t in args.param)
    opts = {k: v for k, v in (("rtol", args.rtol), ("dt", args.dt)) if v is not None}
    opts.update(study_settings(args))
    if is_parquet_file(args.out):
        return _stream_sweep(args, scene, params, opts)
    out = Path(args.out)
    files = [out / "sweep.csv", out / "sweep.png", out / "sweep.parquet"]
    refuse_existing(files, args.overwrite)
    require_parquet(args.parquet)
    with executor_from(args.workers, args.scheduler, args.dask) as executor:
        s = sweep(scene, params, method=args.method, grid=args.grid, executor=executor, **opts)
    # (each writer fills the temporary file write_files made: that one checked the targets)
    writers = {out / "sweep.csv": lambda file: s.to_csv(file, overwrite=True)}
    if args.parquet:
        writers[out / "sweep.parquet"] = parquet_writer(s)
    if not args.no_plots:
        from .plots import sweep_metric
        writers[out / "sweep.png"] = lambda file: sweep_metric(s, args.metric, args.index, file,
                                                                overwrite=True)
    written = write_files(writers, overwrite=args.overwrite, replaces=files)
    n, bad = s.stats["members"], s.stats["failed"]
    print(f"{s.scene.name}: {n} members by {s.method} in {s.stats['wall_time']:.3g} s"
          + (f", {bad} failed (see the status column)" if bad else "") + _warned(s.stats))
    print(f"written to {folder(args.out)}: " + ", ".join(p.name for p in written))
    return 0


def _stream_sweep(args, scene, params, opts) -> int:
    """``lsc sweep --out FILE.parquet``: every member streamed into one Parquet file."""
    from .chunks import executor_from
    from .sweep import sweep
    refuse_existing([Path(args.out)], args.overwrite)
    require_parquet()
    with executor_from(args.workers, args.scheduler, args.dask) as executor:
        f = sweep(scene, params, method=args.method, grid=args.grid, executor=executor,
                  out=args.out, overwrite=args.overwrite, **opts)
    n, bad = f.stats["members"], f.stats["failed"]
    print(f"{f.scene.name}: {n} members by {f.method} in {f.stats['wall_time']:.3g} s"
          + (f", {bad} failed (see the status column)" if bad else "") + _warned(f.stats))
    print(f"written to {args.out}")
    return 0


def _warned(stats: dict) -> str:
    """The summary's note of the members whose solve came with warnings ("" where none)."""
    k = stats.get("warned", 0)
    return f", {k} with warnings (see the warnings column)" if k else ""


# --------------------------------------------------------------------------- lsc scenes
def _add_scenes(sub) -> None:
    p = sub.add_parser("scenes", help="list the packaged scenes",
                       description="List the packaged scenes (usable as `lsc run NAME`).")
    p.set_defaults(func=_cmd_scenes)


def _cmd_scenes(args) -> int:
    import tomllib
    from . import data
    names = data.names()
    w = max(len(n) for n in names)
    for n in names:
        with open(data.path(n), "rb") as fh:
            title = tomllib.load(fh).get("name", "")
        print(f"{n:<{w}}  {title}")
    return 0


# --------------------------------------------------------------------------- lsc schema
def _add_schema(sub) -> None:
    p = sub.add_parser("schema", help="print the JSON Schema of the scene format",
                       description="Print the JSON Schema (draft 2020-12) of the scene format, "
                                   "generated from the scene loader (the package ships it as "
                                   "lsc/data/scene.schema.json).")
    p.add_argument("--out", type=Path, help="write it to this file instead of printing it")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    p.set_defaults(func=_cmd_schema)


def _cmd_schema(args) -> int:
    from .schema import schema_text
    text = schema_text()
    if args.out is None:
        sys.stdout.write(text)
        return 0
    write_files({args.out: lambda tmp: Path(tmp).write_text(text, encoding="utf-8")},
                overwrite=args.overwrite)
    print(f"schema written to {args.out}")
    return 0


# --------------------------------------------------------------------------- lsc report
DEFAULT_REPORT = "report.html"


def _add_report(sub) -> None:
    from .report import MC_SAMPLES, MC_SEED
    p = sub.add_parser("report", help="a self-contained HTML report of one crash, for a case file",
                       description="Simulate one crash and write one self-contained HTML file "
                       "(figures embedded, nothing loaded from elsewhere): the scene as given and "
                       "its SHA-256, the method, tolerances and accuracy, versions, the summary "
                       "and impacts, warnings, the MER cross-check, the figures, the scene's "
                       "uncertainty and failure-force bound results, and a methods paragraph.")
    p.add_argument("scene", nargs="?", metavar="SCENE",
                   help="a scene TOML file or a packaged scene name (default: the packaged "
                        "'default', as for lsc run)")
    add_solver_options(p)
    p.add_argument("--n", type=int, default=MC_SAMPLES,
                   help=f"Monte Carlo samples of the scene's [uncertainty] table "
                        f"(default {MC_SAMPLES})")
    p.add_argument("--seed", type=int, default=MC_SEED,
                   help=f"Monte Carlo seed, stated in the report (default {MC_SEED})")
    p.add_argument("--out", default=DEFAULT_REPORT, metavar="FILE",
                   help=f"the HTML file (default: {DEFAULT_REPORT})")
    add_overwrite_option(p)
    p.set_defaults(func=_cmd_report)


def _cmd_report(args) -> int:
    from .report import write_report
    if args.n < 1:
        raise SceneError("n", f"the number of samples must be positive, got {args.n}")
    file = scene_file(args.scene)
    resolve_scene(args.scene)  # a bad scene is refused before anything else
    refuse_existing([Path(args.out)], args.overwrite)  # before the solve, not after
    opts = solver_options(args)
    if args.method is not None:
        opts["method"] = args.method
    path = write_report(file, args.out, overwrite=args.overwrite, mc_samples=args.n,
                        seed=args.seed, **opts)
    print(f"report written to {path}")
    return 0


# --------------------------------------------------------------------------- the parser
#: The subcommands, in the order ``lsc --help`` lists them (then the analyses: bound, mc).
COMMANDS = [_add_run, _add_sweep, _add_scenes, _add_schema, _add_report]


def _analysis_commands() -> list:
    from .analysis import cli as acli
    return list(acli.COMMANDS)


def build_parser() -> argparse.ArgumentParser:
    """The ``lsc`` argument parser with every subcommand of ``COMMANDS``."""
    ap = argparse.ArgumentParser(
        prog="lsc", description="Low-speed collinear bumper-to-bumper crash simulation.")
    ap.add_argument("--version", action="version", version=f"lsc {__version__}")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in COMMANDS + _analysis_commands():
        add(sub)
    return ap


def _error(message: str) -> None:
    print(f"lsc: error: {' '.join(str(message).split())}", file=sys.stderr)


def _stdout_gone() -> None:
    """The reader of stdout went away (``lsc run | head``): point stdout at the null device so
    that Python's final flush does not fail again (the Python docs' note on SIGPIPE)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (AttributeError, OSError, ValueError):  # not a real file (e.g. captured by a test)
        pass


def main(argv=None) -> int:
    """Run ``lsc`` with ``argv`` (default: ``sys.argv[1:]``); returns the exit status: 1, with
    nothing printed, when stdout is a pipe whose reader has gone (what was not yet printed or
    written is not: the command did not finish)."""
    try:
        status = _run_command(argv)
        sys.stdout.flush()
        return status
    except BrokenPipeError:
        _stdout_gone()
        return 1


def _run_command(argv) -> int:
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # --help, --version, usage errors (argparse printed them)
        return e.code if isinstance(e.code, int) else 2
    try:
        return args.func(args)
    except SceneError as e:
        _error(f"{e.path}: {e.message}" if e.path else e.message)
        return 2
    except OutputExistsError as e:
        _error(f"{', '.join(map(str, e.paths))} already exist{'s' if len(e.paths) == 1 else ''}"
               " (the results of an earlier run): pass --overwrite to replace them, or write "
               "elsewhere")
        return 2
    except OutputError as e:
        _error(f"cannot write {e.filename}: {e.strerror}; nothing was written")
        return 1
    except SimulationError as e:
        _error(e)
        return 1
    except KeyboardInterrupt:
        _error("interrupted")
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
