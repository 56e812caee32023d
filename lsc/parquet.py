"""A study written to Parquet as it is solved (:class:`ParquetSink`), and read back
(:class:`SweepFile`).

The file has the columns of :func:`lsc.frames.sweep_frame` (``member``, each swept path with its
unit, the kept metrics per vehicle / contact / scene, ``status``), one row group per chunk, in
member order; ``pandas.read_parquet`` reads it whole with the frame's ``attrs``. Needs pyarrow
(the ``[frames]`` extra).
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .result import METRICS
from .scene import Scene

__all__ = ["ParquetSink", "SweepFile", "require_pyarrow"]

#: Distinct failure messages counted one by one while a study is written; more are counted
#: together (a summary lists the most frequent few).
MAX_REASONS = 1000


def require_pyarrow(field: str) -> None:
    """``SceneError`` on ``field`` where pyarrow (the ``[frames]`` extra) is missing."""
    from .errors import SceneError

    try:
        import pyarrow  # noqa: F401
    except ModuleNotFoundError:
        raise SceneError(field, "writing Parquet needs pyarrow: pip install 'lsc[frames]'") \
            from None


class ParquetSink:
    """The consumer of :func:`lsc.chunks.run_tasks` that appends each chunk to the Parquet file
    ``file`` as one row group, counting members, failures and their reasons."""

    def __init__(self, file, scene: Scene, method: str, shape: tuple):
        self.file, self.scene, self.method, self.shape = Path(file), scene, method, tuple(shape)
        self.writer = self.schema = None
        self.members = self.warned = 0
        self.reasons: Counter = Counter()

    def __call__(self, start: int, task, result: dict) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = self._table(start, task, result)
        if self.writer is None:
            self.schema = table.schema
            self.writer = pq.ParquetWriter(self.file, self.schema)
        self.writer.write_table(pa.Table.from_batches(table.to_batches(), self.schema),
                                row_group_size=max(1, table.num_rows))
        self.members += table.num_rows
        self.warned += sum(1 for w in result["warnings"] if w)
        self._count(result["status"])

    def _table(self, start: int, task, result: dict):
        import pandas as pd
        import pyarrow as pa
        from .frames import sweep_frame
        from .sweep import SweepResult

        m = len(task)
        chunk = SweepResult(self.scene, task.values, result["metrics"], result["status"],
                            self.method, (m,), warnings=result["warnings"])
        df = sweep_frame(chunk)
        df.attrs["shape"] = list(self.shape)
        df.index = pd.RangeIndex(start, start + m, name="member")
        table = pa.Table.from_pandas(df, preserve_index=True)
        meta = {**(table.schema.metadata or {}), b"PANDAS_ATTRS": json.dumps(df.attrs).encode()}
        return table.replace_schema_metadata(meta)

    def _count(self, status: np.ndarray) -> None:
        for reason, count in zip(*np.unique(status[status != "ok"].astype(str),
                                            return_counts=True)):
            key = reason if (reason in self.reasons or len(self.reasons) < MAX_REASONS) \
                else "(other reasons)"
            self.reasons[key] += int(count)

    def close(self) -> None:
        """Finish the file (its footer); a study of no chunk writes none."""
        if self.writer is not None:
            self.writer.close()


@dataclass(eq=False)
class SweepFile:
    """A study written to Parquet (``path``), read back a column at a time.

    ``paths``: the swept paths; ``names``: the metrics kept; ``method``, ``shape``, ``stats``
    (wall time [s], members, failed) and ``reasons`` (failure message → count) as the study
    ran. ``metrics`` maps each kept metric to its values, read from the file on access ((n,),
    (n, N) or (n, K)); ``params`` (swept path → values [scene units]), ``status`` and ``ok``
    likewise: the names of :class:`lsc.SweepResult`.
    """

    path: Path
    scene: Scene
    paths: tuple
    names: tuple
    method: str
    shape: tuple
    stats: dict = field(default_factory=dict)
    reasons: dict = field(default_factory=dict)

    @property
    def units(self) -> dict[str, str]:
        """Unit of every metric (pint spelling)."""
        return {name: self.scene.unit(kind) for name, (kind, _) in METRICS.items()}

    def labels(self, name: str) -> list[str]:
        """The file's columns of metric ``name`` (one per vehicle / contact, or one)."""
        from .frames import _item_columns

        kind, per = METRICS[name]
        width = {"vehicle": self.scene.n_vehicles, "contact": len(self.scene.contacts)}
        empty = np.empty((0, width[per])) if per in width else np.empty(0)
        return list(_item_columns(name, empty, per, self.scene, self.scene.unit(kind)))

    def param_label(self, path: str) -> str:
        """The file's column of swept path ``path``."""
        from .frames import _path_unit, _with_unit

        return _with_unit(path, _path_unit(self.scene, path))

    def column(self, label: str) -> np.ndarray:
        """One column of the file as an array."""
        import pyarrow.parquet as pq

        return pq.read_table(self.path, columns=[label]).column(0).to_numpy()

    def metric(self, name: str) -> np.ndarray:
        """Metric ``name`` of every member: (n,), (n, N) or (n, K)."""
        cols = [self.column(label) for label in self.labels(name)]
        return cols[0] if METRICS[name][1] == "scene" else np.column_stack(cols)

    @property
    def metrics(self) -> Mapping:
        return _Columns(self.names, self.metric)

    @property
    def params(self) -> Mapping:
        """Swept path → values of every member [scene units], read on access."""
        return _Columns(self.paths, lambda p: self.column(self.param_label(p)))

    @property
    def status(self) -> np.ndarray:
        return self.column("status").astype(object)

    @property
    def warnings(self) -> np.ndarray:
        """Each member's warnings, a tuple (empty where none), as :class:`lsc.SweepResult`'s."""
        from .solvers.base import warning_array

        return warning_array(tuple(text.split("\n")) if text else ()
                             for text in self.column("warnings"))

    @property
    def ok(self) -> np.ndarray:
        """Mask of the members that were solved (compared in Arrow: no string per member)."""
        import pyarrow.compute as pc
        import pyarrow.parquet as pq

        status = pq.read_table(self.path, columns=["status"]).column(0)
        return pc.equal(status, "ok").to_numpy(zero_copy_only=False)

    def percentiles(self, name: str, q) -> np.ndarray:
        """Percentiles ``q`` [%] of metric ``name`` over the solved members, exact (NumPy's
        linear rule, as :func:`numpy.percentile`), computed a column at a time (memory: about
        two columns, 16 bytes per member): ``(len(q),)``, ``(len(q), N)`` or ``(len(q), K)``;
        NaN where no member was solved."""
        ok = self.ok
        out = []
        for label in self.labels(name):
            values = self.column(label)[ok]       # a copy: the file's buffer is freed here
            out.append(np.percentile(values, q, overwrite_input=True) if values.size
                       else np.full(len(q), np.nan))
        return out[0] if METRICS[name][1] == "scene" else np.column_stack(out)

    def to_dataframe(self):
        """The whole file as a pandas DataFrame (index ``member``)."""
        import pandas as pd

        return pd.read_parquet(self.path)


class _Columns(Mapping):
    """A read-only mapping whose values are read (by ``read(key)``) when asked for."""

    def __init__(self, keys, read):
        self._keys, self._read = tuple(keys), read

    def __getitem__(self, key):
        if key not in self._keys:
            raise KeyError(key)
        return self._read(key)

    def __iter__(self):
        return iter(self._keys)

    def __len__(self):
        return len(self._keys)
