"""Results as pandas DataFrames and xarray Datasets (lsc.frames): every column is the Result's
own array, every unit is the Result's own, a grid sweep's Dataset is the sweep reshaped and each
of its cells is the single solve of that member."""

import subprocess
import sys

import numpy as np
import pytest

import lsc
from lsc import data
from lsc.frames import result_frame, summary_frame, sweep_frame, sweep_xarray
from lsc.result import METRICS

pd = pytest.importorskip("pandas")


@pytest.fixture(scope="module")
def paper():
    return lsc.solve(data.load("default"))


def twins(name="car"):
    """Three vehicles, two sharing a name (the loader accepts repeated names)."""
    return {"units": "US", "g": "32.2 ft/s^2",
            "vehicles": [{"name": name, "weight": 3500, "speed": 10},
                         {"name": name, "weight": 3000, "speed": 0},
                         {"name": "front", "weight": 2500, "speed": 0}],
            "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}},
                         {"loading": {"stiffness": 30000}, "unloading": {"restitution": 0.3},
                          "gap": 0.1}]}


# --------------------------------------------------------------------------- time series
def test_result_frame_columns_are_the_results_series_with_their_units(paper):
    df = result_frame(paper)
    u = paper.units
    assert df.shape == (paper.t.size, 3 * 2 + 2 * 1)
    assert df.index.name == "t (s)"
    np.testing.assert_array_equal(df.index.to_numpy(), paper.t)
    for key in ("x", "v", "a"):
        for i, name in enumerate(("bullet", "target")):
            col = f"{key}[{name}] ({u[key]})"
            np.testing.assert_array_equal(df[col].to_numpy(), getattr(paper, key)[:, i])
            assert df.attrs["units"][col] == u[key]
    np.testing.assert_array_equal(df["force[0] (lbf)"].to_numpy(), paper.force[:, 0])
    np.testing.assert_array_equal(df["deformation[0] (ft)"].to_numpy(), paper.deformation[:, 0])
    assert df.attrs["units"]["t (s)"] == "s"
    assert (df.attrs["unit_system"], df.attrs["method"]) == ("US", paper.method)


def test_result_frame_keeps_every_vehicle_when_names_repeat():
    r = lsc.solve(twins())
    df = result_frame(r)
    assert df.shape[1] == 3 * 3 + 2 * 2
    np.testing.assert_array_equal(df["v[car #0] (ft/s)"].to_numpy(), r.v[:, 0])
    np.testing.assert_array_equal(df["v[car #1] (ft/s)"].to_numpy(), r.v[:, 1])
    np.testing.assert_array_equal(df["v[front] (ft/s)"].to_numpy(), r.v[:, 2])


def test_result_frame_in_si_units_names_si_units():
    r = lsc.solve({"vehicles": [{"mass": 1500, "speed": 3}, {"mass": 1200, "speed": 0}],
                   "contacts": [{"loading": {"stiffness": 4e5},
                                 "unloading": {"restitution": 0.3}}]})
    df = result_frame(r)
    assert "a[vehicle 1] (m/s^2)" in df.columns and "force[0] (N)" in df.columns
    assert df.attrs["units"]["x[vehicle 2] (m)"] == "m"


# --------------------------------------------------------------------------- metrics
def test_summary_frame_holds_every_metric_in_its_parts_rows(paper):
    df = summary_frame(paper)
    u = paper.units
    assert list(df.index) == [("vehicle", "bullet"), ("vehicle", "target"),
                              ("contact", "0 (bullet-target)"),
                              ("scene", paper.scene.name)]
    rows = {"vehicle": slice(0, 2), "contact": slice(2, 3), "scene": slice(3, 4)}
    for name, (_, per) in METRICS.items():
        col = f"{name} ({u[name]})" if u[name] else name
        assert df.attrs["units"][col] == u[name] and df.attrs["part"][col] == per
        values = df[col].to_numpy()
        np.testing.assert_array_equal(values[rows[per]], np.atleast_1d(getattr(paper, name)))
        others = np.delete(values, np.arange(4)[rows[per]])
        assert np.all(np.isnan(others)), name
    np.testing.assert_array_equal(df.loc["vehicle", "v0 (ft/s)"].to_numpy(), [10.0, 0.0])
    # the paper's closed form: ΔV = ∓(1+e) v0 / 2 for equal masses
    assert df.loc[("vehicle", "target"), "delta_v (ft/s)"] == pytest.approx(7.0, rel=1e-12)


# --------------------------------------------------------------------------- sweeps
@pytest.fixture(scope="module")
def grid():
    speeds, es = [4.0, 5.0, 6.0, -1.0], [0.2, 0.8]
    return lsc.sweep(data.load("table3"), {"vehicles.0.speed": speeds,
                                           "contacts.0.unloading.restitution": es}, grid=True)


def test_sweep_frame_one_row_per_member_with_paths_metrics_and_status(grid):
    df = sweep_frame(grid)
    n = len(grid.status)
    assert df.shape[0] == n == 8 and df.index.name == "member"
    np.testing.assert_array_equal(df["vehicles.0.speed (ft/s)"].to_numpy(),
                                  grid.params["vehicles.0.speed"])
    np.testing.assert_array_equal(df["contacts.0.unloading.restitution"].to_numpy(),
                                  grid.params["contacts.0.unloading.restitution"])
    assert df.attrs["units"]["vehicles.0.speed (ft/s)"] == "ft/s"
    assert df.attrs["paths"]["vehicles.0.speed (ft/s)"] == "vehicles.0.speed"
    np.testing.assert_array_equal(df["delta_v[target] (ft/s)"].to_numpy(), grid.delta_v[:, 1])
    np.testing.assert_array_equal(df["peak_force[0] (lbf)"].to_numpy(), grid.peak_force[:, 0])
    np.testing.assert_array_equal(df["duration (s)"].to_numpy(), grid.duration)
    assert list(df["status"]) == list(grid.status)
    bad = df["status"] != "ok"
    assert bad.sum() == 2 and df.loc[bad, "peak_force[0] (lbf)"].isna().all()
    assert df.attrs["shape"] == [4, 2]


def test_sweep_frame_writes_and_reads_parquet(grid, tmp_path):
    pytest.importorskip("pyarrow")
    df = sweep_frame(grid)
    df.to_parquet(tmp_path / "s.parquet")
    back = pd.read_parquet(tmp_path / "s.parquet")
    pd.testing.assert_frame_equal(back, df, check_dtype=False)


def test_grid_sweep_as_xarray_is_the_sweep_reshaped_with_units(grid):
    pytest.importorskip("xarray")
    ds = sweep_xarray(grid)
    assert dict(ds.sizes) == {"vehicles.0.speed": 4, "contacts.0.unloading.restitution": 2,
                              "vehicle": 2, "contact": 1}
    np.testing.assert_array_equal(ds["vehicles.0.speed"].values, [4.0, 5.0, 6.0, -1.0])
    np.testing.assert_array_equal(ds["contacts.0.unloading.restitution"].values, [0.2, 0.8])
    assert ds["vehicles.0.speed"].attrs["units"] == "ft/s"
    assert ds["contacts.0.unloading.restitution"].attrs["units"] == ""
    assert list(ds["vehicle"].values) == ["bullet", "target"]
    for name, (_, per) in METRICS.items():
        arr = grid.metrics[name]
        np.testing.assert_array_equal(ds[name].values, arr.reshape((4, 2) + arr.shape[1:]))
        assert ds[name].attrs["units"] == grid.units[name]
    assert ds["status"].values.tolist() == np.asarray(grid.status).reshape(4, 2).tolist()


def test_xarray_cell_is_the_single_solve_of_that_member(grid):
    pytest.importorskip("xarray")
    ds = sweep_xarray(grid)
    cell = ds.sel({"vehicles.0.speed": 5.0, "contacts.0.unloading.restitution": 0.8})
    r = lsc.solve(data.load("table3").with_values({"contacts.0.unloading.restitution": 0.8}))
    assert float(cell["peak_force"].sel(contact=0)) == pytest.approx(r.peak_force[0], rel=1e-12)
    assert float(cell["delta_v"].sel(vehicle="target")) == pytest.approx(r.delta_v[1], rel=1e-12)


def test_plain_sweep_of_two_paths_is_refused_by_to_xarray():
    s = lsc.sweep(data.load("default"), {"vehicles.0.speed": [5, 10, 15],
                                         "contacts.0.unloading.restitution": [0.2, 0.4, 0.6]})
    with pytest.raises(lsc.SceneError) as err:
        sweep_xarray(s)
    assert err.value.path == "grid"
    assert str(err.value) == (
        "grid: to_xarray needs a grid sweep (lsc.sweep(..., grid=True)); this sweep sets 2 "
        "paths together member by member (vehicles.0.speed, contacts.0.unloading.restitution: "
        "3 members): use to_dataframe() for it")


def test_plain_sweep_of_one_path_is_its_own_axis():
    pytest.importorskip("xarray")
    s = lsc.sweep(data.load("default"), {"vehicles.0.speed": [5, 10, 15]})
    ds = sweep_xarray(s)
    np.testing.assert_array_equal(ds["delta_v"].sel(vehicle="bullet").values, s.delta_v[:, 0])
    # closed form, equal masses, e = 0.4: ΔV1 = -(1 + e) v0 / 2
    np.testing.assert_allclose(ds["delta_v"].sel(vehicle="bullet").values,
                               -0.7 * np.array([5, 10, 15]), rtol=1e-12)


def test_importing_lsc_frames_and_html_loads_neither_pandas_nor_xarray():
    code = ("import sys, lsc, lsc.frames, lsc.html; "
            "print(' '.join(m for m in ('pandas', 'xarray', 'pyarrow') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_to_xarray_without_xarray_says_how_to_install_it(grid, monkeypatch):
    monkeypatch.setitem(sys.modules, "xarray", None)  # as if it were not installed
    with pytest.raises(ImportError, match=r'to_xarray needs xarray: pip install "lsc\[frames\]"'):
        sweep_xarray(grid)


def test_a_swept_path_whose_unit_lsc_does_not_know_gets_none_not_dimensionless():
    kelvin = {"units": "US", "g": "32.2 ft/s^2",
              "vehicles": [{"weight": 3500, "speed": 10}, {"weight": 3500, "speed": 0}],
              "contacts": [{"law": "kelvin", "stiffness": 24000, "damping": 100}]}
    s = lsc.sweep(kelvin, {"contacts.0.damping": [50.0, 100.0]})
    df = sweep_frame(s)
    assert "contacts.0.damping" in df.columns and df.attrs["units"]["contacts.0.damping"] is None
    np.testing.assert_array_equal(df["peak_force[0] (lbf)"].to_numpy(), s.peak_force[:, 0])
    pytest.importorskip("xarray")
    assert "units" not in sweep_xarray(s)["contacts.0.damping"].attrs


def test_result_methods_are_the_frames_and_html_functions(paper):
    """``Result.to_dataframe``, ``summary_frame`` and ``_repr_html_`` (Jupyter) are the
    functions of lsc.frames and lsc.html."""
    from lsc.html import result_html
    assert paper.to_dataframe().equals(result_frame(paper))
    assert paper.summary_frame().equals(summary_frame(paper))
    assert paper._repr_html_() == result_html(paper)
