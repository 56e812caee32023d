"""Output files written all at once or not at all, never over an earlier run's without leave.

A command (``lsc run``, ``lsc sweep``, ``lsc mc``, ...) or :func:`lsc.plots.save_all` hands
:func:`write_files` every file it produces as ``path → writer``, where ``writer(tmp)`` writes
the file's content to the path ``tmp``. Each writer writes to a hidden temporary name beside
its file (same folder, same suffix, so that matplotlib picks the format from it); only when
every one has succeeded are they moved into place with :func:`os.replace`. If one fails, the
temporary files (and the folders created for them) are removed and the earlier files are left
as they were.

A file that already exists is the result of an earlier run: :func:`write_files` refuses it
(:class:`OutputExistsError`) unless ``overwrite=True``. With ``overwrite`` the earlier files are
set aside before the new ones move in and put back if a move fails, and the ``replaces`` files
(the command's outputs that this run does not write, e.g. the figures of a run before
``--no-plots``) are removed, so that a folder never mixes two runs.
"""

from __future__ import annotations

import errno
import os
import secrets
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

__all__ = ["OutputExistsError", "OutputError", "refuse_existing", "write_files", "write_file"]

Writer = Callable[[Path], object]


class OutputExistsError(FileExistsError):
    """Output files of an earlier run are in the way (``paths``); nothing was written."""

    def __init__(self, paths: Iterable[Path]):
        self.paths = tuple(Path(p) for p in paths)
        names = ", ".join(str(p) for p in self.paths)
        super().__init__(f"{names} already exist{'s' if len(self.paths) == 1 else ''} (the "
                         f"results of an earlier run): pass overwrite=True to replace them")


class OutputError(OSError):
    """An output file could not be written (``filename``: the file, ``strerror``: why); none of
    the files of that call were written and the earlier ones are as they were."""


def refuse_existing(paths: Iterable[Path], overwrite: bool = False) -> None:
    """Raise :class:`OutputExistsError` naming those of ``paths`` that exist (unless
    ``overwrite``), or :class:`OutputError` for one that exists but is not a file."""
    existing = [Path(p) for p in paths if os.path.lexists(p)]
    for p in existing:
        if p.is_dir():
            raise OutputError(errno.EISDIR, "a folder is in the way of the output file", str(p))
    if existing and not overwrite:
        raise OutputExistsError(existing)


def write_files(writers: Mapping[Path, Writer], *, overwrite: bool = False,
                replaces: Iterable[Path] = ()) -> list[Path]:
    """Write every ``path → writer(tmp)`` of ``writers`` (creating their folders), all or none;
    returns the paths written. Refuses existing files of ``writers`` or ``replaces``
    (:class:`OutputExistsError`) unless ``overwrite``; then also removes the ``replaces`` files.
    An :class:`OSError` while writing is raised as :class:`OutputError` naming the file."""
    targets = [Path(p) for p in writers]
    stale = [Path(p) for p in replaces if Path(p) not in targets]
    refuse_existing(targets + stale, overwrite)
    batch = _Batch()
    try:
        for path, write in zip(targets, writers.values()):
            batch.write(path, write)
        batch.commit(stale)
    except BaseException:
        batch.roll_back()
        raise
    return targets


class _Batch:
    """The temporary files, created folders and set-aside earlier files of one
    :func:`write_files` call, with how to commit or undo them."""

    def __init__(self):
        self.folders: list[Path] = []      # created here, outermost first
        self.temporary: dict[Path, Path] = {}   # final path → temporary path
        self.set_aside: dict[Path, Path] = {}   # final path → the earlier file's hidden name
        self.moved: list[Path] = []        # final paths already holding the new file

    def write(self, path: Path, write: Writer) -> None:
        """Write one file to its temporary name (an OSError becomes :class:`OutputError`)."""
        try:
            self._make_folder(path.parent)
            tmp = _reserve(path, ".partial")
            self.temporary[path] = tmp
            write(tmp)
        except OutputError:
            raise
        except OSError as e:
            raise OutputError(e.errno, e.strerror or str(e), str(path)) from e

    def commit(self, stale: list[Path]) -> None:
        """Set the earlier files aside, move the new ones in, then drop the earlier ones."""
        try:
            for path in [*self.temporary, *stale]:
                if os.path.lexists(path):
                    self.set_aside[path] = _reserve(path, ".earlier")
                    os.replace(path, self.set_aside[path])
            for path, tmp in self.temporary.items():
                os.replace(tmp, path)
                self.moved.append(path)
        except OSError as e:
            raise OutputError(e.errno, e.strerror or str(e), str(e.filename or "")) from e
        for earlier in self.set_aside.values():
            _remove(earlier)
        self.set_aside.clear()

    def roll_back(self) -> None:
        """Remove what this call wrote and put the earlier files back."""
        for path in self.moved:
            _remove(path)
        for path, earlier in self.set_aside.items():
            os.replace(earlier, path)
        for tmp in self.temporary.values():
            _remove(tmp)
        for folder in reversed(self.folders):
            try:
                folder.rmdir()
            except OSError:
                break

    def _make_folder(self, folder: Path) -> None:
        missing = []
        while not folder.exists() and folder != folder.parent:
            missing.append(folder)
            folder = folder.parent
        for f in reversed(missing):
            f.mkdir()
            self.folders.append(f)


def _reserve(path: Path, tag: str) -> Path:
    """A new empty hidden file beside ``path`` with ``path``'s suffix (mode as for ``open``)."""
    while True:
        tmp = path.with_name(f".{path.stem}.{secrets.token_hex(4)}{tag}{path.suffix}")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return tmp
        except FileExistsError:
            continue


def _remove(path: Path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def write_file(path, write: Writer, *, overwrite: bool = False) -> Path:
    """Write one file with ``write(tmp)`` (:func:`write_files`): whole or not at all, and never
    over an existing file unless ``overwrite``; returns the path. What the Python API's
    ``to_csv``, ``to_json``, ``file=`` arguments use."""
    return write_files({Path(path): write}, overwrite=overwrite)[0]
