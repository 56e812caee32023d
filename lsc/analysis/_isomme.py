"""ISO-MME 1.6 data sets (ISO/TS 13499): read (a folder, ``.zip`` or ``.mme``) and the files
written, for :func:`lsc.analysis.channels.read_channels` and
:func:`~lsc.analysis.channels.write_isomme`.
"""

from __future__ import annotations

import io
import re
import zipfile
from dataclasses import replace
from pathlib import Path, PurePosixPath

import numpy as np

from ..errors import SceneError
from ._channel import STEP_TOLERANCE, Channel, Channels, kind_of

__all__ = ["read_isomme", "isomme_files"]


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


def read_isomme(path: Path):
    """``(t [s], {code: Channel})`` of the ISO-MME data set at ``path``; SceneError naming the
    file and line of anything it cannot read."""
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
    kind = kind_of(unit, f"{where}, line {unit_line}")
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
        if abs((t0 - t0_ref) / dt - k) > STEP_TOLERANCE:
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


def _lines(pairs) -> str:
    return "".join(f"{k:<28}:{v}\n" for k, v in pairs)


def isomme_files(channels: Channels, test: str, comments, codes) -> dict[str, str]:
    """``{member path: text}`` of the ISO-MME data set holding ``channels``."""
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
