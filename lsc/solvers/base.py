"""The backend contract: what a backend declares, and the one definition of every option.

A backend is one module (or one small package) of :mod:`lsc.solvers` that holds a
:class:`Backend` named ``BACKEND``: its name, the options it takes (names of :data:`OPTIONS`,
validated here for every backend alike), a *positive* declaration of the features it solves
(:meth:`lsc.model.HybridModel.features`: contact laws, curve kinds, effects, gaps) and of the
numbers of vehicles, and the module whose ``solve(model, **options) -> Result`` (and, where it
has one, ``solve_batch(model, values, **options) -> dict``) do the work. The implementation
module is imported on first use, so declarations are cheap to read (the diffrax backend's does
not import JAX).

A scene that uses a feature a backend does not declare is refused by it with a
:class:`~lsc.errors.SceneError` naming that feature, never solved without it.
"""

from __future__ import annotations

import contextvars
import difflib
import importlib
import importlib.util
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError

__all__ = ["Option", "OPTIONS", "CONTROLS", "MAX_SAMPLES", "Backend", "check_option",
           "solve_alone", "warning_array"]

#: Most points in a Result's sampled series (``n_samples``): a million rows of every series.
MAX_SAMPLES = 1_000_000
#: The warnings of the members a batch path hands to its single solve (:func:`solve_alone`),
#: member index → ``Result.warnings``, gathered for :meth:`Backend.solve_batch` (``None``
#: outside one).
_ALONE_WARNINGS = contextvars.ContextVar("lsc_alone_warnings", default=None)


@dataclass(frozen=True)
class Option:
    """A solver option: its ``name``, its ``kind`` (``"rtol"``: in (0, 1); ``"positive"``: a
    positive finite number; ``"count"``: a whole number >= 1, at most ``most``; ``"name"``: a
    string), whether ``None`` is accepted (the backend's default), and what it means (``doc``,
    with units)."""

    name: str
    kind: str
    doc: str
    none: bool = False
    most: int | None = None

    def check(self, value) -> None:
        """Raise a :class:`SceneError` at ``solver.<name>`` if ``value`` is out of range."""
        path = f"solver.{self.name}"
        if value is None and self.none:
            return
        if self.kind == "name":
            if not isinstance(value, str):
                raise SceneError(path, f"{self.name} must be a name, got {value!r}")
            return
        if self.kind == "count":
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise SceneError(path, f"{self.name} must be a positive integer, got {value!r}")
            if self.most is not None and value > self.most:
                raise SceneError(path, f"{self.name} must be at most {self.most:,} ({self.doc}), "
                                       f"got {value:,}")
            return
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
                or not np.isfinite(value) or value <= 0:
            raise SceneError(path, f"{self.name} must be a positive finite number, got {value!r}")
        if self.kind == "rtol" and not value < 1:
            raise SceneError(path, f"{self.name} must be a positive finite number below 1 (a "
                                   f"relative tolerance, such as 1e-10), got {value!r}")


def _options(*opts: Option) -> dict[str, Option]:
    return {o.name: o for o in opts}


#: Every solver option, defined once. A backend declares which of them it takes.
OPTIONS = _options(
    Option("rtol", "rtol", "relative tolerance of an adaptive integrator"),
    Option("atol", "positive", "absolute tolerance (None: the model's default scales)", none=True),
    Option("integrator", "name", "the integration method of the backend (e.g. 'DOP853')"),
    Option("t_end", "positive", "simulate until this time [s] (must not cut the crash)"),
    Option("first_step", "positive", "first step of the integrator [s]"),
    Option("dt", "positive", "fixed time step [s] of the paper's algorithm"),
    Option("max_events", "count", "most discrete events in one solve"),
    Option("max_steps", "count", "most integrator steps (in one segment, or in all)"),
    Option("n_samples", "count", "points in each sampled series", most=MAX_SAMPLES),
)

#: How a batch path runs (``lsc.sweep`` keywords, not solver options of a scene).
CONTROLS = _options(
    Option("chunk", "count", "most members in one batch call"),
    Option("workers", "count", "batch calls run at once (threads)"),
)


def check_option(name: str, value) -> None:
    """Refuse, with a :class:`SceneError` at ``solver.<name>``, an option no backend knows
    (naming the closest known one) or a value outside its range (:class:`Option`)."""
    opt = OPTIONS.get(name)
    if opt is None:
        close = difflib.get_close_matches(str(name), sorted(OPTIONS), n=1, cutoff=0.6)
        hint = f"; did you mean {close[0]!r}?" if close else ";"
        raise SceneError(f"solver.{name}", f"unknown option {name!r}{hint} accepted options: "
                         f"{', '.join(sorted(OPTIONS))}")
    opt.check(value)


#: What each feature of a model means, for messages (features not listed are shown as named).
FEATURES = {
    "law:ifd": "the IF-D hysteresis contact law",
    "law:kelvin": "the Kelvin contact law",
    "law:hunt-crossley": "the Hunt-Crossley contact law",
    "law:brach": "the Brach contact law",
    "loading:linear": "a linear loading line (one stiffness)",
    "loading:table": "a loading table (piecewise-linear IF-D curve)",
    "unloading:restitution": "unloading by restitution",
    "unloading:stiffness": "unloading by stiffness",
    "unloading:table": "an unloading table",
    "effect:brake": "braking",
    "effect:failure": "a bumper failure force",
    "effect:post-failure": "a post-failure loading curve",
    "gap:open": "an initial gap between vehicles",
    "contact:lock": ("locked pairs (a chain's near-plastic contact, e < 0.05, that chatters "
                     "pressed shut by its neighbours locks: lsc.locking)"),
}


def describe(feature: str) -> str:
    """The words for a ``feature`` in messages."""
    return FEATURES.get(feature, f"the feature {feature!r}")


@dataclass(frozen=True)
class Backend:
    """A backend's declaration.

    Attributes
    ----------
    name : str
        The method name users give (``lsc.solve(scene, method=name)``).
    module : str
        The module (absolute) holding ``solve`` and, if ``batch`` is given, ``solve_batch``;
        imported on first use.
    options : tuple of str
        The options (names of :data:`OPTIONS`) ``solve`` takes.
    solves : frozenset of str
        Every feature (:meth:`lsc.model.HybridModel.features`) it solves.
    vehicles : (int, int or None)
        Fewest and most vehicles (``None``: any number).
    exact : bool
        Its answers are exact to rounding (``auto`` picks among these).
    cost : float
        Order of preference of ``auto`` among exact backends (lower first).
    batch : frozenset of str or None
        The features its ``solve_batch`` solves (``None``: no batch path).
    batch_options : tuple of str
        The options ``solve_batch`` takes.
    requires : tuple of str
        Modules it needs (an optional extra), and how to install them (``install``).
    auto : bool
        Whether ``auto`` may pick it (``False``: only by its name, e.g. while it is still slower
        than the integrator ``auto`` would use instead).
    """

    name: str
    module: str
    options: tuple[str, ...]
    solves: frozenset[str]
    vehicles: tuple[int, int | None] = (2, None)
    exact: bool = False
    cost: float = 0.0
    batch: frozenset[str] | None = None
    batch_options: tuple[str, ...] = ()
    requires: tuple[str, ...] = ()
    install: str = ""
    summary: str = ""
    auto: bool = True

    def __post_init__(self):
        unknown = (set(self.options) - set(OPTIONS)) | (set(self.batch_options) - set(OPTIONS)
                                                        - set(CONTROLS))
        if unknown:  # pragma: no cover - a declaration error, caught by the registry tests
            raise ValueError(f"backend {self.name!r} declares unknown options {sorted(unknown)}")

    # ------------------------------------------------------------------ what it solves
    def missing(self, model, batch: bool = False) -> list[str]:
        """The reasons (words) this backend cannot solve ``model`` (a
        :class:`~lsc.model.HybridModel`); empty when it can. ``batch``: by ``solve_batch``."""
        lo, hi = self.vehicles
        out = []
        if model.N < lo or (hi is not None and model.N > hi):
            want = f"exactly {lo}" if lo == hi else (f"at least {lo}" if hi is None
                                                      else f"{lo} to {hi}")
            out.append(f"it solves {want} vehicles, the scene has {model.N}")
        solves = self.batch if batch else self.solves
        if solves is None:
            return out + ["it has no batch path"]
        out += [f"it does not solve {describe(f)}" for f in sorted(model.features() - solves)]
        return out

    def why_not(self, model, batch: bool = False) -> str | None:
        """Why this backend cannot solve ``model`` (``None`` if it can)."""
        reasons = self.missing(model, batch)
        return "; ".join(reasons) if reasons else None

    def available(self) -> bool:
        """True when the modules it needs are installed."""
        return all(importlib.util.find_spec(m) is not None for m in self.requires)

    def check(self, model, batch: bool = False) -> None:
        """Raise a :class:`SceneError` at ``solver.method`` naming what this backend does not
        solve in ``model``."""
        reason = self.why_not(model, batch)
        if reason:
            from . import solvers_for

            # the general integrator first (it solves every built-in feature), then the others
            others = sorted((b for b in solvers_for(model) if b != self.name),
                            key=lambda b: b != "scipy")
            hint = (f"use method {others[0]!r} (or 'auto')" if others else
                    "no registered backend solves this scene")
            raise SceneError("solver.method", f"method {self.name!r} does not apply to this "
                                              f"scene: {reason}; {hint}")

    def check_options(self, options: dict, batch: bool = False) -> None:
        """Refuse options this backend does not take, and values out of range."""
        accepted = self.batch_options if batch else self.options
        for name, value in options.items():
            if name not in accepted:
                if name not in CONTROLS:
                    check_option(name, value)  # an unknown name gets the closest known one
                raise SceneError(f"solver.{name}", f"option {name!r} does not apply to method "
                                                   f"{self.name!r}; it accepts: "
                                                   f"{', '.join(sorted(accepted))}")
            (CONTROLS.get(name) or OPTIONS[name]).check(value)

    # ------------------------------------------------------------------ doing it
    def implementation(self):
        """The implementation module (imported now), or a :class:`SceneError` saying how to
        install what it needs."""
        try:
            return importlib.import_module(self.module)
        except ModuleNotFoundError as exc:
            if self.requires and not self.available():
                raise SceneError("solver.method", f"method {self.name!r} needs "
                                 f"{' and '.join(self.requires)} ({exc}); install them with: "
                                 f"{self.install}") from exc
            raise

    def solve(self, model, **options):
        """Solve ``model`` (checked against the declaration first) as a
        :class:`~lsc.result.Result`."""
        self.check(model)
        self.check_options(options)
        return self.implementation().solve(model, **options)

    def solve_batch(self, model, values: dict, *, progress=None, **options) -> dict:
        """Solve every member of ``values`` (dotted scene path → (n,) array in scene units,
        each member already validated) of ``model``'s scene: a dict with ``metrics`` (name →
        array, leading axis n, :data:`lsc.result.METRICS`) and ``status`` ((n,) object array:
        ``"ok"`` or ``"SimulationError: ..."``, the message a single solve raises).
        ``progress``: optional callable ``progress(k)``, advanced by ``k`` members as they
        finish. Also ``warnings`` ((n,) object array of tuples): each member's
        ``Result.warnings``, those of the members the backend solves alone
        (:func:`solve_alone`) and, for the others, what the metrics say
        (:func:`lsc.laws.damping_tails.member_tails`)."""
        from ..laws.damping_tails import member_tails

        self.check(model, batch=True)
        self.check_options(options, batch=True)
        alone = {}
        token = _ALONE_WARNINGS.set(alone)
        try:
            out = self.implementation().solve_batch(model, values, progress=progress, **options)
        finally:
            _ALONE_WARNINGS.reset(token)
        met = out["metrics"]
        tails = member_tails(model.scene, met["max_deformation"], met["permanent_deformation"])
        return {**out, "warnings": warning_array(alone.get(j, tail)
                                                 for j, tail in enumerate(tails))}


def warning_array(items) -> np.ndarray:
    """(n,) object array of each member's warnings, ``items`` (tuples of strings; ``[()] * n``:
    none has any)."""
    items = list(items)
    out = np.empty(len(items), dtype=object)
    out[:] = items
    return out


def solve_alone(solve, model, values: dict, members, metrics: dict, status, *, progress=None,
                **options) -> None:
    """A batch path's members ``members`` (indices) solved one by one by the backend's single
    ``solve(model, n_samples=2, **options)``, as :func:`lsc.solve` would solve them: each one's
    metrics written into ``metrics`` (arrays with the member axis first) and ``"ok"`` into
    ``status``, or NaN metrics and ``"SimulationError: <the single solve's message>"``;
    ``progress(1)`` after each. Its ``Result.warnings`` are kept for
    :meth:`Backend.solve_batch`."""
    from ..errors import SimulationError
    from ..model import HybridModel

    gathered = _ALONE_WARNINGS.get()
    for j in members:
        member = {path: float(v[j]) for path, v in values.items()}
        try:
            r = solve(HybridModel(model.scene.with_values(member)), n_samples=2, **options)
        except SimulationError as err:
            for arr in metrics.values():
                arr[j] = np.nan
            status[j] = f"SimulationError: {err}"
        else:
            for name, arr in metrics.items():
                arr[j] = getattr(r, name)
            status[j] = "ok"
            if gathered is not None:
                gathered[int(j)] = r.warnings
        if progress is not None:
            progress(1)
