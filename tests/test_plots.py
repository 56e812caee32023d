"""``lsc.plots``: each figure has the scene's units on its axes, the vehicles in its legend,
the events marked, and draws the result's own numbers."""

import subprocess
import sys

import numpy as np
import pytest

import lsc
from lsc import data

mpl = pytest.importorskip("matplotlib")
mpl.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from lsc import plots  # noqa: E402

SI_CHAIN = {
    "name": "three-car chain",
    "units": "SI",
    "vehicles": [{"name": "A", "mass": 1500, "speed": "16 km/h"},
                 {"name": "B", "mass": 1200, "speed": 0},
                 {"name": "C", "mass": 1400, "speed": 0}],
    "contacts": [
        {"loading": {"table": [[0, 0], [0.02, 5000], [0.08, 60000], [0.3, 120000]]},
         "unloading": {"restitution": 0.3}},
        {"loading": {"stiffness": 400000}, "unloading": {"restitution": 0.5}, "gap": 0.05},
    ],
}


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def us():
    return lsc.solve(data.load("default"))


@pytest.fixture(scope="module")
def si():
    return lsc.solve(SI_CHAIN)


def _legend(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def _vlines(ax):
    """x positions of the vertical event lines."""
    return sorted(float(np.asarray(l.get_xdata())[0]) for l in ax.get_lines()
                  if len(l.get_xdata()) == 2 and np.ptp(np.asarray(l.get_xdata(), float)) == 0
                  and np.ptp(np.asarray(l.get_ydata(), float)) == 1)


def test_import_lsc_does_not_import_matplotlib():
    code = "import sys, lsc, lsc.cli, lsc.data; sys.exit('matplotlib' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


@pytest.mark.parametrize("res, t, a", [("us", "s", "ft/s^2"), ("si", "s", "m/s^2")])
def test_acceleration(request, res, t, a):
    r = request.getfixturevalue(res)
    fig = plots.acceleration(r)
    assert isinstance(fig, mpl.figure.Figure)
    ax = fig.axes[0]
    assert ax.get_xlabel() == f"time [{t}]"
    assert ax.get_ylabel() == "acceleration [g]"
    right = [c for c in ax.child_axes if c.get_ylabel()]
    assert [c.get_ylabel() for c in right] == [f"acceleration [{a}]"]
    names = [veh.name for veh in r.scene.vehicles]
    assert set(names) <= set(_legend(ax))
    # the curves are the accelerations in g, and the events are marked at their times
    ydata = [l.get_ydata() for l in ax.get_lines() if l.get_label() in names]
    np.testing.assert_allclose(np.column_stack(ydata), r.a / r.scene.g)
    assert _vlines(ax) == pytest.approx(sorted(e.time for e in r.events))
    assert "max deformation" in _legend(ax) and "separation" in _legend(ax)


@pytest.mark.parametrize("res, unit", [("us", "ft/s"), ("si", "m/s")])
def test_velocity(request, res, unit):
    r = request.getfixturevalue(res)
    fig = plots.velocity(r)
    ax = fig.axes[0]
    assert ax.get_ylabel() == f"velocity [{unit}]" and ax.get_xlabel() == "time [s]"
    names = [veh.name for veh in r.scene.vehicles]
    assert set(names) <= set(_legend(ax))
    last = [l.get_ydata()[-1] for l in ax.get_lines() if l.get_label() in names]
    assert last == pytest.approx(list(r.v_final))


def test_ifd_loop_us(us):
    fig = plots.ifd_loop(us)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "deformation [ft]" and ax.get_ylabel() == "force [lbf]"
    assert {"bullet–target", "loading", "unloading", "max deformation"} <= set(_legend(ax))
    lines = [l for l in ax.get_lines() if len(l.get_xdata()) > 2]
    styles = {l.get_linestyle() for l in lines}
    assert styles == {"-", "--"}, "loading solid, unloading dashed"
    f = np.concatenate([np.asarray(l.get_ydata(), float) for l in lines])
    d = np.concatenate([np.asarray(l.get_xdata(), float) for l in lines])
    assert np.nanmax(f) == pytest.approx(us.peak_force[0])
    assert np.nanmax(d) == pytest.approx(us.max_deformation[0])
    # the loop closes at the permanent set
    marks = [(float(l.get_xdata()[0]), float(l.get_ydata()[0])) for l in ax.get_lines()
             if len(l.get_xdata()) == 1]
    assert (pytest.approx(us.max_deformation[0]), pytest.approx(us.peak_force[0])) in marks
    assert (pytest.approx(us.permanent_deformation[0]), pytest.approx(0.0, abs=1e-6)) in marks


def test_ifd_loop_chain_one_entry_per_contact(si):
    ax = plots.ifd_loop(si).axes[0]
    assert ax.get_xlabel() == "deformation [m]" and ax.get_ylabel() == "force [N]"
    legend = _legend(ax)
    assert "contact 0 (A–B)" in legend and "contact 1 (B–C)" in legend


def test_draws_on_given_axes(us):
    fig, (a1, a2, a3) = plt.subplots(1, 3)
    assert plots.acceleration(us, ax=a1) is fig
    assert plots.velocity(us, ax=a2) is fig
    assert plots.ifd_loop(us, ax=a3) is fig
    assert len(plt.get_fignums()) == 1


def test_save_all(us, tmp_path):
    before = plt.get_fignums()
    files = plots.save_all(us, tmp_path / "figs")
    assert [f.name for f in files] == ["acceleration.png", "velocity.png", "ifd.png"]
    for f in files:
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > 1000
    assert plt.get_fignums() == before, "save_all leaves no open pyplot figures"


def test_ifd_loop_e0_drops_at_max_deformation():
    """e = 0: no rebound, the unloading branch is the vertical drop at D_max."""
    r = lsc.solve(data.paper_scene("study1_restitution", 0.0))
    ax = plots.ifd_loop(r).axes[0]
    dashed = [l for l in ax.get_lines() if l.get_linestyle() == "--" and len(l.get_xdata())]
    assert len(dashed) == 1
    d, f = np.asarray(dashed[0].get_xdata(), float), np.asarray(dashed[0].get_ydata(), float)
    assert d == pytest.approx([r.max_deformation[0]] * 2)
    assert f == pytest.approx([r.peak_force[0], 0.0])
    assert r.permanent_deformation[0] == pytest.approx(r.max_deformation[0])


# ---------------------------------------------------------------------------- tornado
@pytest.fixture(scope="module")
def sens():
    """Sensitivities of a table scene by finite differences of the exact backend (no JAX)."""
    from lsc.analysis import sensitivity
    scene = {"name": "table", "units": "US",
             "vehicles": [{"name": "bullet", "weight": 4000, "speed": 6},
                          {"name": "target", "weight": 3000, "speed": 0}],
             "contacts": [{"loading": {"table": [[0, 0], [0.02, 400], [0.05, 3000], [0.3, 40000]]},
                           "unloading": {"restitution": 0.4}}]}
    return sensitivity(scene, metrics=("delta_v", "peak_acceleration_g", "duration"),
                       method="finite-difference")


def _bars(ax):
    return [p for p in ax.patches if isinstance(p, mpl.patches.Rectangle)]


@pytest.mark.parametrize("metric, index", [("delta_v", None), ("peak_acceleration_g", "bullet"),
                                           ("duration", None)])
def test_tornado_bars_are_the_elasticities_largest_on_top(sens, metric, index):
    fig = plots.tornado(sens, metric, index)
    ax = fig.axes[0]
    bars = sorted(_bars(ax), key=lambda p: p.get_y())       # bottom to top
    el = sens.elasticities[metric][sens._index(metric, index)]
    want = sorted(el, key=abs)                                # smallest at the bottom
    assert [b.get_width() for b in bars] == pytest.approx(want, rel=1e-12, abs=1e-15)
    assert all(b.get_x() == 0 for b in bars)
    order = sorted(range(len(el)), key=lambda j: abs(el[j]))
    labels = [t.get_text().split("\n")[0] for t in ax.get_yticklabels()]
    assert labels == [sens.labels[j] for j in order]
    # raising the parameter raises the metric: red; lowers it: blue
    for b, v in zip(bars, want):
        assert mpl.colors.to_hex(b.get_facecolor()) == mpl.colors.to_hex("C3" if v > 0 else "C0")
    who = "bullet" if index == "bullet" else ("target" if metric != "duration" else "")
    assert who in ax.get_title() and "elasticity" in ax.get_xlabel()


def test_tornado_swing_spans_the_first_order_range(sens, tmp_path):
    fig, ax = plt.subplots()
    assert plots.tornado(sens, "delta_v", swing=0.1, ax=ax) is fig
    M = sens.value("delta_v")
    d = sens.derivatives["delta_v"][1]
    spans = d * 0.1 * sens.reference
    bars = _bars(ax)
    assert len(bars) == 2 * len(sens.params)
    assert all(b.get_x() == pytest.approx(M) for b in bars)
    widths = sorted(abs(b.get_width()) for b in bars)
    assert widths == pytest.approx(sorted(np.repeat(np.abs(spans), 2)), rel=1e-12, abs=1e-15)
    # explicit swings in units; the others are left out
    path = plots.tornado(sens, "delta_v", swing={"vehicles.0.speed": "1 mph",
                                                 "contacts.0.unloading.restitution": 0.1},
                         file=tmp_path / "t.png")
    assert path.stat().st_size > 1000
    ax2 = plots.tornado(sens, "delta_v", swing={"vehicles.0.speed": "1 mph"}).axes[0]
    [up, down] = sorted(_bars(ax2), key=lambda b: b.get_width())
    assert up.get_width() == pytest.approx(-down.get_width())
    assert abs(up.get_width()) == pytest.approx(abs(d[sens.params.index("vehicles.0.speed")])
                                                * 5280 / 3600, rel=1e-12)


# ------------------------------------------------------------------ styles, legends, labels
EVERY_KIND = [*plots._EVENT_STYLE, "stable", "mode", "brake_stop", "contact+failure"]


def test_each_event_kind_has_its_own_style():
    from types import SimpleNamespace
    from matplotlib.figure import Figure
    from lsc.result import Event
    fake = SimpleNamespace(events=[Event(0.01 * j, kind, 0) for j, kind in enumerate(EVERY_KIND)])
    ax = Figure().add_subplot()
    plots._mark_events(ax, fake)
    lines = [l for l in ax.get_lines() if not l.get_label().startswith("_")]
    assert len(lines) == len(EVERY_KIND)  # one legend entry per kind
    looks = {(tuple(l._dash_pattern[1] or ()), l._dash_pattern[0],
              tuple(np.round(mpl.colors.to_rgba(l.get_color()), 6))) for l in lines}
    assert len(looks) == len(lines)  # no two kinds drawn alike
    assert len({l.get_label() for l in lines}) == len(lines)


def test_event_styles_on_a_real_run_are_distinct(si):
    fig = plots.velocity(si)
    ax = fig.axes[0]
    lines = [l for l in ax.get_lines() if not l.get_label().startswith("_")
             and l.get_label() not in [v.name for v in si.scene.vehicles]]
    assert {l.get_label() for l in lines} >= {"contact", "separation", "table breakpoint"}
    looks = {(tuple(l._dash_pattern[1] or ()), tuple(mpl.colors.to_rgba(l.get_color())))
             for l in lines}
    assert len(looks) == len(lines)


def _overlaps(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.mark.parametrize("draw", [plots.acceleration, plots.velocity, plots.ifd_loop])
def test_legend_covers_no_data_nor_labels(us, draw):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(7.0, 4.5), layout="constrained")
    draw(us, ax=fig.add_subplot())
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    ax = fig.axes[0]
    r = canvas.get_renderer()
    legend = ax.get_legend().get_window_extent(r)
    assert not _overlaps(legend, ax.get_window_extent(r))          # off the data
    assert not _overlaps(legend, ax.xaxis.get_tightbbox(r))       # and off the time axis
    assert legend.y0 >= 0 and fig.bbox.x0 <= legend.x0 and legend.x1 <= fig.bbox.x1  # on the page


def test_sweep_plot_axes_have_readable_names_and_units():
    s = lsc.sweep(data.load("default"), {"vehicles.0.speed": [4.0, 8.0],
                                          "contacts.0.unloading.restitution": [0.2, 0.4]},
                  grid=True)
    ax = plots.sweep_metric(s, "delta_v").axes[0]
    assert ax.get_xlabel() == "initial speed of bullet [ft/s]"
    assert ax.get_ylabel() == "ΔV of target [ft/s]"
    assert _legend(ax) == ["restitution of contact 0 (bullet–target) = 0.2",
                           "restitution of contact 0 (bullet–target) = 0.4"]
    ax = plots.sweep_metric(s, "peak_acceleration_g", index=0).axes[0]
    assert ax.get_ylabel() == "peak acceleration of bullet [g]"
    ax = plots.sweep_metric(s, "peak_force").axes[0]
    assert ax.get_ylabel() == "peak force of contact 0 (bullet–target) [lbf]"
    si = lsc.sweep(SI_CHAIN, {"contacts.1.gap": [0.03, 0.05]})
    assert plots.sweep_metric(si, "duration").axes[0].get_xlabel() == "gap of contact 1 (B–C) [m]"


# ------------------------------------------------------------------ work-precision diagrams
def _compare_script():
    import importlib.util
    from pathlib import Path
    file = Path(__file__).resolve().parents[1] / "scripts" / "compare_integrators.py"
    spec = importlib.util.spec_from_file_location("compare_integrators", file)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _wp_rows(scene, methods):
    rows = []
    for j, m in enumerate(methods):
        settings = ["-"] if m in ("closed-form", "exact") else \
            [f"dt={dt:g}" for dt in (1e-4, 1e-5)] if m == "reference" else \
            [f"rtol={rt:g}" for rt in (1e-6, 1e-10)]
        for k, setting in enumerate(settings):
            rows.append({"scene": scene, "method": m, "setting": setting,
                         "time_s": 1e-3 * (j + 1) * (k + 1), "error": 10.0 ** -(3 + 3 * k + j),
                         "compile_s": 3.5 + k if m.startswith("diffrax") else float("nan")})
    return rows


def test_work_precision_figures_keep_one_colour_per_method_and_label_their_points():
    ci = _compare_script()
    defaults = {"scipy DOP853": "rtol=1e-10", "diffrax Dopri8": "rtol=1e-10",
                "reference": "dt=1e-05"}
    everything = ["closed-form", "exact", "reference", "scipy RK45", "scipy DOP853",
                  "diffrax Dopri8"]
    fewer = ["reference", "scipy DOP853", "diffrax Dopri8"]  # no exact backends here
    rows = _wp_rows("a", everything) + _wp_rows("b", fewer)
    colours = []
    for name in ("a", "b"):
        ax = ci.figure(rows, name, name, defaults=defaults).axes[0]
        lines = {l.get_label(): l for l in ax.get_lines() if not l.get_label().startswith("_")}
        colours.append({m: (mpl.colors.to_hex(l.get_color()), l.get_marker())
                        for m, l in lines.items() if m in everything})
        texts = {t.get_text() for t in ax.texts}
        assert {"1e-6", "1e-10", "1e-4", "1e-5"} <= texts           # each point's tolerance
        assert "default setting of lsc.solve" in lines
        rings = {(float(l.get_xdata()[0]), float(l.get_ydata()[0])) for l in ax.get_lines()
                 if l.get_markerfacecolor() == "none" and l.get_markersize() > 11}
        assert rings == {(r["error"], r["time_s"]) for r in rows if r["scene"] == name
                         and defaults.get(r["method"]) == r["setting"]} and rings
        assert "Dopri8 up to 4.5 s" in ax.get_title()                # compile time, apart
        assert "compile excluded" in ax.get_ylabel()
    assert set(colours[1]) == set(fewer)
    assert all(colours[0][m] == colours[1][m] for m in fewer)        # same look in both panels
    assert len(set(colours[0].values())) == len(everything)          # and one per method
