"""Measured force–deflection data → loading curves (paper Appendix B).

:func:`read_measured` reads two columns of a CSV file (any units) and :func:`measured_curve`
turns deformation/force samples into a :class:`~lsc.curves.Curve` table in a unit system: the
compression branch (up to the largest deformation), shifted to start at zero deformation, made
strictly increasing in deformation, optionally cut (at the max force or a deformation),
resampled (``n`` points or a ``step``) and smoothed (moving average or Savitzky–Golay), with
negative forces set to zero. :func:`series_measured` combines two bumpers' measured curves in
series (at equal force the deformations add: the paper's Fig. B5 dotted curve).
:func:`curve_table` gives the ``[[D, F], ...]`` list for a scene's ``loading = { table = ... }``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..curves import Curve
from ..errors import SceneError
from ..units import to_system, unit_factor

__all__ = ["read_measured", "read_columns", "measured_curve", "series_measured", "curve_table",
           "cut_at_force", "envelope"]


def read_columns(path, *, columns=(0, 1), delimiter=None) -> tuple[np.ndarray, np.ndarray]:
    """Two numeric columns of a CSV / text file, as given (no units applied).

    ``columns``: two indices or header names; ``delimiter``: ``","``, ``";"``, ``"\\t"`` or
    ``None`` (guessed per line: comma, semicolon, else whitespace). Leading non-numeric rows
    (headers) and ``#`` comment lines are skipped.
    """
    file = Path(path).expanduser()
    try:
        text = file.read_text(encoding="utf-8-sig")
    except OSError as e:
        raise SceneError(str(path), f"cannot read {file}: {e.strerror or e}") from None
    header = None
    rows = []
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        sep = delimiter if delimiter is not None else ("," if "," in line else (";" if ";" in line else None))
        cells = [c.strip().strip('"').strip("'") for c in line.split(sep)]
        nums = []
        for c in cells:
            try:
                nums.append(float(c))
            except ValueError:
                nums.append(None)
        if not rows and all(x is None for x in nums):
            header = cells
            continue
        rows.append((lineno, nums))
    if not rows:
        raise SceneError(str(path), f"{file} has no numeric rows")
    idx = []
    for c in columns:
        if isinstance(c, str):
            if header is None or c not in header:
                raise SceneError(str(path), f"no column named {c!r}" + (f"; header: {header}" if header else
                                                                       " (the file has no header row)"))
            idx.append(header.index(c))
        else:
            idx.append(int(c))
    out = np.empty((len(rows), 2))
    for j, (lineno, nums) in enumerate(rows):
        for col, i in enumerate(idx):
            if i >= len(nums) or nums[i] is None or not np.isfinite(nums[i]):
                raise SceneError(str(path), f"{file}, line {lineno}: column {i} is not a finite number")
            out[j, col] = nums[i]
    return out[:, 0], out[:, 1]


def read_measured(path, *, deformation=None, force=None, units: str = "SI", columns=(0, 1),
                  delimiter=None, **processing) -> Curve:
    """A loading curve from a CSV of measured deformation and force.

    ``deformation``, ``force``: the columns' units (``"in"``, ``"mm"``, ``"lbf"``, ``"kN"``;
    default: already in ``units``); ``units``: the unit system of the curve (``"SI"``: m, N;
    ``"US"``: ft, lbf), that of the scene it goes into. ``processing``: the options of
    :func:`measured_curve`.
    """
    d, f = read_columns(path, columns=columns, delimiter=delimiter)
    return measured_curve(d, f, deformation=deformation, force=force, units=units, **processing)


def measured_curve(d, f, *, deformation=None, force=None, units: str = "SI", branch: str = "loading",
                   zero: bool = True, cut=None, resample: int | None = None, step=None,
                   smooth: str | None = None, window: int = 5, polyorder: int = 2) -> Curve:
    """Deformation/force samples → a :class:`Curve` table in ``units`` (m/N or ft/lbf).

    Parameters
    ----------
    d, f : array (n,)
        Deformation and force samples in time order, in the units ``deformation`` / ``force``
        (default: those of ``units``).
    branch : ``"loading"`` or ``"all"``
        Keep the samples up to the largest deformation (the compression branch), or all.
    zero : bool
        Shift the deformation so that the first sample is at zero [length].
    cut : None, ``"max-force"``, float or str
        End the curve at its largest force, or at a deformation (a number in ``units`` or
        ``"2.5 in"``); the end point is interpolated.
    resample : int, optional
        Resample onto this many evenly spaced deformations (linear interpolation).
    step : float or str, optional
        Resample onto deformations ``0, step, 2 step, ...`` and the end [length].
    smooth : None, ``"moving"`` or ``"savgol"``
        Moving average over ``window`` samples, or Savitzky–Golay (``window``, ``polyorder``),
        applied to the forces after resampling (smoothing assumes evenly spaced samples).

    Samples that do not advance the deformation beyond every earlier one are dropped (noise in a
    slowly moving LVDT), and negative forces become zero (bumpers push, never pull).
    """
    sys_ = _system(units)
    d = np.asarray(d, float).reshape(-1)
    f = np.asarray(f, float).reshape(-1)
    if d.shape != f.shape or d.size < 2:
        raise SceneError("measured", "deformation and force need the same number (>= 2) of samples")
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(f))):
        raise SceneError("measured", "deformation and force samples must be finite numbers")
    if deformation is not None:
        d = d * unit_factor(deformation, "length", sys_, "deformation")
    if force is not None:
        f = f * unit_factor(force, "force", sys_, "force")
    if branch == "loading":
        i = int(np.argmax(d))
        d, f = d[: i + 1], f[: i + 1]
    elif branch != "all":
        raise SceneError("branch", f'branch is "loading" or "all", got {branch!r}')
    if zero:
        d = d - d[0]
    keep = np.concatenate([[True], d[1:] > np.maximum.accumulate(d)[:-1]])
    d, f = d[keep], f[keep]
    if d[0] != 0.0:
        if d[0] < 0:
            raise SceneError("measured", "the first deformation is negative (use zero=True)")
        d, f = np.concatenate([[0.0], d]), np.concatenate([[0.0], f])
    if d.size < 2:
        raise SceneError("measured", "fewer than two samples with increasing deformation")
    if cut is not None:
        d, f = _cut(d, f, cut, sys_)
    if resample is not None or step is not None:
        d, f = _resample(d, f, resample, step, sys_)
    if smooth is not None:
        f = _smooth(f, smooth, window, polyorder)
    return Curve.table(np.column_stack([d, np.maximum(f, 0.0)]))


def _system(units: str) -> str:
    u = str(units).strip().upper()
    if u not in ("SI", "US"):
        raise SceneError("units", f'the unit system is "SI" (m, N) or "US" (ft, lbf), got {units!r}')
    return u


def _cut(d, f, cut, sys_):
    if isinstance(cut, str) and cut.strip().lower().replace("_", "-") in ("max-force", "max"):
        i = int(np.argmax(f))
        return d[: i + 1], f[: i + 1]
    x = to_system(cut, "length", sys_, "cut")
    if not 0 < x <= d[-1]:
        raise SceneError("cut", f"the cut must lie in (0, {d[-1]:g}], got {x:g}")
    i = int(np.searchsorted(d, x, side="left"))
    if d[i] == x:
        return d[: i + 1], f[: i + 1]
    fx = np.interp(x, d, f)
    return np.append(d[:i], x), np.append(f[:i], fx)


def _resample(d, f, n, step, sys_):
    if n is not None and step is not None:
        raise SceneError("resample", "give resample (points) or step, not both")
    if n is not None:
        if isinstance(n, bool) or int(n) != n or n < 2:
            raise SceneError("resample", f"resample is a number of points >= 2, got {n!r}")
        grid = np.linspace(0.0, d[-1], int(n))
    else:
        h = to_system(step, "length", sys_, "step")
        if not 0 < h < d[-1]:
            raise SceneError("step", f"the step must lie in (0, {d[-1]:g}), got {h:g}")
        grid = np.arange(0.0, d[-1], h)
        if d[-1] - grid[-1] < 1e-9 * h:
            grid = grid[:-1]
        grid = np.append(grid, d[-1])
    return grid, np.interp(grid, d, f)


def _smooth(f, how, window, polyorder):
    how = str(how).strip().lower().replace("_", "-")
    if isinstance(window, bool) or int(window) != window or window < 1:
        raise SceneError("window", f"the window is a number of samples >= 1, got {window!r}")
    window = int(window)
    if window > f.size:
        raise SceneError("window", f"the window ({window}) is longer than the data ({f.size} samples)")
    if how in ("moving", "moving-average", "mean"):
        from scipy.ndimage import uniform_filter1d
        return uniform_filter1d(f, size=window, mode="nearest")
    if how in ("savgol", "savitzky-golay"):
        from scipy.signal import savgol_filter
        if not 0 <= polyorder < window:
            raise SceneError("polyorder", f"polyorder must be below the window ({window}), got {polyorder!r}")
        return savgol_filter(f, window, int(polyorder), mode="interp")
    raise SceneError("smooth", f'smooth is "moving" or "savgol", got {how!r}')


def cut_at_force(curve, force_limit: float) -> Curve:
    """The curve up to where it first reaches ``force_limit`` [force] (unchanged if never)."""
    c = curve if isinstance(curve, Curve) else Curve.table(curve)
    F = float(force_limit)
    if not F > 0:
        raise SceneError("force_limit", f"the force limit must be positive, got {F:g}")
    over = np.nonzero(c.f >= F)[0]
    if over.size == 0:
        if c.extends and c.end_slope > 0:
            return Curve(np.append(c.d, c.deformation_at(F)), np.append(c.f, F), None)
        return c
    i = int(over[0])
    if i == 0:
        raise SceneError("force_limit", f"the curve starts at or above the limit ({c.f[0]:g})")
    return Curve(np.append(c.d[:i], c.deformation_at(F)), np.append(c.f[:i], F), None)


def envelope(curve) -> Curve:
    """The rising envelope of a curve [length, force]: at each deformation the largest force
    reached so far (flat after a peak until the curve climbs back, where the crossing is kept)."""
    c = curve if isinstance(curve, Curve) else Curve.table(curve)
    d, f = c.d, c.f
    out_d, out_f, top = [d[0]], [f[0]], f[0]
    for i in range(1, d.size):
        if f[i] >= top:
            if f[i - 1] < top:  # climbs back through the previous peak inside this segment
                dc = d[i - 1] + (top - f[i - 1]) / (f[i] - f[i - 1]) * (d[i] - d[i - 1])
                if dc > out_d[-1]:
                    out_d.append(dc)
                    out_f.append(top)
            if d[i] > out_d[-1]:
                out_d.append(d[i])
                out_f.append(f[i])
            top = f[i]
    end = c.end_slope
    if f[-1] < top:  # ends below its peak: flat to the last deformation
        out_d.append(d[-1])
        out_f.append(top)
        end = None if end is None else (end if end >= 0 else 0.0)
    return Curve(np.array(out_d), np.array(out_f), end)


def series_measured(a, b, *, force_limit: float | None = None, monotone: str = "envelope") -> Curve:
    """Two bumpers' measured curves in series: at equal force the deformations add (Fig. B5).

    ``a``, ``b``: Curves (or ``[[D, F], ...]``) in one unit system. ``force_limit`` [force]: build
    the system curve up to this force (the paper: 10,000 lb). Curves that fall after a peak (a
    failed impact bar) have no single deformation at a given force: ``monotone="envelope"``
    replaces each by its rising :func:`envelope` (the force held at its peak until the curve
    climbs back; each force keeps the deformation at which it is first reached); ``"error"``
    refuses them.
    """
    curves = []
    for name, c in (("first", a), ("second", b)):
        c = c if isinstance(c, Curve) else Curve.table(c)
        if force_limit is not None:
            c = cut_at_force(c, force_limit)
        if np.any(np.diff(c.f) < 0):
            if monotone == "error":
                raise SceneError(name, f"the {name} curve falls after a peak; use "
                                       "monotone=\"envelope\" or a force_limit below the peak")
            if monotone != "envelope":
                raise SceneError("monotone", f'monotone is "envelope" or "error", got {monotone!r}')
            c = envelope(c)
        curves.append(c)
    try:
        return Curve.series(*curves)
    except ValueError as e:
        raise SceneError("series", str(e)) from None


def curve_table(curve: Curve) -> list[list[float]]:
    """The curve's breakpoints as ``[[D, F], ...]`` for ``loading = { table = ... }``."""
    return np.column_stack([curve.d, curve.f]).tolist()
