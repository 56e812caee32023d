"""compare(result, channels): a simulation against its own channels rates 1 everywhere; against a
test made with another restitution, the differences are those of the closed form."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import lsc
import lsc.data
from lsc.analysis import compare
from lsc.analysis.channels import Channel, Channels

RATE = 10_000.0


def channels_of(result, *, names=("accel_bullet", "accel_target"), t_end=0.15) -> Channels:
    """Accelerations of ``result`` sampled at 10 kHz from 10 ms before contact, in ft/s^2."""
    t = np.arange(-0.01 * RATE, t_end * RATE + 1) / RATE
    chans = {n: Channel(n, np.interp(t, result.t, result.a[:, i], left=0.0, right=0.0), "ft/s^2",
                        "acceleration", "test") for i, n in enumerate(names)}
    return Channels(t, chans, "test")


def closed_form(e, scene):
    m1, m2 = (v.mass for v in scene.vehicles)
    mu = m1 * m2 / (m1 + m2)
    omega = math.sqrt(24000.0 / mu)
    return (1 + e) * m1 * 10.0 / (m1 + m2), math.pi / (2 * omega) * (1 + e)


@pytest.fixture(scope="module")
def scene():
    return lsc.data.load("default")


@pytest.fixture(scope="module")
def result(scene):
    return lsc.solve(scene)


def test_a_simulation_against_its_own_channels_rates_one(result):
    c = compare(result, channels_of(result))
    assert set(c.iso18571) == {"accel_bullet", "accel_target"}
    for rating in c.iso18571.values():
        assert (rating.corridor, rating.phase, rating.magnitude, rating.slope, rating.total) == (1, 1, 1, 1, 1)
    for v in c.vehicles:
        assert v.metrics["peak_acceleration"][2] == 0.0 and v.metrics["pulse_duration"][2] == 0.0
        assert abs(v.metrics["delta_v"][2]) < 1e-3                        # trapezoid vs exact velocity
    target = c.vehicles[1]   # the closed form's (1 + e) v0 / 2, uniform motion after separation
    assert target.metrics["delta_v"][1] == pytest.approx(7.0, rel=1e-12)
    assert target.t[-1] == pytest.approx(0.15) and c.notes == ()


def test_against_a_test_with_another_restitution(scene, result):
    test = lsc.solve(scene.with_values({"contacts.0.unloading.restitution": 0.3}))
    c = compare(result, channels_of(test), pulse_threshold=1e-9)
    dv_sim, pulse_sim = closed_form(0.4, scene)
    dv_test, pulse_test = closed_form(0.3, scene)
    target = {v.name: v for v in c.vehicles}["target"]
    meas, sim, diff = target.metrics["delta_v"]
    assert meas == pytest.approx(dv_test, abs=1e-3) and sim == pytest.approx(dv_sim, rel=1e-12)
    assert diff == pytest.approx(dv_sim - dv_test, abs=1e-3)
    assert target.metrics["peak_acceleration"][2] == pytest.approx(0.0, abs=1e-4)   # same loading branch (of 105)
    assert target.metrics["pulse_duration"][2] == pytest.approx(pulse_sim - pulse_test, abs=2.5 / RATE)
    for rating in c.iso18571.values():
        assert 0 < rating.total < 1 and rating.magnitude < 1 and rating.corridor < 1


def test_measured_metrics_do_not_depend_on_the_simulation(scene, result):
    """The interval runs to the end of the record, not to the end of the simulated crash: a shorter
    simulated pulse leaves the measured ΔV and pulse as they are."""
    test = channels_of(result)
    shorter = lsc.solve(scene.with_values({"contacts.0.unloading.restitution": 0.1}))
    for v, w in zip(compare(result, test).vehicles, compare(shorter, test).vehicles):
        assert v.metrics["delta_v"][0] == w.metrics["delta_v"][0]
        assert v.metrics["pulse_duration"][0] == w.metrics["pulse_duration"][0]


def test_braked_scene_ends_the_interval_at_the_simulation_end(scene):
    braked = lsc.solve(scene.with_values({"vehicles.1.brake": {"mu": 0.7, "mu_static": 0.8}}))
    c = compare(braked, channels_of(braked, t_end=braked.t[-1] + 0.05))
    assert c.vehicles[0].t[-1] <= braked.t[-1] and c.iso18571["accel_target"].total == 1
    assert c.notes and "the scene has braking" in c.notes[0]


def test_time_zero_is_first_contact_in_a_scene_with_a_gap():
    """With a gap the simulation starts before contact: its first contact is aligned with the
    test's time zero."""
    gap = lsc.solve({"units": "SI", "vehicles": [{"name": "bullet", "mass": 1000, "speed": 3},
                                                 {"name": "target", "mass": 1200, "speed": 0}],
                     "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 0.5}, "gap": 0.3}]})
    touch = next(e.time for e in gap.events if e.kind == "contact")
    assert touch == pytest.approx(0.1)
    t = np.arange(-100, 2001) / RATE
    chans = {n: Channel(n, np.interp(t + touch, gap.t, gap.a[:, i], right=0.0), "m/s^2", "acceleration")
             for i, n in enumerate(("accel_bullet", "accel_target"))}
    c = compare(gap, Channels(t, chans, "gap test"))
    assert all(r.total == pytest.approx(1, abs=1e-12) and r.shift == 0 for r in c.iso18571.values())
    assert c.vehicles[1].metrics["delta_v"][1] == pytest.approx(1.5 * 1000 * 3 / 2200, rel=1e-12)


def test_velocity_channel_is_rated_as_delta_v(result):
    t = np.arange(0, 1501) / RATE
    chans = {"velocity_target": Channel("velocity_target", np.interp(t, result.t, result.v[:, 1]), "ft/s", "velocity")}
    c = compare(result, Channels(t, chans, "v test"))
    assert list(c.iso18571) == ["velocity_target"] and c.iso18571["velocity_target"].total == 1
    assert c.vehicles[0].metrics["delta_v"][2] == pytest.approx(0.0, abs=1e-12)


def test_mapping_window_and_errors(result):
    swapped = channels_of(result, names=("A2", "A1"))          # A1 is the target's, under another name
    c = compare(result, swapped, mapping={"accel_target": "A1"})
    assert [v.name for v in c.vehicles] == ["target"] and c.iso18571["accel_target"].total == 1
    with pytest.raises(lsc.SceneError) as e:
        compare(result, swapped)
    assert str(e.value) == ("test: no channel matches a vehicle of the scene: name them accel_bullet, accel_target "
                            "(or velocity_<vehicle>) or pass mapping={role: channel}; the channels are: A2, A1")
    with pytest.raises(lsc.SceneError, match=r"window: the window \(0, 0.5\) s must lie inside both records, which overlap over \(0, 0.15\) s"):
        compare(result, channels_of(result), window=(0, 0.5))
    with pytest.raises(lsc.SceneError, match=r"pulse_threshold: a fraction of the peak in \(0, 1\), got 5"):
        compare(result, channels_of(result), pulse_threshold=5)
    short = compare(result, channels_of(result), window=(0, 0.05))
    assert short.vehicles[0].t[-1] == pytest.approx(0.05)


def test_table_csv_and_json(result, tmp_path):
    c = compare(result, channels_of(result))
    frame = c.to_frame()
    assert list(frame.columns) == ["vehicle", "metric", "unit", "measured", "simulated", "difference"]
    assert len(frame) == 6 and set(frame.unit) == {"ft/s^2", "ft/s", "s"}
    data = json.loads(c.to_json(tmp_path / "c.json").read_text())
    assert data["unit_system"] == "US" and data["iso18571"]["accel_target"]["total"] == 1
    lines = c.to_csv(tmp_path / "c.csv").read_text().splitlines()
    assert lines[0] == "vehicle,metric,unit,measured,simulated,difference"
    assert "accel_target,iso18571_total,,,1," in lines


def test_figure(result):
    pytest.importorskip("matplotlib")
    import matplotlib
    matplotlib.use("Agg")
    fig = compare(result, channels_of(result)).figure()
    assert len(fig.axes) == 4 and fig.axes[0].get_title().startswith("bullet — ISO/TS 18571 1.000")


def test_shipped_synthetic_test_rates_high_but_not_one(result):
    from lsc.analysis import read_channels

    c = compare(result, read_channels(lsc.data.__path__[0] + "/synthetic_test.zip"))
    for rating in c.iso18571.values():
        assert 0.9 < rating.total < 1 and rating.phase == 1.0


def test_import_lsc_loads_neither_pandas_nor_matplotlib():
    code = ("import sys, lsc, lsc.analysis; "
            "print(' '.join(m for m in ('pandas', 'matplotlib', 'jax') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
