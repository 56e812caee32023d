"""``lsc bound``, ``lsc mc`` and ``lsc sensitivity``: subcommands for :mod:`lsc.cli` (added to its
``COMMANDS``).

    lsc bound SCENE --failure-force "5000 lbf" [--contact K] [--speed-path P] [--step S]
              [--margin-steps N] [--method M] [--json FILE] [--overwrite]
    lsc mc SCENE [--n N] [--seed S] [--sampling random|sobol|lhs] [--uncertainty FILE]
           [--method M] [--percentiles 5,50,95]
           [--out DIR|FILE.parquet] [--no-plots] [--no-progress] [--overwrite]
           [--workers N] [--dask] [--scheduler tcp://HOST:PORT] [--task-size N] [--metrics M,...]
    lsc compare SCENE DATA [--method M] [--cfc C] [--time-zero T] [--out DIR] [--no-plots]
                [--overwrite]
    lsc fit SCENE DATA --param PATH [--param ...] [--initial PATH=V] [--bounds PATH=LO:HI]
            [--method M] [--cfc C] [--time-zero T] [--errors autocorrelated|independent]
            [--out DIR] [--no-plots] [--overwrite]
    lsc sensitivity SCENE [--params P,P,...] [--metrics M,M,...]
                    [--derivative autodiff|finite-difference] [--method M] [--rtol R]
                    [--plot FILE] [--plot-metric M] [--swing R] [--json FILE] [--overwrite]
    lsc sensitivity SCENE --global [--samples N] [--seed S] [--uncertainty FILE]
                    [--metrics M,M,...] [--method M] [--out DIR] [--no-plots] [--overwrite]

Each is a pair ``add_<name>(subparsers)`` / ``cmd_<name>(args)`` (returns the exit status), as in
:mod:`lsc.cli`; :class:`lsc.SceneError` and :class:`lsc.SimulationError` propagate to its
``main``, which prints them on one line and exits 2 or 1. Files are written with
:func:`lsc.outputs.write_files` (all or none; an earlier run's files are refused, before the
computation, unless ``--overwrite``).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from ..cli_common import (add_overwrite_option, add_speed_unit_option, add_study_options,
                          is_parquet_file, json_writer, parquet_writer, require_parquet,
                          resolve_scene, study_settings)
from ..errors import SceneError
from ..outputs import refuse_existing, write_files
# the measured-data commands (compare, fit) live in lsc.analysis.cli_measured
from .cli_measured import (COMPARE_FILES, FIT_FILES, add_compare, add_fit,  # noqa: F401
                           cmd_compare, cmd_fit)

__all__ = ["add_bound", "cmd_bound", "add_mc", "cmd_mc", "add_sensitivity", "cmd_sensitivity",
           "add_compare", "cmd_compare", "add_fit", "cmd_fit", "COMMANDS", "load_with_uncertainty"]


def _number_or_quantity(text: str):
    try:
        return float(text)
    except ValueError:
        return text  # "5000 lbf": converted (and checked) against the scene's units


# --------------------------------------------------------------------------- lsc bound
def add_bound(sub) -> None:
    """Declare ``lsc bound``."""
    from ..scene import METHODS
    p = sub.add_parser("bound", help="closing-speed bound from a bumper failure force (paper, Table 3)",
                       description="The speed at which the simulated peak contact force reaches the "
                       "lowest failure force of the bumpers involved, the crash there, and the "
                       "whole-unit rows up to the conservative bound (the paper's technique).")
    p.add_argument("scene", metavar="SCENE", help="a scene TOML file or a packaged scene name")
    p.add_argument("--failure-force", type=_number_or_quantity, metavar="F",
                   help='the lowest failure force, e.g. "5000 lbf" (a bare number is in the scene\'s '
                        "units; default: the contact's failure.force)")
    p.add_argument("--contact", type=int, default=0, help="the contact (default 0)")
    p.add_argument("--speed-path", default="vehicles.0.speed",
                   help="the speed searched (default vehicles.0.speed)")
    p.add_argument("--step", type=_number_or_quantity, default=1.0,
                   help='the whole unit of speed for the table and the bound, e.g. "1 mph" '
                        "(default 1 in the scene's units)")
    p.add_argument("--margin-steps", type=int, default=1,
                   help="steps above the first whole step at or above the root (default 1)")
    p.add_argument("--method", choices=METHODS, default="auto", help="backend (default auto)")
    p.add_argument("--json", metavar="FILE", help="also write the bound as JSON")
    add_speed_unit_option(p, "the speeds and delta-Vs (default: the unit of --step)")
    add_overwrite_option(p)
    p.set_defaults(func=cmd_bound)


def cmd_bound(args) -> int:
    """Run ``lsc bound``: print the bound's summary (and write JSON)."""
    from ..display import speed_display
    from .bounds import max_closing_speed
    scene = resolve_scene(args.scene)
    speed_display(args.speed_unit, scene.units, "--speed-unit")  # before the search
    files = [Path(args.json)] if args.json else []
    refuse_existing(files, args.overwrite)
    b = max_closing_speed(scene, args.failure_force, contact=args.contact,
                          speed_path=args.speed_path, method=args.method, step=args.step,
                          margin_steps=args.margin_steps)
    print(b.summary(speed_unit=args.speed_unit))
    write_files({f: json_writer(b.to_dict()) for f in files}, overwrite=args.overwrite)
    return 0


# --------------------------------------------------------------------------- lsc mc
def load_with_uncertainty(text: str, uncertainty: str | None = None):
    """``(scene, distributions)`` from a scene TOML with an ``[uncertainty]`` table (or a packaged
    scene name), plus an optional separate TOML holding the table (at its top level or under
    ``[uncertainty]``; it extends / overrides the scene's)."""
    from ..scene import Scene
    file = Path(text).expanduser()
    dists: dict = {}
    if file.is_file():
        try:
            src = tomllib.loads(file.read_text(encoding="utf-8-sig"))
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise SceneError("", f"cannot read {file}: {e}") from None
        dists = dict(src.pop("uncertainty", {}) or {})
        src.setdefault("name", file.stem)
        scene = Scene.load(src, base_dir=file.parent.absolute())
    else:
        scene = resolve_scene(text)
    if uncertainty:
        ufile = Path(uncertainty).expanduser()
        try:
            extra = tomllib.loads(ufile.read_text(encoding="utf-8-sig"))
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise SceneError("uncertainty", f"cannot read {ufile}: {e}") from None
        dists.update(extra.get("uncertainty", extra))
    if not dists:
        raise SceneError("uncertainty", "no distributions: add an [uncertainty] table to the scene "
                                        "(e.g. \"vehicles.0.speed\" = { uniform = [\"4 ft/s\", \"8 ft/s\"] }) "
                                        "or pass --uncertainty FILE")
    return scene, dists


def _percentiles(text: str):
    import argparse
    try:
        q = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers separated by commas, got {text!r}") from None
    if not q or any(not 0 <= x <= 100 for x in q):
        raise argparse.ArgumentTypeError(f"percentiles lie in [0, 100], got {text!r}")
    return q


def add_mc(sub) -> None:
    """Declare ``lsc mc``."""
    from ..scene import METHODS
    from .uncertainty import SAMPLINGS
    p = sub.add_parser("mc", help="Monte Carlo over the scene's [uncertainty] distributions",
                       description="Sample the scene's [uncertainty] table (dotted paths to "
                       "{ normal = [mean, sd] }, { uniform = [lo, hi] }, { triangular = [lo, mode, "
                       "hi] }, { choice = [...] }, { function = \"module:name\" }; an optional "
                       "correlation = [[1, 0.5], [0.5, 1]] or [[\"path_a\", \"path_b\", 0.5]]: "
                       "Spearman rank correlations), solve every sample and print the "
                       "percentiles of delta-V, peak acceleration, pulse duration and peak force.")
    p.add_argument("scene", metavar="SCENE", help="a scene TOML file (with an [uncertainty] table) "
                                                  "or a packaged scene name")
    p.add_argument("--n", type=int, default=10_000, help="number of samples (default 10000)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--sampling", choices=SAMPLINGS, default="random",
                   help="the design: random (pseudo-random draws, default), sobol (scrambled "
                        "Sobol' points: quasi-Monte Carlo; --n a power of two) or lhs (Latin "
                        "hypercube)")
    p.add_argument("--uncertainty", metavar="FILE", help="a TOML file with the distributions")
    p.add_argument("--method", choices=METHODS, default="auto", help="backend (default auto)")
    p.add_argument("--percentiles", type=_percentiles, default=(5.0, 50.0, 95.0),
                   help="comma-separated percentiles (default 5,50,95)")
    p.add_argument("--out", metavar="DIR|FILE.parquet",
                   help="write mc.csv (the samples and the reported metrics of every member) and "
                        "histograms here; a FILE.parquet streams every member into that one file "
                        "as it is solved (samples drawn a block at a time, memory bounded "
                        "whatever --n; percentiles exact, read back from the file)")
    p.add_argument("--no-plots", action="store_true", help="with --out: no histogram PNGs")
    p.add_argument("--parquet", action="store_true",
                   help="with --out: also write mc.parquet (every member's samples and metrics; "
                        "needs the [frames] extra)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_study_options(p)
    add_overwrite_option(p)
    p.set_defaults(func=cmd_mc)


#: The metrics ``lsc mc`` reports, writes to ``mc.csv`` and draws as ``mc_<metric>.png``.
MC_METRICS = ("delta_v", "peak_acceleration_g", "duration", "peak_force")


def _mc_files(out: Path) -> list[Path]:
    return [out / "mc.csv", out / "mc.parquet", *(out / f"mc_{metric}.png" for metric in MC_METRICS)]


def _histogram_writer(mc, metric: str):
    def write(file):
        from matplotlib.figure import Figure  # no pyplot: nothing to show or close
        fig = Figure(figsize=(6.0, 4.0), layout="constrained")
        mc.histogram(metric, ax=fig.add_subplot())
        fig.savefig(file, dpi=120)
    return write


def cmd_mc(args) -> int:
    """Run ``lsc mc``: print the percentile table (and write CSV / histograms)."""
    from ..chunks import executor_from
    from .uncertainty import monte_carlo
    if args.n < 1:
        raise SceneError("n", f"the number of samples must be positive, got {args.n}")
    scene, dists = load_with_uncertainty(args.scene, args.uncertainty)
    streamed = is_parquet_file(args.out)
    out = Path(args.out) if args.out else None
    refuse_existing([out] if streamed else _mc_files(out) if out else [], args.overwrite)
    require_parquet(streamed or (bool(out) and args.parquet))
    with executor_from(args.workers, args.scheduler, args.dask) as executor:
        mc = monte_carlo(scene, dists, args.n, seed=args.seed, sampling=args.sampling,
                         method=args.method, progress=False if args.no_progress else None,
                         percentiles=args.percentiles, executor=executor,
                         out=out if streamed else None, overwrite=args.overwrite,
                         **study_settings(args))
    print(mc.summary())
    if streamed:
        print(f"\nwritten to {out}")
    elif out:
        writers = {out / "mc.csv": lambda file: mc.sweep.to_csv(file, metrics=MC_METRICS,
                                                                   overwrite=True)}
        if args.parquet:
            writers[out / "mc.parquet"] = parquet_writer(mc.sweep)
        if not args.no_plots:
            writers.update({out / f"mc_{m}.png": _histogram_writer(mc, m) for m in MC_METRICS})
        written = write_files(writers, overwrite=args.overwrite, replaces=_mc_files(out))
        print(f"\nwritten to {out}/: " + ", ".join(p.name for p in written))
    return 0


# --------------------------------------------------------------------------- lsc sensitivity
def _names(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


#: ``lsc sensitivity --derivative``: the technique → the ``method`` of :func:`lsc.analysis.sensitivity`.
DERIVATIVES = {"autodiff": "diffrax", "finite-difference": "finite-difference"}


def _sensitivity_backend(text: str) -> str:
    """``--method`` of ``lsc sensitivity``: a backend, as for every command; the derivative
    techniques that ``--method`` named before are refused with a pointer to ``--derivative``."""
    import argparse
    from ..scene import METHODS
    if text in METHODS:
        return text
    if text in DERIVATIVES:
        raise argparse.ArgumentTypeError(
            f"--method is the backend of the solves ({', '.join(METHODS)}), as for every "
            f"command; the derivative technique is --derivative {text}")
    raise argparse.ArgumentTypeError(f"invalid backend {text!r} (choose from "
                                     f"{', '.join(METHODS)})")


def add_sensitivity(sub) -> None:
    """Declare ``lsc sensitivity``."""
    import argparse
    from .sensitivity import DEFAULT_METRICS
    p = sub.add_parser("sensitivity", help="derivatives of delta-V, peak acceleration and duration "
                       "with respect to masses, speeds, stiffness and restitution",
                       description="Sensitivities of the crash metrics to the scene's parameters, "
                       "by forward-mode autodiff through the diffrax solve (events included) or by "
                       "finite differences: each parameter's value, the derivative in the scene's "
                       "units and the elasticity (percent per percent), largest effect first.")
    p.add_argument("scene", metavar="SCENE", help="a scene TOML file or a packaged scene name")
    p.add_argument("--params", type=_names, metavar="P,P,...",
                   help="dotted parameter paths (default: each vehicle's weight or mass and speed, "
                        "each contact's stiffness or force scale and restitution)")
    p.add_argument("--metrics", type=_names, default=list(DEFAULT_METRICS), metavar="M,M,...",
                   help="metrics (default " + ",".join(DEFAULT_METRICS) + ")")
    p.add_argument("--derivative", choices=tuple(DERIVATIVES), default=None,
                   help="autodiff (forward mode through the diffrax solve, default) or "
                        "finite-difference (central differences of the --method solves)")
    p.add_argument("--method", type=_sensitivity_backend, default=None, metavar="M",
                   help="backend of the solves: diffrax for autodiff (the default there); any "
                        "backend for finite differences (default auto)")
    p.add_argument("--rtol", type=float, default=None,
                   help="solver tolerance (default 1e-12; with --global: the backend's own)")
    p.add_argument("--backend", help=argparse.SUPPRESS)  # the old name of --method: refused
    p.add_argument("--plot", metavar="FILE", help="write a tornado chart (PNG, SVG, PDF)")
    p.add_argument("--plot-metric", default=None, metavar="M",
                   help="the metric of the tornado chart (default: the first of --metrics; the "
                        "front vehicle of a per-vehicle one)")
    p.add_argument("--swing", type=float, default=None, metavar="R",
                   help="tornado bars as the metric with each parameter moved by +-R of its value "
                        "(default: elasticities)")
    p.add_argument("--json", metavar="FILE", help="also write the sensitivities as JSON")
    _add_global_options(p)
    add_overwrite_option(p)
    p.set_defaults(func=cmd_sensitivity)


#: The files ``lsc sensitivity --global --out DIR`` writes.
GLOBAL_FILES = ("sobol.csv", "sobol.png")
#: ``lsc sensitivity`` options of the derivative analysis (refused with ``--global``).
_LOCAL_ONLY = ("params", "derivative", "plot", "plot_metric", "swing", "json", "backend")
#: ``lsc sensitivity`` options of ``--global`` (refused without it).
_GLOBAL_ONLY = ("samples", "seed", "uncertainty", "out", "no_plots")


def _add_global_options(p) -> None:
    """Declare ``--global`` and its options on the ``lsc sensitivity`` parser ``p``."""
    g = p.add_argument_group("global sensitivity", "Sobol' first-order and total indices of the "
                             "metrics over the scene's [uncertainty] distributions (SALib), with "
                             "their confidence intervals")
    g.add_argument("--global", dest="global_", action="store_true",
                   help="variance-based indices instead of derivatives")
    g.add_argument("--samples", type=int, default=None, metavar="N",
                   help="base samples of the Sobol' design, a power of two (default 1024; "
                        "N x (inputs + 2) solves)")
    g.add_argument("--seed", type=int, default=None, help="seed of the design (default 0)")
    g.add_argument("--uncertainty", metavar="FILE", help="a TOML file with the distributions")
    g.add_argument("--out", metavar="DIR", help="write sobol.csv (the table) and sobol.png (the "
                                                "bar chart) here")
    g.add_argument("--no-plots", action="store_true", help="with --out: no sobol.png")


def _refuse_options(args, names, why: str) -> None:
    """A ``SceneError`` on the first of ``names`` given on the command line."""
    for name in names:
        if getattr(args, name, None) not in (None, False):
            raise SceneError(name.replace("_", "-"), f"--{name.replace('_', '-')} {why}")


def _sensitivity_options(args) -> dict:
    """``method`` and ``backend`` of :func:`lsc.analysis.sensitivity` from ``--derivative`` and
    ``--method``; :class:`lsc.SceneError` for the old ``--backend`` and for autodiff through a
    backend other than diffrax."""
    if args.backend is not None:
        raise SceneError("backend", "--backend is now --method (the backend of the solves, as "
                                    "for every command); the derivative technique is "
                                    "--derivative autodiff|finite-difference")
    if args.derivative in (None, "autodiff"):
        if args.method not in (None, "diffrax"):
            raise SceneError("method", f"autodiff differentiates through the diffrax solve, not "
                                       f"{args.method}; use --method diffrax, or --derivative "
                                       "finite-difference for another backend")
        return {"method": DERIVATIVES["autodiff"]}
    return {"method": DERIVATIVES["finite-difference"], "backend": args.method or "auto"}


def cmd_sensitivity(args) -> int:
    """Run ``lsc sensitivity``: print the table (and write a tornado chart / JSON)."""
    from .sensitivity import sensitivity
    if args.global_:
        return _cmd_global_sensitivity(args)
    _refuse_options(args, _GLOBAL_ONLY, "is an option of --global")
    options = _sensitivity_options(args)
    scene = resolve_scene(args.scene)
    files = _sensitivity_files(args)
    refuse_existing(files.values(), args.overwrite)
    s = sensitivity(scene, args.params, metrics=args.metrics,
                    rtol=1e-12 if args.rtol is None else args.rtol, **options)
    print(s.summary())
    metric = args.plot_metric or args.metrics[0]
    if args.plot and metric not in s.derivatives:
        raise SceneError("plot-metric", f"{metric!r} is not among --metrics "
                                        f"({', '.join(s.derivatives)})")
    writers = {}
    if args.plot:
        from ..plots import tornado
        writers[files["plot"]] = lambda file: tornado(s, metric, swing=args.swing, file=file,
                                                     overwrite=True)
    if args.json:
        writers[files["json"]] = json_writer(s.to_dict())
    write_files(writers, overwrite=args.overwrite)
    if args.plot:
        print(f"\ntornado chart written to {args.plot}")
    return 0


def _cmd_global_sensitivity(args) -> int:
    """Run ``lsc sensitivity --global``: print the Sobol' indices (and write CSV / bar chart)."""
    from .global_sensitivity import global_sensitivity
    _refuse_options(args, _LOCAL_ONLY, "is an option of the derivative sensitivity; with "
                                       "--global the inputs are the [uncertainty] distributions")
    scene, dists = load_with_uncertainty(args.scene, args.uncertainty)
    out = Path(args.out) if args.out else None
    files = [out / f for f in GLOBAL_FILES] if out else []
    refuse_existing(files, args.overwrite)
    options = {} if args.rtol is None else {"rtol": args.rtol}
    g = global_sensitivity(scene, dists, metrics=args.metrics,
                           n=1024 if args.samples is None else args.samples,
                           seed=0 if args.seed is None else args.seed,
                           method=args.method or "auto", **options)
    print(g.summary())
    if out:
        writers = {out / "sobol.csv": lambda f: g.to_csv(f, overwrite=True)}
        if not args.no_plots:
            writers[out / "sobol.png"] = lambda f: g.plot(file=f, overwrite=True)
        written = write_files(writers, overwrite=args.overwrite, replaces=files)
        print(f"\nwritten to {out}/: " + ", ".join(p.name for p in written))
    return 0


def _sensitivity_files(args) -> dict[str, Path]:
    """The files of ``--plot`` and ``--json`` (refused when they name the same file)."""
    files = {k: Path(getattr(args, k)) for k in ("plot", "json") if getattr(args, k)}
    if len(files) == 2 and files["plot"].resolve() == files["json"].resolve():
        raise SceneError("json", f"--plot and --json name the same file ({args.json})")
    return files


# --------------------------------------------------------------------------- lsc compare
#: The files ``lsc compare --out DIR`` writes.
COMMANDS = [add_bound, add_mc, add_sensitivity, add_compare, add_fit]
