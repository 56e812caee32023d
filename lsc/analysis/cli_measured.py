"""The command-line subcommands on measured test data: ``lsc compare`` (a simulation against a
test, ISO/TS 18571) and ``lsc fit`` (scene parameters fitted to a test). Registered with the other
analyses' subcommands by :mod:`lsc.analysis.cli`."""

from __future__ import annotations

from pathlib import Path

from ..cli_common import add_overwrite_option, resolve_scene
from ..errors import SceneError
from ..outputs import refuse_existing, write_files


COMPARE_FILES = ("comparison.csv", "comparison.json", "comparison.png")


def _add_test_arguments(p, scene_help: str) -> None:
    """Declare SCENE, DATA (a crash test's channels), ``--cfc`` and ``--time-zero`` (read back
    by :func:`_read_test`) on the subcommand parser ``p``."""
    p.add_argument("scene", metavar="SCENE", help=scene_help)
    p.add_argument("data", metavar="DATA", help="the test's channels (table or ISO-MME data set)")
    p.add_argument("--cfc", type=float, default=None, metavar="C",
                   help="filter every channel with the SAE J211 CFC filter of this class "
                        "(60, 180, 600, 1000; default: as recorded)")
    p.add_argument("--time-zero", type=float, default=0.0, metavar="T",
                   help="the file time [s] of first contact (default 0)")


def _read_test(args):
    """The test's channels named by :func:`_add_test_arguments`' arguments."""
    from .channels import read_channels
    return read_channels(args.data, time_zero=args.time_zero, cfc=args.cfc)


def add_compare(sub) -> None:
    """Declare ``lsc compare``."""
    from ..scene import METHODS
    p = sub.add_parser("compare", help="a simulation against measured test channels: metric "
                       "differences and the ISO/TS 18571 rating",
                       description="Solve the scene, read the test's channels (a CSV/TSV/Excel "
                       "table with headers such as 'accel_target [g]', or an ISO-MME data set: "
                       "folder, .zip or .mme) and compare them: peak acceleration, delta-V and "
                       "pulse duration per vehicle, measured and simulated, and the ISO/TS 18571 "
                       "corridor, phase, magnitude, slope and total scores of each channel.")
    _add_test_arguments(p, "a scene TOML file or a packaged scene name")
    p.add_argument("--method", choices=METHODS, default="auto", help="backend (default auto)")
    p.add_argument("--out", metavar="DIR", help="write comparison.csv, comparison.json and "
                                                "comparison.png (the overlay) here")
    p.add_argument("--no-plots", action="store_true", help="with --out: no comparison.png")
    add_overwrite_option(p)
    p.set_defaults(func=cmd_compare)


def cmd_compare(args) -> int:
    """Run ``lsc compare``: print the comparison (and write CSV, JSON and the overlay figure)."""
    from ..api import solve
    from .compare import compare
    scene = resolve_scene(args.scene)
    out = Path(args.out) if args.out else None
    files = [out / f for f in COMPARE_FILES] if out else []
    refuse_existing(files, args.overwrite)
    comparison = compare(solve(scene, method=args.method), _read_test(args))
    print(comparison.summary())
    if out:
        # (each writer fills the temporary file write_files made: that one checked the targets)
        writers = {out / "comparison.csv": lambda f: comparison.to_csv(f, overwrite=True),
                   out / "comparison.json": lambda f: comparison.to_json(f, overwrite=True)}
        if not args.no_plots:
            writers[out / "comparison.png"] = lambda file: comparison.figure().savefig(file, dpi=120)
        written = write_files(writers, overwrite=args.overwrite, replaces=files)
        print(f"\nwritten to {out}/: " + ", ".join(p.name for p in written))
    return 0


# --------------------------------------------------------------------------- lsc fit
#: The files ``lsc fit --out DIR`` writes.
FIT_FILES = ("fitted.toml", "fit.json", "fit.png")


def _path_value(text: str) -> tuple[str, float]:
    """``PATH=VALUE`` (a number in the scene's units)."""
    path, sep, value = text.partition("=")
    try:
        if not sep or not path.strip():
            raise ValueError
        return path.strip(), float(value)
    except ValueError:
        raise SceneError("initial", f"expected PATH=NUMBER (e.g. contacts.0.loading.stiffness="
                                    f"30000), got {text!r}") from None


def _path_bounds(text: str) -> tuple[str, tuple[float, float]]:
    """``PATH=LO:HI`` (numbers in the scene's units)."""
    path, sep, rng = text.partition("=")
    lo, colon, hi = rng.partition(":")
    try:
        if not sep or not colon or not path.strip():
            raise ValueError
        return path.strip(), (float(lo), float(hi))
    except ValueError:
        raise SceneError("bounds", f"expected PATH=LO:HI (e.g. contacts.0.unloading.restitution="
                                   f"0:1), got {text!r}") from None


def add_fit(sub) -> None:
    """Declare ``lsc fit``."""
    from ..scene import METHODS
    p = sub.add_parser("fit", help="fit scene parameters to measured test channels (least squares)",
                       description="Solve the scene repeatedly and fit the given parameters "
                       "(dotted paths: a stiffness, a loading-table force scale, a restitution, a "
                       "speed, a mass) to the test's acceleration and force channels by least "
                       "squares; print the fitted values with standard errors, their correlation "
                       "and the ISO/TS 18571 rating of the fit.")
    _add_test_arguments(p, "a scene TOML file or a packaged scene name (its values are the "
                           "starting values)")
    p.add_argument("--param", action="append", required=True, metavar="PATH",
                   help="a fitted parameter, e.g. contacts.0.loading.stiffness (repeatable)")
    p.add_argument("--initial", action="append", default=[], metavar="PATH=V",
                   help="a starting value in the scene's units (repeatable)")
    p.add_argument("--bounds", action="append", default=[], metavar="PATH=LO:HI",
                   help="bounds of a parameter in the scene's units (repeatable)")
    p.add_argument("--method", choices=METHODS, default=None, help="backend (default: the scene's)")
    p.add_argument("--errors", choices=("autocorrelated", "independent"), default="autocorrelated",
                   help="standard errors allowing for residuals correlated in time (default) or "
                        "assuming independent ones")
    p.add_argument("--out", metavar="DIR", help="write fitted.toml (the fitted scene), fit.json "
                                                "and fit.png (the overlay) here")
    p.add_argument("--no-plots", action="store_true", help="with --out: no fit.png")
    add_overwrite_option(p)
    p.set_defaults(func=cmd_fit)


def cmd_fit(args) -> int:
    """Run ``lsc fit``: print the fit (and write the fitted scene, JSON and the overlay)."""
    from .fit import fit
    scene = resolve_scene(args.scene)
    initial = dict(_path_value(t) for t in args.initial)
    bounds = dict(_path_bounds(t) for t in args.bounds)
    out = Path(args.out) if args.out else None
    files = [out / f for f in FIT_FILES] if out else []
    refuse_existing(files, args.overwrite)
    result = fit(scene, _read_test(args), args.param, initial=initial or None, bounds=bounds or None,
                 method=args.method, errors=args.errors)
    print(result.summary())
    if out:
        writers = {out / "fitted.toml": lambda f: result.to_toml(f, overwrite=True),
                   out / "fit.json": lambda f: result.to_json(f, overwrite=True)}
        if not args.no_plots:
            writers[out / "fit.png"] = \
                lambda file: result.comparison().figure().savefig(file, dpi=120)
        written = write_files(writers, overwrite=args.overwrite, replaces=files)
        print(f"\nwritten to {out}/: " + ", ".join(p.name for p in written))
    return 0


#: The subcommands this module adds to ``lsc.cli.COMMANDS``.
