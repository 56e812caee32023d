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
import io
import re
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path, PurePosixPath

import numpy as np

from ..errors import SceneError
from ..units import unit_factor

__all__ = ["Channel", "Channels", "read_channels", "write_csv", "write_isomme", "KINDS"]

#: Channel kind → the lsc unit kind its values convert to.
KINDS = {"acceleration": "acceleration", "force": "force", "displacement": "length", "velocity": "velocity"}

_HEADER_UNIT = re.compile(r"^\s*(.*?)\s*[\[(]\s*(.*?)\s*[\])]\s*$")
_TIME_NAMES = ("time", "t")
_STEP_TOLERANCE = 1e-3    # a sample time may stray this fraction of a sample period from the grid


@dataclass(frozen=True)
class Channel:
    """One measured channel: ``values`` in ``unit`` (pint spelling), its ``kind`` (a key of
    :data:`KINDS`), the file it came from (``source``) and a free-text ``label``."""

    name: str
    values: np.ndarray
    unit: str
    kind: str
    source: str = ""
    label: str = ""

    def to(self, system: str) -> np.ndarray:
        """The values in a unit system's unit of the kind (``"SI"``: m/s², N, m, m/s; ``"US"``: ft...)."""
        return self.values * unit_factor(_pint_unit(self.unit), KINDS[self.kind], system, self.source or self.name)


@dataclass(frozen=True)
class Channels:
    """A uniform time base ``t`` [s] (0 = time zero of the test) and named :class:`Channel` s."""

    t: np.ndarray
    channels: dict = field(default_factory=dict)
    source: str = ""
    cfc: object = None

    def __getitem__(self, name: str) -> Channel:
        """The channel of this name (or, failing that, of this label)."""
        if name in self.channels:
            return self.channels[name]
        try:
            return next(c for c in self.channels.values() if c.label and c.label == name)
        except StopIteration:
            raise SceneError(self.source, f"no channel named {name!r}; the channels are: "
                                          f"{', '.join(self.channels) or '(none)'}") from None

    def __contains__(self, name) -> bool:
        return name in self.channels

    def __iter__(self):
        return iter(self.channels.values())

    def __len__(self) -> int:
        return len(self.channels)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.channels)

    @property
    def dt(self) -> float:
        """Sample period [s]."""
        return float(self.t[1] - self.t[0])

    @property
    def sample_rate(self) -> float:
        """Sample rate [Hz]."""
        return 1.0 / self.dt

    @property
    def pre_trigger(self) -> int:
        """Number of samples before time zero."""
        return int(np.count_nonzero(self.t < -0.5 * self.dt))

    def filtered(self, cfc, names=None) -> "Channels":
        """The channels (or those ``names``) filtered by the J211 CFC filter of class ``cfc``."""
        from .filters import cfc_filter

        names = self.names if names is None else tuple(names)
        out = dict(self.channels)
        for name in names:
            ch = self[name]
            out[name] = replace(ch, values=cfc_filter(ch.values, cfc, self.sample_rate))
        return replace(self, channels=out, cfc=cfc)

    def match(self, scene, mapping: dict | None = None) -> dict[str, Channel]:
        """The channels that belong to ``scene``: ``{role: Channel}``, roles as in the module
        docstring; ``mapping`` ({role: channel name}) overrides matching by name."""
        roles = scene_roles(scene)
        found = {}
        for role, kind in roles.items():
            ch = self._find(role)
            if ch is not None:
                found[role] = _checked_kind(ch, role, kind)
        for role, name in (mapping or {}).items():
            if role not in roles:
                raise SceneError(f"mapping.{role}", f"{role!r} is not a channel role of this scene; "
                                                    f"the roles are: {', '.join(roles)}")
            found[role] = _checked_kind(self[name], role, roles[role])
        return found

    def _find(self, role: str) -> Channel | None:
        key = _normal(role)
        for ch in self.channels.values():
            if _normal(ch.name) == key or (ch.label and _normal(ch.label) == key):
                return ch
        return None

    def to_frame(self):
        """A pandas DataFrame: ``time [s]`` and one ``name [unit]`` column per channel."""
        import pandas as pd

        data = {"time [s]": self.t}
        data.update({f"{c.name} [{c.unit}]": c.values for c in self.channels.values()})
        return pd.DataFrame(data)


def scene_roles(scene) -> dict[str, str]:
    """``{role: kind}`` of the channels a scene can be compared with."""
    from ..scene import Scene

    scene = Scene.load(scene)
    roles = {}
    for v in scene.vehicles:
        roles[f"accel_{v.name}"] = "acceleration"
        roles[f"velocity_{v.name}"] = "velocity"
    for k in range(len(scene.contacts)):
        suffix = "" if k == 0 else f"_{k + 1}"
        roles[f"force{suffix}"] = "force"
        roles[f"deformation{suffix}"] = "displacement"
    return roles


def _normal(name: str) -> str:
    return re.sub(r"[\s_]+", "_", name.strip().lower())


def _checked_kind(ch: Channel, role: str, kind: str) -> Channel:
    if ch.kind != kind:
        raise SceneError(ch.source or ch.name, f"channel {ch.name!r} ({ch.unit}) is {_a(ch.kind)}, "
                                               f"but {role!r} needs {_a(kind)}")
    return ch


def _a(kind: str) -> str:
    return f"an {kind}" if kind[0] in "aeiou" else f"a {kind}"


# ---------------------------------------------------------------------------------- units

def _pint_unit(unit: str) -> str:
    """A channel unit in pint's spelling: ``g`` (and ``G``, ``gn``) is standard gravity."""
    unit = unit.strip().replace("²", "^2").replace("**", "^")
    return re.sub(r"(?<![\w.])(g|G|gn)(?![\w])", "g_0", unit)


def _kind_of(unit: str, where: str) -> str:
    """The channel kind of ``unit``; SceneError at ``where`` if unknown or of another dimension."""
    for kind, unit_kind in KINDS.items():
        try:
            unit_factor(_pint_unit(unit), unit_kind, "SI", where)
            return kind
        except SceneError:
            continue
    raise SceneError(where, f'unknown or unsupported unit "{unit}": a channel is an acceleration '
                            f'("g", "m/s^2"), a force ("N", "kN", "lbf"), a displacement ("mm", "in") '
                            f'or a velocity ("m/s", "km/h", "mph")')


def _time_factor(unit: str, where: str) -> float:
    return unit_factor(unit, "time", "SI", where)


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
        t, chans = _read_isomme(path)
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
    t = _uniform_time(data[:, 0] * _time_factor(unit_of["time"], f"{where}, column {t_col + 1} ({header[t_col]!r})"),
                      [no for no, _ in rows], where, line, t_col)
    chans = {}
    for j, (name, col) in enumerate(picked.items(), 1):
        unit = unit_of[name]
        kind = _kind_of(unit, f"{where}, {line} {head_no}, column {col + 1} ({header[col]!r})")
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
    off = np.nonzero(np.abs(t - grid) > _STEP_TOLERANCE * dt)[0]
    if off.size:
        i = max(int(off[0]), 1)
        raise SceneError(where, f"{line} {lines[i]}, column {col + 1}: time step {t[i] - t[i - 1]:.6g} s differs "
                                f"from the mean sample interval {dt:.6g} s; the channels must have one "
                                "constant sample rate (resample the file)")
    return grid


# ---------------------------------------------------------------------------------- ISO-MME

class _Archive:
    """Members of an ISO-MME folder or zip file, found case-insensitively."""

    def __init__(self, path: Path):
        self.path = path
        if path.suffix.lower() == ".mme" and path.is_file():
            path = path.parent
            self.path = path
        if path.is_dir():
            self._names = {p.relative_to(path).as_posix(): p for p in path.rglob("*") if p.is_file()}
            self._zip = None
        else:
            try:
                self._zip = zipfile.ZipFile(path)
            except (OSError, zipfile.BadZipFile) as e:
                raise SceneError(str(path), f"cannot open {path} as a zip file: {e}") from None
            self._names = {n: n for n in self._zip.namelist() if not n.endswith("/")}

    def find(self, pattern: str) -> list[str]:
        rx = re.compile(pattern, re.IGNORECASE)
        return sorted(n for n in self._names if rx.fullmatch(n))

    def label(self, name: str) -> str:
        return f"{self.path}/{name}" if self._zip is None else f"{self.path}:{name}"

    def read(self, name: str) -> list[str]:
        raw = self._names[name].read_bytes() if self._zip is None else self._zip.read(name)
        try:
            return raw.decode("utf-8-sig").splitlines()
        except UnicodeDecodeError:
            return raw.decode("latin-1").splitlines()


_FIELD = re.compile(r"([^:]*[^:\s])\s*:(.*)")


def _header(lines) -> tuple[dict, int]:
    """``({field: (value, line)}, index of the first data line)``; a repeated field keeps the first."""
    fields = {}
    for i, text in enumerate(lines):
        if not text.strip():
            continue
        m = _FIELD.fullmatch(text.strip())
        if m is None:
            return fields, i
        fields.setdefault(m.group(1).strip(), (m.group(2).strip(), i + 1))
    return fields, len(lines)


def _field(fields, key, where, number=False):
    if key not in fields or fields[key][0].upper() in ("", "NOVALUE"):
        raise SceneError(where, f"the channel header has no {key!r} field")
    value, no = fields[key]
    if not number:
        return value, no
    try:
        return float(value), no
    except ValueError:
        raise SceneError(where, f"line {no}: {key!r} is {value!r}, not a number") from None


def _read_isomme(path: Path):
    archive = _Archive(path)
    mmes = archive.find(r"(.*/)?[^/]+\.mme")
    if len(mmes) != 1:
        raise SceneError(str(path), f"an ISO-MME data set holds exactly one .mme file; found "
                                    f"{len(mmes)}{': ' + ', '.join(mmes) if mmes else ''}")
    root = str(PurePosixPath(mmes[0]).parent)
    root = "" if root == "." else root + "/"
    stem = re.escape(PurePosixPath(mmes[0]).stem)
    chn = archive.find(rf"{re.escape(root)}channel/{stem}\.chn")
    if not chn:
        raise SceneError(archive.label(mmes[0]), f"no channel list Channel/{PurePosixPath(mmes[0]).stem}.chn "
                                                 "beside the .mme file")
    fields, _ = _header(archive.read(chn[0]))
    listed = sorted((m.group(1), v[0]) for k, v in fields.items()
                    if (m := re.fullmatch(r"Name of channel (\d+)", k)))
    if not listed:
        raise SceneError(archive.label(chn[0]), "lists no channel ('Name of channel 001 :...')")
    parsed = []
    for number, _ in listed:
        files = archive.find(rf"{re.escape(root)}channel/{stem}\.{number}")
        if not files:
            raise SceneError(archive.label(chn[0]), f"channel {number} is listed but its file "
                                                    f"Channel/{PurePosixPath(mmes[0]).stem}.{number} is missing")
        parsed.append(_read_isomme_channel(archive, files[0]))
    return _common_base(parsed)


def _read_isomme_channel(archive: _Archive, name: str):
    where = archive.label(name)
    lines = archive.read(name)
    fields, start = _header(lines)
    code, _ = _field(fields, "Channel code", where)
    reference = fields.get("Reference channel", ("implicit", 0))
    if reference[0].lower() == "explicit":
        raise SceneError(where, f"line {reference[1]}: channel {code} is timed by an explicit time channel, "
                                "which lsc does not read; give it 'Sampling interval' and 'Time of first sample' "
                                "(Reference channel :implicit)")
    unit, unit_line = _field(fields, "Unit", where)
    dt, dt_line = _field(fields, "Sampling interval", where, number=True)
    t0, _ = _field(fields, "Time of first sample", where, number=True)
    count, count_line = _field(fields, "Number of samples", where, number=True)
    label = fields.get("Name of the channel", ("", 0))[0]
    label = "" if label.upper() == "NOVALUE" else label
    if not dt > 0:
        raise SceneError(where, f"line {dt_line}: 'Sampling interval' must be a positive number of seconds")
    values = []
    for i in range(start, len(lines)):
        text = lines[i].strip()
        if not text:
            continue
        try:
            value = float(text)
        except ValueError:
            value = np.nan
        if not np.isfinite(value):
            raise SceneError(where, f"line {i + 1}, column 1 ({code}): {text!r} is not a finite number")
        values.append(value)
    if len(values) != int(count):
        raise SceneError(where, f"line {count_line}: 'Number of samples' is {int(count)}, but the file holds "
                                f"{len(values)} values")
    kind = _kind_of(unit, f"{where}, line {unit_line}")
    chan = Channel(code, np.array(values), unit, kind, where, label)
    return chan, t0, dt, dt_line


def _common_base(parsed):
    """One time base for channels that share a sample interval: their common time span."""
    first, t0_ref, dt, _ = parsed[0]
    for chan, t0, dt_i, dt_line in parsed[1:]:
        if abs(dt_i - dt) > 1e-6 * dt:
            raise SceneError(chan.source, f"line {dt_line}: sampling interval {dt_i:.6g} s differs from "
                                          f"{dt:.6g} s of {first.source}; the channels must have one sample rate")
    starts = [round((t0 - t0_ref) / dt) for _, t0, _, _ in parsed]
    for (chan, t0, _, _), k in zip(parsed, starts):
        if abs((t0 - t0_ref) / dt - k) > _STEP_TOLERANCE:
            raise SceneError(chan.source, f"time of first sample {t0:.6g} s is not on the sample grid of "
                                          f"{first.source} (interval {dt:.6g} s)")
    lo = max(starts)
    hi = min(k + p[0].values.size for k, p in zip(starts, parsed))
    if hi - lo < 3:
        raise SceneError(first.source, "the channels share fewer than 3 samples in time")
    chans = {}
    for (chan, *_), k in zip(parsed, starts):
        if chan.name in chans:
            raise SceneError(chan.source, f"channel code {chan.name} appears twice")
        chans[chan.name] = replace(chan, values=chan.values[lo - k:hi - k])
    return t0_ref + np.arange(lo, hi) * dt, chans


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
    files = _isomme_files(channels, test, comments, codes or {})
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


def _lines(pairs) -> str:
    return "".join(f"{k:<28}:{v}\n" for k, v in pairs)


def _isomme_files(channels: Channels, test: str, comments, codes) -> dict[str, str]:
    mme = [("Data format", "ISO-MME"), ("Version", "1.6"), ("Laboratory test ref. number", test),
           ("Name of the test", test), ("Number of test objects", 1)]
    mme += [("Comments", c) for c in comments]
    chn = [("Number of channels", len(channels))]
    files = {f"{test}.mme": _lines(mme)}
    for i, ch in enumerate(channels, 1):
        code = codes.get(ch.name, ch.name)
        chn.append((f"Name of channel {i:03d}", f"{code} / {ch.name}"))
        head = [("Channel code", code), ("Name of the channel", ch.name), ("Reference channel", "implicit"),
                ("Channel frequency class", channels.cfc if channels.cfc is not None else "NOVALUE"),
                ("Unit", ch.unit), ("Sampling interval", repr(channels.dt)),
                ("Time of first sample", repr(float(channels.t[0]))), ("Number of samples", ch.values.size)]
        buf = io.StringIO()
        np.savetxt(buf, ch.values, fmt="%.10g")
        files[f"Channel/{test}.{i:03d}"] = _lines(head) + buf.getvalue()
    files[f"Channel/{test}.chn"] = _lines(chn)
    return files
