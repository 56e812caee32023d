"""Results as pandas DataFrames and xarray Datasets, with their units.

Plain functions behind :meth:`lsc.Result.to_dataframe`, :meth:`lsc.Result.summary_frame`,
:meth:`lsc.SweepResult.to_dataframe` and :meth:`lsc.SweepResult.to_xarray`. pandas is a
dependency of lsc; xarray comes with the ``frames`` extra (``pip install "lsc[frames]"``, which
also brings pyarrow for ``DataFrame.to_parquet``). Both are imported on first use, never by
``import lsc``.

Units: every DataFrame column name ends with its unit in parentheses (``"v[bullet] (ft/s)"``;
none for a dimensionless one), and ``df.attrs["units"]`` maps each column to its unit (pint
spelling, ``""`` for dimensionless, ``None`` where lsc does not know the unit of a swept scene
path). In a Dataset every variable and coordinate has ``attrs["units"]``.

Vehicles are labelled by name; a name that several vehicles share gets its index
(``"car #0"``, ``"car #1"``) so that no column hides another. Contacts are labelled by index
in series and metric columns (``"force[0] (lbf)"``, as in the CSV export) and by index and the
vehicles they join in the summary (``"0 (bullet-target)"``).
"""

from __future__ import annotations

import numpy as np

from .errors import SceneError
from .result import METRICS
from .sweep import warning_text

__all__ = ["result_frame", "summary_frame", "sweep_frame", "sweep_xarray", "vehicle_labels",
           "contact_labels"]

_SERIES = {"vehicle": ("x", "v", "a"), "contact": ("deformation", "force")}


# --------------------------------------------------------------------------- labels
def vehicle_labels(scene) -> list[str]:
    """One distinct label per vehicle: its name, with ``" #i"`` (its index) where names repeat."""
    names = [v.name for v in scene.vehicles]
    return [f"{n} #{i}" if names.count(n) > 1 else n for i, n in enumerate(names)]


def contact_labels(scene) -> list[str]:
    """One label per contact: its index and the vehicles it joins, ``"0 (bullet-target)"``."""
    v = vehicle_labels(scene)
    return [f"{k} ({v[k]}-{v[k + 1]})" for k in range(len(scene.contacts))]


def _with_unit(name: str, unit) -> str:
    """``"name (unit)"``; the bare name for a dimensionless (``""``) or unknown (None) unit."""
    return f"{name} ({unit})" if unit else name


def _item_columns(name: str, arr: np.ndarray, per: str, scene, unit) -> dict:
    """Columns of a quantity per vehicle or contact (last axis of ``arr``) or per scene:
    label → (values, unit)."""
    if per == "scene":
        return {_with_unit(name, unit): (arr, unit)}
    items = vehicle_labels(scene) if per == "vehicle" else range(arr.shape[-1])
    return {_with_unit(f"{name}[{item}]", unit): (arr[..., j], unit)
            for j, item in enumerate(items)}


def _frame(columns: dict, index, attrs: dict):
    """A DataFrame from ``label → (values, unit)``, the units in ``attrs["units"]``."""
    import pandas as pd

    df = pd.DataFrame({label: values for label, (values, _) in columns.items()}, index=index)
    df.attrs.update(attrs)
    df.attrs["units"] = {label: unit for label, (_, unit) in columns.items()}
    return df


def _attrs(scene, method: str) -> dict:
    return {"scene": scene.name, "unit_system": scene.units, "method": method}


# --------------------------------------------------------------------------- one result
def result_frame(result):
    """The time series of ``result`` as a :class:`pandas.DataFrame`.

    Index: time, named ``"t (s)"``. Columns: ``x, v, a`` per vehicle (``"x[bullet] (ft)"``),
    ``deformation, force`` per contact (``"force[0] (lbf)"``), in the scene's units;
    ``df.attrs``: ``units`` (column → unit, the index under its name), ``scene``,
    ``unit_system``, ``method``.
    """
    import pandas as pd

    scene, units = result.scene, result.units
    columns = {}
    for per, keys in _SERIES.items():
        for key in keys:
            columns.update(_item_columns(key, getattr(result, key), per, scene, units[key]))
    t_name = _with_unit("t", units["t"])
    df = _frame(columns, pd.Index(result.t, name=t_name), _attrs(scene, result.method))
    df.attrs["units"][t_name] = units["t"]
    return df


def summary_frame(result):
    """The metrics of ``result`` as a :class:`pandas.DataFrame`: one row per vehicle, per
    contact and one for the scene.

    Index: ``(part, label)`` with part ``"vehicle"``, ``"contact"`` or ``"scene"`` (labels as
    :func:`vehicle_labels`, :func:`contact_labels`, the scene's name). Columns: ``v0`` (the
    initial speed) and every metric of :data:`lsc.result.METRICS`, named with their unit
    (``"delta_v (ft/s)"``). A metric has values only in its own part's rows: the others are NaN
    (``df.loc["vehicle"]`` selects one part; ``df.attrs["part"]`` says each column's part).
    """
    import pandas as pd

    scene, units = result.scene, result.units
    labels = {"vehicle": vehicle_labels(scene), "contact": contact_labels(scene),
              "scene": [scene.name]}
    rows = [(part, label) for part, names in labels.items() for label in names]
    where = {part: [i for i, (p, _) in enumerate(rows) if p == part] for part in labels}
    columns, parts = {}, {}
    v0 = [("v0", scene.speeds, "vehicle", scene.unit("velocity"))]
    for name, values, per, unit in v0 + [(n, getattr(result, n), per, units[n])
                                         for n, (_, per) in METRICS.items()]:
        column = np.full(len(rows), np.nan)
        column[where[per]] = np.atleast_1d(values)
        label = _with_unit(name, unit)
        columns[label] = (column, unit)
        parts[label] = per
    index = pd.MultiIndex.from_tuples(rows, names=["part", "label"])
    df = _frame(columns, index, _attrs(scene, result.method))
    df.attrs["part"] = parts
    return df


# --------------------------------------------------------------------------- sweeps
def _path_unit(scene, path: str):
    """The unit of a swept scene path in the scene's system, None where lsc does not know it."""
    from .analysis._common import path_kind

    kind = path_kind(path)
    return None if kind is None else scene.unit(kind)


def sweep_frame(sweep_result):
    """A :class:`pandas.DataFrame` with one row per member of ``sweep_result`` (index
    ``"member"``, in the sweep's order, a grid flattened in C order).

    Columns: each swept path with its unit (``"vehicles.0.speed (ft/s)"``), every metric per
    vehicle / contact / scene as :meth:`lsc.SweepResult.columns` names them (vehicle labels as
    :func:`vehicle_labels`), then ``status`` (``"ok"`` or the member's error; its metrics are
    NaN). ``df.attrs``: ``units`` (column → unit; None for a swept path whose unit lsc does
    not know), ``paths`` (column → swept path), ``scene``, ``unit_system``, ``method``,
    ``shape`` (the grid shape).
    """
    import pandas as pd

    s = sweep_result
    columns, paths = {}, {}
    for path, values in s.params.items():
        unit = _path_unit(s.scene, path)
        label = _with_unit(path, unit)
        columns[label] = (values, unit)
        paths[label] = path
    for name, (_, per) in METRICS.items():
        if name in s.metrics:  # (a study may keep only some metrics)
            columns.update(_item_columns(name, s.metrics[name], per, s.scene, s.units[name]))
    columns["status"] = (np.asarray(s.status, dtype=str), None)
    columns["warnings"] = (np.asarray(warning_text(s.warnings), dtype=str), None)
    df = _frame(columns, pd.RangeIndex(len(s.status), name="member"), _attrs(s.scene, s.method))
    df.attrs["paths"] = paths
    df.attrs["shape"] = list(s.shape)
    return df


def _grid_axes(sweep_result) -> dict:
    """Swept path → its axis values (one per grid index); SceneError for a non-grid sweep."""
    s = sweep_result
    shape, paths = tuple(s.shape), list(s.params)
    if len(shape) != len(paths):
        raise SceneError("grid", f"to_xarray needs a grid sweep (lsc.sweep(..., grid=True)); this "
                                 f"sweep sets {len(paths)} paths together member by member "
                                 f"({', '.join(paths)}: {int(np.prod(shape))} members): use "
                                 "to_dataframe() for it")
    axes = {}
    for d, path in enumerate(paths):
        values = np.asarray(s.params[path], float).reshape(shape)
        axis = np.moveaxis(values, d, 0).reshape(shape[d], -1)
        if not np.array_equal(axis, np.repeat(axis[:, :1], axis.shape[1], axis=1), equal_nan=True):
            raise SceneError("grid", f"the values of {path} do not form an axis of the sweep's "
                                     f"grid {shape}: use to_dataframe() for this sweep")
        axes[path] = axis[:, 0]
    return axes


def _xarray():
    """The xarray module, or an ImportError that says how to install it."""
    try:
        import xarray
    except ImportError as e:
        raise ImportError('to_xarray needs xarray: pip install "lsc[frames]" (or xarray)') from e
    return xarray


def sweep_xarray(sweep_result):
    """A grid sweep as an :class:`xarray.Dataset` (needs the ``frames`` extra).

    Dimensions: one per swept path, named by the path, in the order given to
    :func:`lsc.sweep` (coordinates: the axis values, ``attrs["units"]``), plus ``vehicle`` and
    ``contact`` (coordinates: :func:`vehicle_labels`, contact indices). Variables: every metric
    (``attrs["units"]``; NaN for a member that failed) and ``status``. A plain (non-grid) sweep
    of several paths has no grid: it raises :class:`lsc.SceneError` (use :func:`sweep_frame`).
    """
    s = sweep_result
    axes = _grid_axes(s)
    xr = _xarray()
    dims, shape = list(axes), tuple(s.shape)
    coords = {}
    for path, values in axes.items():
        unit = _path_unit(s.scene, path)  # None: lsc does not know it, the attribute is left out
        coords[path] = (path, values, {} if unit is None else {"units": unit})
    coords["vehicle"] = ("vehicle", vehicle_labels(s.scene))
    coords["contact"] = ("contact", np.arange(len(s.scene.contacts)))
    data = {}
    for name, (_, per) in METRICS.items():
        arr = np.asarray(s.metrics[name])
        extra = [] if per == "scene" else [per]
        data[name] = (dims + extra, arr.reshape(shape + arr.shape[1:]), {"units": s.units[name]})
    data["status"] = (dims, np.asarray(s.status, dtype=str).reshape(shape))
    data["warnings"] = (dims, np.asarray(warning_text(s.warnings), dtype=str).reshape(shape))
    return xr.Dataset(data, coords=coords, attrs=_attrs(s.scene, s.method))
