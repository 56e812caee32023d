"""read_channels: tables and ISO-MME data sets in, units and kinds read, bad files refused with
the file, line and column."""

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

import lsc
import lsc.data
from lsc.analysis.channels import Channels, read_channels, write_csv, write_isomme
from lsc.analysis.filters import cfc_filter

DATA = Path(lsc.data.__file__).parent
SHIPPED_CSV, SHIPPED_ZIP = DATA / "synthetic_test.csv", DATA / "synthetic_test.zip"
G = 9.80665


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_shipped_csv_and_isomme_hold_the_same_channels():
    a, b = read_channels(SHIPPED_CSV), read_channels(SHIPPED_ZIP)
    assert a.names == ("accel_bullet", "accel_target", "force", "deformation")
    assert [c.label for c in b] == list(a.names)    # ISO-MME: names are the channel codes
    assert a.sample_rate == pytest.approx(1e4) and a.pre_trigger == 200 and np.allclose(a.t, b.t, atol=1e-12)
    for ca, cb in zip(a, b):
        assert (ca.unit, ca.kind) == (cb.unit, cb.kind) and np.array_equal(ca.values, cb.values)
    assert [c.kind for c in a] == ["acceleration", "acceleration", "force", "displacement"]


def test_shipped_data_is_the_default_scene_within_its_noise():
    """The synthetic test is the packaged default scene: its ΔV (integral of the acceleration)
    is the closed form's 7.0 ft/s within the filtered noise."""
    ch = read_channels(SHIPPED_CSV)
    a = ch["accel_target"].to("US")
    dv = np.trapezoid(a[ch.t >= 0], ch.t[ch.t >= 0]) if hasattr(np, "trapezoid") else np.trapz(a[ch.t >= 0], ch.t[ch.t >= 0])
    assert dv == pytest.approx(7.0, abs=0.02)
    assert ch["accel_target"].to("SI").max() == pytest.approx(ch["accel_target"].values.max() * G)


def test_shipped_sets_round_trip_through_the_writers(tmp_path):
    shipped = read_channels(SHIPPED_ZIP)
    with zipfile.ZipFile(SHIPPED_ZIP) as z:
        z.extractall(tmp_path / "folder")
    folder = read_channels(tmp_path / "folder")
    mme = read_channels(tmp_path / "folder" / "SYNTH14.mme")
    csv = read_channels(write_csv(read_channels(SHIPPED_CSV), tmp_path / "again.csv"))
    iso = read_channels(write_isomme(shipped, tmp_path / "again.zip", test="X"))
    for other in (folder, mme, iso):
        assert other.names == shipped.names and np.array_equal(other.t, shipped.t)
        assert all(np.array_equal(c.values, o.values) for c, o in zip(shipped, other))
    assert all(np.array_equal(c.values, o.values) for c, o in zip(read_channels(SHIPPED_CSV), csv))


def test_header_units_tsv_semicolons_and_time_in_ms(tmp_path):
    rows = [(0.0, 1.0, 2.0, 10.0), (0.1, 2.0, 4.0, 20.0), (0.2, 3.0, 6.0, 30.0), (0.3, 4.0, 8.0, 40.0)]
    body = "\n".join("\t".join(str(x) for x in r) for r in rows)
    tsv = write(tmp_path, "a.tsv", "time (ms)\taccel_target [g]\tforce [kN]\tdeformation [mm]\n" + body)
    semi = write(tmp_path, "a.txt", "# lab export\ntime [ms];accel_target [g];force [kN];deformation [mm]\n"
                 + body.replace("\t", ";"))
    for path in (tsv, semi):
        ch = read_channels(path)
        assert ch.dt == pytest.approx(1e-4)
        assert np.allclose(ch["accel_target"].to("SI"), [G, 2 * G, 3 * G, 4 * G])
        assert np.allclose(ch["force"].to("US"), np.array([2, 4, 6, 8]) * 1000 / 4.4482216152605)
        assert np.allclose(ch["deformation"].to("SI"), [0.01, 0.02, 0.03, 0.04])


def test_explicit_columns_and_units(tmp_path):
    path = write(tmp_path, "b.csv", "t,A1,A2\n0,1,-1\n0.001,2,-2\n0.002,3,-3\n")
    ch = read_channels(path, columns={"accel_target": "A1", "accel_bullet": 2},
                       units={"time": "s", "accel_target": "m/s^2", "accel_bullet": "ft/s^2"})
    assert ch.names == ("accel_target", "accel_bullet")
    assert np.allclose(ch["accel_bullet"].to("SI"), np.array([-1, -2, -3]) * 0.3048)


def test_sign_convention_invert(tmp_path):
    path = write(tmp_path, "c.csv", "time [s],accel_bullet [g]\n0,0.5\n0.001,1\n0.002,0.5\n")
    ch = read_channels(path, invert=["accel_bullet"])
    assert np.array_equal(ch["accel_bullet"].values, [-0.5, -1.0, -0.5])


def test_time_zero_pre_trigger_offset_and_cfc(tmp_path):
    t = np.arange(-50, 450) / 1e4 + 0.2              # file time: contact at 0.2 s
    a = 0.3 + np.where(t >= 0.2, np.sin(np.pi * (t - 0.2) / 0.04) * (t < 0.24), 0)
    path = tmp_path / "d.csv"
    np.savetxt(path, np.column_stack([t, a]), delimiter=",", header="time [s],accel_target [g]", comments="")
    ch = read_channels(path, time_zero=0.2, offset="pre-trigger")
    assert ch.pre_trigger == 50 and ch.t[50] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(ch["accel_target"].values[:50], 0.0) and ch["accel_target"].values.max() == pytest.approx(1, abs=1e-6)
    filtered = read_channels(path, cfc=60)
    assert np.array_equal(filtered["accel_target"].values, cfc_filter(a, 60, ch.sample_rate)) and filtered.cfc == 60


def test_match_by_name_and_by_mapping():
    scene = lsc.data.load("default")
    ch = read_channels(SHIPPED_ZIP)
    assert set(ch.match(scene)) == {"accel_bullet", "accel_target", "force", "deformation"}
    swapped = ch.match(scene, {"accel_bullet": "20VEHC0000ACXD"})
    assert swapped["accel_bullet"].name == "20VEHC0000ACXD"
    with pytest.raises(lsc.SceneError, match=r"channel '10BUMP0000FOXD' \(lbf\) is a force, but 'accel_target' needs an acceleration"):
        ch.match(scene, {"accel_target": "force"})
    with pytest.raises(lsc.SceneError, match=r"mapping.accel_car: 'accel_car' is not a channel role"):
        ch.match(scene, {"accel_car": "force"})


# ------------------------------------------------------------------ malformed files

def test_missing_channel_and_missing_time_column(tmp_path):
    path = write(tmp_path, "e.csv", "time [s],accel_target [g]\n0,1\n0.001,2\n0.002,3\n")
    with pytest.raises(lsc.SceneError) as e:
        read_channels(path, columns={"accel_bullet": "accel_bullet"})
    assert str(e.value) == (f"{path}: channel 'accel_bullet': no column 'accel_bullet' in the header (line 1); "
                            "the columns are: time [s], accel_target [g]")
    with pytest.raises(lsc.SceneError, match="no channel named 'accel_bullet'; the channels are: accel_target"):
        read_channels(path)["accel_bullet"]
    nt = write(tmp_path, "f.csv", "secs [s],accel_target [g]\n0,1\n0.001,2\n0.002,3\n")
    with pytest.raises(lsc.SceneError, match=r"no time column: head one column 'time \[s\]' \(line 1\)"):
        read_channels(nt)


def test_non_numeric_and_empty_cells(tmp_path):
    path = write(tmp_path, "g.csv", "time [s],accel_target [g]\n0,1\n0.001,x2\n0.002,3\n")
    with pytest.raises(lsc.SceneError) as e:
        read_channels(path)
    assert str(e.value) == f"{path}: line 3, column 2 ('accel_target [g]') is 'x2', not a finite number"
    empty = write(tmp_path, "h.csv", "time [s],accel_target [g]\n0,1\n0.001,\n0.002,3\n")
    with pytest.raises(lsc.SceneError, match=r"line 3, column 2 \('accel_target \[g\]'\) is empty"):
        read_channels(empty)


def test_duplicate_names_refused_and_empty_trailing_column_skipped(tmp_path):
    twice = write(tmp_path, "n.csv", "time [s],accel [g],accel [m/s^2]\n0,1,1\n0.001,2,2\n0.002,3,3\n")
    with pytest.raises(lsc.SceneError) as e:
        read_channels(twice)
    assert str(e.value) == (f"{twice}: line 1: columns 2 and 3 are both named 'accel'; rename one, or pick "
                            "columns with columns={name: column}")
    trailing = write(tmp_path, "o.csv", "time [s],accel_target [g],\n0,1,\n0.001,2,\n0.002,3,\n")
    assert read_channels(trailing).names == ("accel_target",)


def test_unknown_or_missing_unit(tmp_path):
    path = write(tmp_path, "i.csv", "time [s],accel_target [bananas]\n0,1\n0.001,2\n0.002,3\n")
    with pytest.raises(lsc.SceneError) as e:
        read_channels(path)
    assert str(e.value).startswith(f"{path}, line 1, column 2 ('accel_target [bananas]'): unknown or "
                                   'unsupported unit "bananas"')
    mass = write(tmp_path, "j.csv", "time [s],accel_target [kg]\n0,1\n0.001,2\n0.002,3\n")
    with pytest.raises(lsc.SceneError, match='unknown or unsupported unit "kg"'):
        read_channels(mass)
    bare = write(tmp_path, "k.csv", "time [s],accel_target\n0,1\n0.001,2\n0.002,3\n")
    with pytest.raises(lsc.SceneError, match=r"column 2 \('accel_target', line 1\) has no unit"):
        read_channels(bare)


def test_inconsistent_sample_rate(tmp_path):
    path = write(tmp_path, "l.csv", "time [s],accel_target [g]\n0,1\n0.001,2\n0.002,3\n0.004,3\n0.005,3\n")
    with pytest.raises(lsc.SceneError) as e:
        read_channels(path)
    assert str(e.value).startswith(f"{path}: line 3, column 1: time step 0.001 s differs from the mean "
                                   "sample interval 0.00125 s")


# ------------------------------------------------------------------ hand-written ISO-MME

MME = "Data format                 :ISO-MME\nVersion                     :1.6\nName of the test            :HAND\n"


def iso_channel(code, name, unit, dt, t0, values, count=None):
    head = (f"Channel code                :{code}\nName of the channel         :{name}\n"
            f"Reference channel           :implicit\nUnit                        :{unit}\n"
            f"Sampling interval           :{dt}\nTime of first sample        :{t0}\n"
            f"Number of samples           :{len(values) if count is None else count}\n")
    return head + "".join(f"{v}\n" for v in values)


def hand_set(tmp_path, channels, name="hand"):
    root = tmp_path / name
    (root / "Channel").mkdir(parents=True)
    (root / "HAND.mme").write_text(MME)
    chn = f"Number of channels          :{len(channels)}\n" + "".join(
        f"Name of channel {i:03d}         :{c[0]} / {c[1]}\n" for i, c in enumerate(channels, 1))
    (root / "Channel" / "HAND.chn").write_text(chn)
    for i, c in enumerate(channels, 1):
        (root / "Channel" / f"HAND.{i:03d}").write_text(iso_channel(*c))
    return root


def test_hand_written_isomme_units_and_offset_start_times(tmp_path):
    root = hand_set(tmp_path, [
        ("10VEHC0000ACXP", "accel_bullet", "m/s**2", 0.001, -0.002, [0, 0, -5, -10, -5, 0]),
        ("20VEHC0000ACXP", "accel_target", "g", 0.001, -0.001, [0, 1, 2, 1, 0, 0, 0]),
        ("10BUMP0000FOXP", "force", "kN", 0.001, 0.0, [1, 2, 1, 0])])
    ch = read_channels(root)
    assert np.allclose(ch.t, [0.0, 0.001, 0.002, 0.003])           # the span all three cover
    assert np.allclose(ch["10VEHC0000ACXP"].values, [-5, -10, -5, 0])
    assert np.allclose(ch["accel_target"].to("SI"), np.array([1, 2, 1, 0]) * G)
    assert ch["force"].kind == "force" and np.allclose(ch["force"].to("SI"), [1000, 2000, 1000, 0])
    shutil.make_archive(str(tmp_path / "hand"), "zip", root)
    zipped = read_channels(tmp_path / "hand.zip")
    assert all(np.array_equal(a.values, b.values) for a, b in zip(ch, zipped))


def test_isomme_inconsistent_sample_rate(tmp_path):
    root = hand_set(tmp_path, [("10VEHC0000ACXP", "a", "g", 0.001, 0.0, [0, 1, 2, 1]),
                               ("20VEHC0000ACXP", "b", "g", 0.0005, 0.0, [0, 1, 2, 1])])
    with pytest.raises(lsc.SceneError) as e:
        read_channels(root)
    assert str(e.value) == (f"{root}/Channel/HAND.002: line 5: sampling interval 0.0005 s differs from 0.001 s "
                            f"of {root}/Channel/HAND.001; the channels must have one sample rate")


def test_isomme_malformed_channel_files(tmp_path):
    bad = hand_set(tmp_path, [("10VEHC0000ACXP", "a", "g", 0.001, 0.0, [0, 1, "NOVALUE", 1])], "bad")
    with pytest.raises(lsc.SceneError) as e:
        read_channels(bad)
    assert str(e.value) == f"{bad}/Channel/HAND.001: line 10, column 1 (10VEHC0000ACXP): 'NOVALUE' is not a finite number"
    short = hand_set(tmp_path, [("10VEHC0000ACXP", "a", "g", 0.001, 0.0, [0, 1, 2, 1], 5)], "short")
    with pytest.raises(lsc.SceneError, match=r"HAND.001: line 7: 'Number of samples' is 5, but the file holds 4 values"):
        read_channels(short)
    unit = hand_set(tmp_path, [("10VEHC0000ACXP", "a", "furlong/s/s/s", 0.001, 0.0, [0, 1, 2, 1])], "unit")
    with pytest.raises(lsc.SceneError, match=r"HAND.001, line 4: unknown or unsupported unit \"furlong/s/s/s\""):
        read_channels(unit)
    explicit = hand_set(tmp_path, [("10VEHC0000ACXP", "a", "g", 0.001, 0.0, [0, 1, 2, 1])], "explicit")
    file = explicit / "Channel" / "HAND.001"
    file.write_text(file.read_text().replace(":implicit", ":explicit"))
    with pytest.raises(lsc.SceneError, match=r"HAND.001: line 3: channel 10VEHC0000ACXP is timed by an explicit"):
        read_channels(explicit)
    missing = hand_set(tmp_path, [("10VEHC0000ACXP", "a", "g", 0.001, 0.0, [0, 1, 2, 1])], "missing")
    (missing / "Channel" / "HAND.001").unlink()
    with pytest.raises(lsc.SceneError, match=r"HAND.chn: channel 001 is listed but its file Channel/HAND.001 is missing"):
        read_channels(missing)
    (missing / "HAND.mme").unlink()
    with pytest.raises(lsc.SceneError, match="exactly one .mme file; found 0"):
        read_channels(missing)


def test_channels_container_basics():
    ch = read_channels(SHIPPED_CSV)
    assert isinstance(ch, Channels) and len(ch) == 4 and "force" in ch
    frame = ch.to_frame()
    assert list(frame.columns) == ["time [s]", "accel_bullet [g]", "accel_target [g]", "force [lbf]", "deformation [in]"]


def test_excel_sheet(tmp_path):
    """An Excel sheet reads like a CSV (rows for lines); without openpyxl the error names the remedy."""
    path = tmp_path / "m.xlsx"
    try:
        import openpyxl  # noqa: F401
    except ImportError:
        with zipfile.ZipFile(path, "w") as z:          # what pandas takes for a workbook: openpyxl's
            z.writestr("xl/workbook.xml", "<workbook/>")
        with pytest.raises(lsc.SceneError, match=r"reading Excel files needs openpyxl .*save the sheet as CSV"):
            read_channels(path)
        return
    import pandas as pd

    pd.DataFrame({"time [ms]": [0, 1, 2, 3], "accel_target [g]": [0, 1, "x", 0]}).to_excel(path, index=False)
    with pytest.raises(lsc.SceneError, match=r"row 4, column 2 \('accel_target \[g\]'\) is 'x', not a finite number"):
        read_channels(path)
    pd.DataFrame({"time [ms]": [0, 1, 2, 3], "accel_target [g]": [0, 1, 2, 0]}).to_excel(path, index=False)
    ch = read_channels(path)
    assert ch.dt == pytest.approx(1e-3) and np.allclose(ch["accel_target"].to("SI"), np.array([0, 1, 2, 0]) * G)
