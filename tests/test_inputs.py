"""Inputs that used to be dropped, misread or let through to a non-finite or absurd result (issue 11,
items 5-7): each is refused with a SceneError that names the field and says what is accepted, and
the scenes next to the limits still solve."""

from __future__ import annotations

import os

import numpy as np
import pytest

import lsc
from lsc.errors import SceneError
from lsc.scene import GAP_RATIO, MAX_CSV_BYTES, Scene
from helpers import with_changes

#: The paper's scene (US units, g = 32.2 ft/s²): ΔV = ∓7 ft/s in 0.1046 s.
PAPER = {"units": "US", "g": "32.2 ft/s^2",
         "vehicles": [{"weight": 3500, "speed": 10}, {"weight": 3500, "speed": 0}],
         "contacts": [{"loading": {"stiffness": 24000}, "unloading": {"restitution": 0.4}}]}

VELOCITY = 'expected a velocity (e.g. "10 ft/s", "16 km/h" or a bare number in ft/s)'
RANGE = ("is outside the range lsc computes with: a magnitude from 1e-100 to 1e+100 {unit} (or 0), "
         "so that the energies, forces and times formed from it stay finite, normal floats")


def scene(**changes) -> dict:
    """The paper scene with dotted-path changes (``scene(**{"vehicles.0.speed": 5})``)."""
    return with_changes(PAPER, **changes)


def refused(obj, path: str, **solve_options) -> str:
    """The message of the SceneError that loading (and solving) ``obj`` raises at ``path``."""
    with pytest.raises(SceneError) as ei:
        lsc.solve(obj, **solve_options) if solve_options else Scene.load(obj)
    assert ei.value.path == path, str(ei.value)
    return ei.value.message


# ----------------------------------------------------------------- item 5: quantities as text
@pytest.mark.parametrize("text", ["12 mph # 10 ft/s", "10 ft/s ± 1", "10 ft/s 5", "10 ft/s, 3",
                                  "1_0 ft/s", "10 ft/s (measured)"])
def test_text_after_a_quantity_is_refused(text):
    assert refused(scene(**{"vehicles.0.speed": text}), "vehicles[0].speed") == (
        f'could not read "{text}" as a quantity: write exactly a number and a unit, with nothing '
        f"after the unit; {VELOCITY}")


@pytest.mark.parametrize("text, ft_s", [("12 mph", 17.6), ("10 ft/s", 10.0), ("3.048 m/s", 10.0),
                                        ("10 ft / s", 10.0), ("1e1 ft*s^-1", 10.0),
                                        ("10 ft·s⁻¹", 10.0), ("+10", 10.0)])
def test_quantity_forms_still_read(text, ft_s):
    assert Scene.load(scene(**{"vehicles.0.speed": text})).speeds[0] == pytest.approx(ft_s, rel=1e-12)


def test_parse_number_is_strict():
    from lsc.units import parse_number

    assert [parse_number(t) for t in ("1.5", " -3 ", "4.5e3", ".5", "7.")] == [1.5, -3.0, 4500.0, 0.5, 7.0]
    assert np.isnan(parse_number("nan")) and parse_number("-inf") == -np.inf
    # what float() reads and a number in a CSV or a quantity must not be
    assert [parse_number(t) for t in ("1_0", "١٠", "0x10", "1e", "", "1 0")] == [None] * 6
    assert float("1_0") == 10.0 and float("١٠") == 10.0


def _csv_scene(tmp_path, text: str, name: str = "c.csv") -> dict:
    (tmp_path / name).write_text(text)
    return scene(**{"contacts.0.loading": {"csv": str(tmp_path / name)}})


@pytest.mark.parametrize("cell", ["1_0", "١", "0x1"])
def test_csv_cell_that_float_reads_is_not_a_number(tmp_path, cell):
    msg = refused(_csv_scene(tmp_path, f"D,F\n0,0\n{cell},100\n"), "contacts[0].loading.csv")
    assert msg == (f'{tmp_path / "c.csv"}, line 3: "{cell}" is not a number; expected two numeric '
                   "columns (deformation, force), each cell a plain decimal number such as 1.2, -3 or "
                   "4.5e3")


def test_csv_first_row_of_bad_numbers_is_not_a_header(tmp_path):
    """A first row "1_0,2_0" used to be skipped as a header, silently dropping a data row."""
    msg = refused(_csv_scene(tmp_path, "0_0,0_0\n1,100\n2,300\n"), "contacts[0].loading.csv")
    assert msg.startswith(f'{tmp_path / "c.csv"}, line 1: "0_0" is not a number')
    # a header of words is still a header
    s = Scene.load(_csv_scene(tmp_path, "deformation (ft),force (lbf)\n0,0\n1,100\n"))
    np.testing.assert_array_equal(s.contacts[0].law.loading.f, [0.0, 100.0])


# ----------------------------------------------------------------- item 5: options
ACCEPTED = "atol, dt, first_step, integrator, max_events, max_steps, n_samples, rtol, t_end"


@pytest.mark.parametrize("method", [None, "auto", "closed-form", "scipy"])
def test_option_no_backend_knows_is_refused(method):
    """``lsc.solve(s, rtoll=1e-13)`` ran with auto at the default tolerance."""
    assert refused(PAPER, "solver.rtoll", method=method, rtoll=1e-13) == (
        f"unknown option 'rtoll'; did you mean 'rtol'? accepted options: {ACCEPTED}")


def test_option_of_another_backend_is_left_out_by_auto():
    """Documented: auto drops an option that only other backends take (rtol for the closed form)."""
    r = lsc.solve(PAPER, rtol=1e-13)
    assert r.method == "closed-form"
    np.testing.assert_allclose(r.delta_v, [-7.0, 7.0], rtol=1e-12)


@pytest.mark.parametrize("rtol", [1e10, 1.0, 2.0])
def test_rtol_must_be_below_one(rtol):
    message = ("rtol must be a positive finite number below 1 (a relative tolerance, such as 1e-10), "
               f"got {rtol!r}")
    assert refused(PAPER, "solver.rtol", method="scipy", rtol=rtol) == message
    assert refused(scene(solver={"rtol": rtol}), "solver.rtol") == message


@pytest.mark.parametrize("atol", [-1.0, 0.0, float("inf"), float("nan"), "1e-9"])
def test_atol_must_be_positive_finite(atol):
    assert refused(PAPER, "solver.atol", method="scipy", atol=atol) == (
        f"atol must be a positive finite number, got {atol!r}")


def test_g_is_checked_before_any_weight():
    """``g = 1e-308`` was blamed on vehicles[0].weight ("weight / g is not a usable mass")."""
    for g in (1e-308, "1e-308 ft/s^2", 1e6, "0.1 ft/s^2"):
        assert refused(scene(g=g), "g").startswith(
            "must be the local acceleration of gravity, between 0.01 and 100 times standard gravity "
            "(0.32174 ft/s^2 to 3217.4 ft/s^2), got ")
    # the Moon's gravity is a gravity
    assert Scene.load(scene(g="1.62 m/s^2")).g == pytest.approx(1.62 / 0.3048)


# ----------------------------------------------------------------- item 6: representable inputs
@pytest.mark.parametrize("path, field, value, unit", [
    ("vehicles.0.speed", "vehicles[0].speed", 1e308, "ft/s"),
    ("vehicles.0.weight", "vehicles[0].weight", 1e308, "lbf"),
    ("vehicles.0.weight", "vehicles[0].weight", 1e-308, "lbf"),
    ("contacts.0.gap", "contacts[0].gap", 1e308, "ft"),
    ("contacts.0.loading.stiffness", "contacts[0].loading.stiffness", 1e-200, "lbf/ft"),
])
def test_unrepresentable_magnitudes_are_refused(path, field, value, unit):
    """Each gave ΔV = ±inf, a NaN duration, a ΔV of 4e-311 or a duration of 0.0 before."""
    msg = refused(scene(**{path: value}), field, method="auto")
    expected = f"{value:g} {unit} " + RANGE.format(unit=unit)
    if field.endswith("speed"):  # only large speeds: a tiny one is almost 0
        expected = expected.replace("from 1e-100 to 1e+100 ft/s (or 0)", "of at most 1e+100 ft/s")
    assert msg == expected


def test_mass_from_weight_must_be_representable():
    # 1e-99 lbf is in range, but 1e-99 lbf / 32.2 ft/s² is not
    assert refused(scene(**{"vehicles.1.weight": 1e-99}), "vehicles[1].weight") == (
        "the mass weight / g = 3.10559e-101 slug " + RANGE.format(unit="slug"))


def test_table_values_must_be_representable(tmp_path):
    at_most = RANGE.format(unit="{unit}").replace("from 1e-100 to 1e+100 {unit} (or 0)",
                                                  "of at most 1e+100 {unit}")
    big = scene(**{"contacts.0.loading": {"table": [[0, 0], [1e120, 1e5]]}})
    assert refused(big, "contacts[0].loading.table") == "row 1: 1e+120 ft " + at_most.format(unit="ft")
    scaled = scene(**{"contacts.0.loading": {"table": [[0, 0], [1, 1e60]], "scale": 1e50}})
    assert refused(scaled, "contacts[0].loading.scale") == \
        "row 1: 1e+110 lbf " + at_most.format(unit="lbf")
    msg = refused(_csv_scene(tmp_path, "0,0\n1,1e200\n"), "contacts[0].loading.csv")
    assert msg == "row 1: 1e+200 lbf " + at_most.format(unit="lbf")


def test_gap_too_wide_for_the_crush_is_refused():
    """A gap of 1e50 ft: the pulse (0.1 s) was below the rounding of the absolute time of contact
    and the duration came out 0.0. The limit is GAP_RATIO (1e-8 / ε) times the largest crush, the
    closed form's D_max = v0 √(μ/k) here."""
    mu = 3500 / 32.2 / 2
    d_max = 10.0 * np.sqrt(mu / 24000)
    msg = refused(scene(**{"contacts.0.gap": 1e50}), "contacts[0].gap", method="auto")
    assert msg == (f"1e+50 ft is too wide for this crash to be represented: the contact can be "
                   f"crushed by at most {d_max:g} ft (all the kinetic energy of the relative motion), "
                   f"and after a gap of more than {GAP_RATIO:.3g} times that (here "
                   f"{GAP_RATIO * d_max:g} ft) the rounding of positions and times exceeds 1e-8 of the "
                   "crush and of the pulse; start the vehicles closer")
    # just inside the limit the closed form's pulse is still found to 1e-8 of its length
    r = lsc.solve(scene(**{"contacts.0.gap": 0.99 * GAP_RATIO * d_max}))
    omega = np.sqrt(24000 / mu)
    assert r.duration == pytest.approx(np.pi / (2 * omega) * 1.4, rel=1e-8)
    np.testing.assert_allclose(r.delta_v, [-7.0, 7.0], rtol=1e-12)


@pytest.mark.parametrize("contact", [
    {"loading": {"table": [[0, 6000], [0.5, 20000]]}, "unloading": {"restitution": 0.4}},
    {"law": "kelvin", "stiffness": 24000, "restitution": 0.4},
    {"law": "hunt-crossley", "stiffness": 24000, "exponent": 1.5, "restitution": 0.4},
])
def test_gap_limit_for_every_law(contact):
    s = scene(**{"contacts.0": {**contact, "gap": 1e12}})
    assert refused(s, "contacts[0].gap").startswith("1e+12 ft is too wide for this crash")


def test_extreme_but_valid_scenes_still_solve():
    """Mass ratio 1000:1, stiffness 1e2 and 1e9 lbf/ft, restitution 0 and 1, 100 m/s and 1e-6 ft/s:
    the closed-form ΔV, as before."""
    for m1, m2, k, e, v, v2, gap in [(1000.0, 1.0, 1e2, 0.0, 330.0, 0.0, 0.1),
                                     (1.0, 1000.0, 1e9, 1.0, 1e-6, 0.0, 0.0),
                                     (54.3, 54.3, 24000.0, 0.4, 1e-6, 3.2e-285, 1e-3)]:
        s = {"units": "US", "vehicles": [{"mass": m1, "speed": v}, {"mass": m2, "speed": v2}],
             "contacts": [{"loading": {"stiffness": k}, "unloading": {"restitution": e},
                           "gap": gap}]}
        r = lsc.solve(s)
        dv2 = (1 + e) * m1 * v / (m1 + m2)
        np.testing.assert_allclose(r.delta_v, [-dv2 * m2 / m1, dv2], rtol=1e-12)
        assert np.isfinite(r.duration) and r.duration > 0


def test_speeds_that_differ_by_less_than_representable():
    s = scene(**{"vehicles.0.speed": 2e-101, "vehicles.1.speed": 1e-101})
    assert refused(s, "vehicles[0].speed") == (
        "the speeds differ by only 1e-101 ft/s: the closing speeds must reach 1e-100 ft/s for the "
        "energies and crushes of the crash to be normal floats")


# ----------------------------------------------------------------- item 7: wrong kinds, sizes
@pytest.mark.parametrize("law, key, unit, hint", [
    ("hunt-crossley", "damping", "a time per length (e.g. \"0.2 s/ft\", \"0.6 s/m\" or a bare number "
     "in s/ft)", "Hunt–Crossley's α multiplies the closing rate in F = k D^n (1 + α dD/dt): it is not "
     "a Kelvin damping c"),
    ("brach", "damping", "a damping per length (e.g. \"20000 lbf*s/ft^2\", \"1 MN*s/m^2\" or a bare "
     "number in lbf*s/ft^2)", "Brach's c multiplies D dD/dt in F = k D + c D dD/dt"),
    ("brach", "damping_restitution", "a damping per length (e.g. \"20000 lbf*s/ft^2\", \"1 MN*s/m^2\" "
     "or a bare number in lbf*s/ft^2)", "Brach's c multiplies D dD/dt in F = k D + c D dD/dt"),
])
def test_damping_of_the_wrong_kind(law, key, unit, hint):
    """A Kelvin damping (N·s/m) given to Hunt–Crossley or Brach was a KeyError: 'slowness'."""
    contact = {"law": law, "stiffness": 24000, key: "300 N*s/m"}
    if key == "damping":
        contact["restitution" if law == "brach" else "gap"] = 0.4 if law == "brach" else 0.0
    msg = refused(scene(**{"contacts.0": contact}), f"contacts[0].{key}")
    assert msg == f'"300 N*s/m" is a damping, expected {unit}; {hint}'


def test_damping_of_the_right_kind_loads():
    s = Scene.load(scene(**{"contacts.0": {"law": "hunt-crossley", "stiffness": 24000,
                                             "damping": "0.6 s/m"}}))
    assert s.contacts[0].law.damping == pytest.approx(0.6 * 0.3048)


def test_n_samples_limit():
    """n_samples = 1e9 was a MemoryError."""
    from lsc.solvers import MAX_SAMPLES

    message = "n_samples must be at most 1,000,000 (points in each sampled series), got 1,000,000,000"
    assert refused(PAPER, "solver.n_samples", n_samples=10**9) == message
    assert refused(scene(solver={"n_samples": 1e9}), "solver.n_samples") == message
    assert lsc.solve(PAPER, n_samples=MAX_SAMPLES).t.size >= MAX_SAMPLES


def test_margin_steps_limit():
    """margin_steps = 1e9 was a MemoryError (a list of a billion speeds)."""
    from lsc.analysis import max_closing_speed

    for steps in (10**9, -1, 1.5, True):
        with pytest.raises(SceneError) as ei:
            max_closing_speed(PAPER, 5000.0, margin_steps=steps)
        assert ei.value.path == "margin_steps"
        assert ei.value.message == (f"must be a whole number from 0 to 1000 (one solve per step), "
                                    f"got {steps!r}")


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_devices_are_not_read():
    """A scene or CSV path of /dev/zero was read without end."""
    assert refused("/dev/zero", "") == ("/dev/zero is not a regular file (a device, pipe or socket); "
                                        "give the path of a scene file")
    assert refused(scene(**{"contacts.0.loading": {"csv": "/dev/zero"}}), "contacts[0].loading.csv") == (
        "/dev/zero is not a regular file (a device, pipe or socket); give the path of a CSV file")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_fifo_is_not_opened(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)   # opening it for reading would block forever
    assert refused(scene(**{"contacts.0.loading": {"csv": str(fifo)}}), "contacts[0].loading.csv") == (
        f"{fifo} is not a regular file (a device, pipe or socket); give the path of a CSV file")


def test_file_size_limits(tmp_path):
    big = tmp_path / "big.csv"
    with open(big, "wb") as fh:
        fh.truncate(MAX_CSV_BYTES + 1)   # sparse: no disk, no memory
    assert refused(scene(**{"contacts.0.loading": {"csv": str(big)}}), "contacts[0].loading.csv") == (
        f"{big} is larger than 64 MB, the most lsc reads from a CSV file")
    toml = tmp_path / "big.toml"
    with open(toml, "wb") as fh:
        fh.truncate(10 * 2**20 + 1)
    assert refused(str(toml), "") == f"{toml} is larger than 10 MB, the most lsc reads from a scene file"
