"""Crash-test channels in: a time base [s] and named channels with units, from a table or ISO-MME.

:func:`read_channels` reads

- a multi-column text table (CSV, TSV, semicolon- or tab-separated) or an Excel sheet (pandas,
  with openpyxl): one time column and any number of channels; each column's unit comes from its
  header (``accel_target [g]``, ``time (ms)``) or from ``units={...}``, and ``columns={...}``
  picks and renames columns;
- an ISO-MME 1.6 data set (ISO/TS 13499, the crash-test exchange format): a folder or ``.zip``
  holding ``<test>.mme``, ``Channel/<test>.chn`` (``Number of channels``, ``Name of channel 001
  :<code> / <name>``) and one file per channel ``Channel/<test>.001``, ... whose header lines
  (``Channel code``, ``Name of the channel``, ``Unit``, ``Sampling interval``, ``Time of first
  sample``, ``Number of samples``, ...) precede one value per line.

Each channel's kind (acceleration, force, displacement, velocity) follows from its unit (pint
spelling; ``g`` is standard gravity). All channels share one uniform time base; time zero is the
file's (for crash tests: first contact) unless ``time_zero`` moves it, and samples before it are
the pre-trigger (``offset="pre-trigger"`` removes each channel's mean over them). Channels can be
filtered with the SAE J211 CFC filter (:func:`~lsc.analysis.filters.cfc_filter`) and negated
(``invert``: a lab's sign convention opposite to ``lsc``'s, positive = direction of travel).

Channels are matched to a scene by name (:meth:`Channels.match`): ``accel_<vehicle name>``,
``velocity_<vehicle name>``, ``force`` / ``deformation`` (first contact; ``force_2`` ... for
later ones), or an explicit mapping ``{role: channel name}``. A bad file raises
:class:`~lsc.SceneError` naming the file, the line and the column.
"""

from __future__ import annotations

import csv
import re
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import SceneError
from ._channel import STEP_TOLERANCE, KINDS, Channel, Channels, kind_of, time_factor
from ._isomme import isomme_files, read_isomme

__all__ = ["Channel", "Channels", "read_channels", "write_csv", "write_isomme", "KINDS"]

_HEADER_UNIT = re.compile(r"^\s*(.*?)\s*[\[(]\s*(.*?)\s*[\])]\s*$")
_TIME_NAMES = ("time", "t")


# ---------------------------------------------------------------------------------- reading

def read_channels(source, *, columns: dict | None = None, units: dict | None = None, time=None,
                  sheet=0, delimiter: str | None = None, time_zero: float = 0.0, offset: str | None = None,
                  invert=(), cfc=None) -> Channels:
    """Test channels from a CSV/TSV/Excel table or an ISO-MME data set (folder, ``.zip``, ``.mme``).

    Parameters
    ----------
    columns : dict, optional
        ``{channel name: column header or 0-based index}`` (tables only): read these columns,
        under these names (default: every column but time, named by its header).
    units : dict, optional
        ``{channel name or "time": unit}``, overriding or supplying the header's ``[unit]``.
    time : str or int, optional
        The time column (default: the one headed ``time`` or ``t``, any unit).
    sheet : str or int
        Excel sheet name or index.
    time_zero : float
        File time [s] that becomes t = 0 (e.g. first contact); earlier samples are the pre-trigger.
    offset : None or ``"pre-trigger"``
        Subtract each channel's mean over the pre-trigger samples (t < 0).
    invert : names
        Channels to negate (recorded with the opposite sign convention).
    cfc : float, optional
        Filter every channel with the J211 CFC filter of this class (60, 180, 600, 1000).

    Raises
    ------
    lsc.SceneError
        Naming the file, line and column: a missing channel or time column, a non-numeric or
        empty cell, an unknown unit, or a time base that is not one constant sample rate.
    """
    path = Path(source).expanduser()
    where = str(source)
    if path.is_dir() or path.suffix.lower() in (".zip", ".mme"):
        t, chans = read_isomme(path)
    elif path.suffix.lower() in (".xlsx", ".xlsm", ".xls", ".ods"):
        t, chans = _table_channels(_excel_rows(path, sheet), where, columns, units, time, excel=True)
    else:
        t, chans = _table_channels(_text_rows(path, delimiter), where, columns, units, time)
    channels = Channels(t - float(time_zero), chans, where)
    return _post_process(channels, offset, invert, cfc)


def _post_process(channels: Channels, offset, invert, cfc) -> Channels:
    out = dict(channels.channels)
    for name in invert:
        ch = channels[name]
        out[name] = replace(ch, values=-ch.values)
    if offset is not None:
        if offset != "pre-trigger":
            raise SceneError("offset", f'offset is None or "pre-trigger", got {offset!r}')
        pre = channels.t < -0.5 * channels.dt
        if not pre.any():
            raise SceneError(channels.source, 'offset="pre-trigger" needs samples before time zero; '
                                              'the file has none (move time_zero or drop offset)')
        out = {n: replace(c, values=c.values - c.values[pre].mean()) for n, c in out.items()}
    channels = replace(channels, channels=out)
    return channels if cfc is None else channels.filtered(cfc)


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        return path.read_text(encoding="latin-1")
    except OSError as e:
        raise SceneError(str(path), f"cannot read {path}: {e.strerror or e}") from None


def _text_rows(path: Path, delimiter) -> tuple[list, int, list]:
    """``(header cells, header line, [(line, cells), ...])`` of a delimited text file."""
    lines = [(i, ln) for i, ln in enumerate(_read_text(path).splitlines(), 1)
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise SceneError(str(path), f"{path} is empty")
    head_no, head = lines[0]
    if delimiter is None:
        delimiter = "\t" if "\t" in head else (";" if ";" in head and "," not in head else ",")
    parse = lambda text: [c.strip() for c in next(csv.reader([text], delimiter=delimiter))]  # noqa: E731
    return parse(head), head_no, [(no, parse(text)) for no, text in lines[1:]]


def _excel_rows(path: Path, sheet) -> tuple[list, int, list]:
    import pandas as pd

    try:
        frame = pd.read_excel(path, sheet_name=sheet, header=None, dtype=object)
    except ImportError as e:
        raise SceneError(str(path), f"reading Excel files needs openpyxl ({e}); "
                                    "pip install openpyxl, or save the sheet as CSV") from None
    except (OSError, ValueError) as e:
        raise SceneError(str(path), f"cannot read sheet {sheet!r} of {path}: {e}") from None
    rows = [(i + 1, ["" if v is None or (isinstance(v, float) and np.isnan(v)) else str(v) for v in row])
            for i, row in enumerate(frame.itertuples(index=False))]
    rows = [(no, cells) for no, cells in rows if any(cells)]
    if not rows:
        raise SceneError(str(path), f"sheet {sheet!r} of {path} is empty")
    return rows[0][1], rows[0][0], rows[1:]


def _split_header(cell: str) -> tuple[str, str | None]:
    m = _HEADER_UNIT.match(cell)
    return (m.group(1), m.group(2)) if m else (cell.strip(), None)


def _table_channels(table, where, columns, units, time, excel=False):
    header, head_no, rows = table
    names_units = [_split_header(c) for c in header]
    names = [n for n, _ in names_units]
    line = "row" if excel else "line"

    def locate(spec, what) -> int:
        if isinstance(spec, int) and not isinstance(spec, bool):
            if not 0 <= spec < len(header):
                raise SceneError(where, f"{what}: column {spec} does not exist (the file has {len(header)} columns)")
            return spec
        for i, (name, _) in enumerate(names_units):
            if spec in (header[i], name):
                return i
        raise SceneError(where, f"{what}: no column {spec!r} in the header ({line} {head_no}); "
                                f"the columns are: {', '.join(header)}")

    if time is None:
        t_col = next((i for i, n in enumerate(names) if n.lower() in _TIME_NAMES), None)
        if t_col is None:
            raise SceneError(where, f"no time column: head one column 'time [s]' ({line} {head_no}) "
                                    "or pass time=<header or index>")
    else:
        t_col = locate(time, "time")
    wanted = columns if columns is not None else _header_channels(names, t_col, where, f"{line} {head_no}")
    picked = {name: locate(spec, f"channel {name!r}") for name, spec in wanted.items()}
    units = dict(units or {})
    unit_of = {}
    for name, col in [("time", t_col), *picked.items()]:
        unit = units.get(name) or names_units[col][1]
        if not unit:
            raise SceneError(where, f"column {col + 1} ({header[col]!r}, {line} {head_no}) has no unit: "
                                    f"write it in the header ('{names[col]} [g]') or pass units={{{name!r}: ...}}")
        unit_of[name] = unit
    data = _numbers(rows, [t_col, *picked.values()], header, where, line)
    t = _uniform_time(data[:, 0] * time_factor(unit_of["time"], f"{where}, column {t_col + 1} ({header[t_col]!r})"),
                      [no for no, _ in rows], where, line, t_col)
    chans = {}
    for j, (name, col) in enumerate(picked.items(), 1):
        unit = unit_of[name]
        kind = kind_of(unit, f"{where}, {line} {head_no}, column {col + 1} ({header[col]!r})")
        chans[name] = Channel(name, data[:, j], unit, kind, f"{where}, column {col + 1}")
    return t, chans


def _header_channels(names, t_col, where, at) -> dict[str, int]:
    """``{name: column}`` of every named column but time (a column with an empty header, such as
    a trailing delimiter leaves, is skipped); SceneError if two columns share a name."""
    out = {}
    for i, name in enumerate(names):
        if i == t_col or not name:
            continue
        if name in out:
            raise SceneError(where, f"{at}: columns {out[name] + 1} and {i + 1} are both named {name!r}; "
                                    "rename one, or pick columns with columns={name: column}")
        out[name] = i
    return out


def _numbers(rows, cols, header, where, line) -> np.ndarray:
    out = np.empty((len(rows), len(cols)))
    for r, (no, cells) in enumerate(rows):
        for j, col in enumerate(cols):
            cell = cells[col] if col < len(cells) else ""
            try:
                value = float(cell)
            except ValueError:
                value = np.nan
            if not np.isfinite(value):
                what = "is empty" if not cell else f"is {cell!r}, not a finite number"
                raise SceneError(where, f"{line} {no}, column {col + 1} ({header[col]!r}) {what}")
            out[r, j] = value
    if len(rows) < 3:
        raise SceneError(where, f"needs at least 3 samples, got {len(rows)}")
    return out


def _uniform_time(t: np.ndarray, lines, where, line, col) -> np.ndarray:
    """The uniform grid ``t[0] + i dt`` that the sample times lie on; SceneError at the first
    sample off it (an inconsistent sample rate, a gap, a repeated or out-of-order time)."""
    n = t.size
    dt = (t[-1] - t[0]) / (n - 1)
    if not dt > 0:
        raise SceneError(where, f"the time column (column {col + 1}) does not increase")
    grid = t[0] + np.arange(n) * dt
    off = np.nonzero(np.abs(t - grid) > STEP_TOLERANCE * dt)[0]
    if off.size:
        i = max(int(off[0]), 1)
        raise SceneError(where, f"{line} {lines[i]}, column {col + 1}: time step {t[i] - t[i - 1]:.6g} s differs "
                                f"from the mean sample interval {dt:.6g} s; the channels must have one "
                                "constant sample rate (resample the file)")
    return grid


# ---------------------------------------------------------------------------------- writing

def write_csv(channels: Channels, path, *, delimiter: str = ",", fmt: str = "%.10g") -> Path:
    """Write ``channels`` as a table headed ``time [s]``, ``name [unit]``, ... (read back by
    :func:`read_channels`)."""
    path = Path(path)
    cols = [channels.t] + [c.values for c in channels]
    header = delimiter.join(["time [s]"] + [f"{c.name} [{c.unit}]" for c in channels])
    np.savetxt(path, np.column_stack(cols), delimiter=delimiter, fmt=fmt, header=header, comments="")
    return path


def write_isomme(channels: Channels, path, *, test: str = "TEST", comments: tuple[str, ...] = (),
                 codes: dict | None = None) -> Path:
    """Write ``channels`` as an ISO-MME 1.6 data set: a folder, or a ``.zip`` if ``path`` ends so.

    ``codes``: ``{channel name: 16-character ISO channel code}`` (default: the name); the name
    goes into ``Name of the channel``.
    """
    files = isomme_files(channels, test, comments, codes or {})
    path = Path(path)
    if path.suffix.lower() == ".zip":
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
            for name, text in files.items():  # fixed member dates: the same channels, the same bytes
                z.writestr(zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0)), text)
    else:
        for name, text in files.items():
            (path / name).parent.mkdir(parents=True, exist_ok=True)
            (path / name).write_text(text, encoding="utf-8")
    return path


