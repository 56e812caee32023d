"""Output files all at once or not at all, never over an earlier run's without leave
(lsc.outputs.write_files and lsc.plots.save_all)."""

import errno
import os
import stat
from pathlib import Path

import pytest

from lsc.outputs import OutputError, OutputExistsError, refuse_existing, write_files


def _text(content):
    def write(path):
        path.write_text(content)
    return write


def _fail(path):
    raise OSError(errno.ENOSPC, "No space left on device", str(path))


def _listing(folder):
    return sorted(os.listdir(folder))


def test_all_files_move_in_together_with_their_names_and_modes(tmp_path):
    out = tmp_path / "new" / "deeper"
    seen = []

    def spy(path):
        seen.append((path.parent, path.suffix, path.name.startswith("."), _listing(out)))
        path.write_text("b")

    written = write_files({out / "a.csv": _text("a"), out / "b.png": spy})
    assert written == [out / "a.csv", out / "b.png"]
    assert (out / "a.csv").read_text() == "a" and (out / "b.png").read_text() == "b"
    # the second file was written beside its target, hidden, with its suffix (matplotlib picks
    # the format from it), while the first was still under its temporary name
    (parent, suffix, hidden, listing), = seen
    assert parent == out and suffix == ".png" and hidden
    assert "a.csv" not in listing and len(listing) == 2
    assert _listing(out) == ["a.csv", "b.png"]
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE((out / "a.csv").stat().st_mode) == 0o666 & ~umask  # as open() makes it


def test_an_earlier_run_is_refused_and_left_untouched(tmp_path):
    (tmp_path / "a.csv").write_text("earlier")
    with pytest.raises(OutputExistsError) as e:
        write_files({tmp_path / "b.csv": _text("b"), tmp_path / "a.csv": _text("a")})
    assert e.value.paths == (tmp_path / "a.csv",)
    assert isinstance(e.value, FileExistsError)
    assert str(e.value) == (f"{tmp_path / 'a.csv'} already exists (the results of an earlier "
                            "run): pass overwrite=True to replace them")
    assert _listing(tmp_path) == ["a.csv"] and (tmp_path / "a.csv").read_text() == "earlier"


def test_overwrite_replaces_and_removes_the_stale_files_of_the_command(tmp_path):
    for name in ("a.csv", "fig.png", "unrelated.txt"):
        (tmp_path / name).write_text("earlier")
    with pytest.raises(OutputExistsError) as e:  # a stale output is an earlier run's too
        write_files({tmp_path / "b.csv": _text("b")}, replaces=[tmp_path / "fig.png"])
    assert e.value.paths == (tmp_path / "fig.png",)
    write_files({tmp_path / "a.csv": _text("new")}, overwrite=True,
                replaces=[tmp_path / "a.csv", tmp_path / "fig.png"])
    assert _listing(tmp_path) == ["a.csv", "unrelated.txt"]
    assert (tmp_path / "a.csv").read_text() == "new"
    assert (tmp_path / "unrelated.txt").read_text() == "earlier"


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_failing_later_file_leaves_nothing_new_and_the_earlier_files_intact(tmp_path, overwrite):
    out = tmp_path / "out"
    out.mkdir()
    if overwrite:
        (out / "a.csv").write_text("earlier a")
        (out / "b.png").write_text("earlier b")
    with pytest.raises(OutputError) as e:
        write_files({out / "a.csv": _text("a"), out / "c.json": _text("c"), out / "b.png": _fail},
                    overwrite=overwrite)
    assert e.value.filename == str(out / "b.png") and e.value.errno == errno.ENOSPC
    assert e.value.strerror == "No space left on device"
    if overwrite:
        assert _listing(out) == ["a.csv", "b.png"]
        assert (out / "a.csv").read_text() == "earlier a"
        assert (out / "b.png").read_text() == "earlier b"
    else:
        assert _listing(out) == []


def test_a_failure_removes_the_folders_it_created_and_only_those(tmp_path):
    with pytest.raises(RuntimeError, match="figure bug"):
        write_files({tmp_path / "x" / "y" / "a.csv": _text("a"),
                     tmp_path / "x" / "y" / "b.png": _raise_runtime})
    assert _listing(tmp_path) == []


def _raise_runtime(path):
    raise RuntimeError("figure bug")


def test_a_failed_move_puts_the_earlier_files_back(tmp_path, monkeypatch):
    for name in ("a.csv", "b.csv", "old.png"):
        (tmp_path / name).write_text(f"earlier {name}")
    real = os.replace
    moves = []

    def replace(src, dst):  # the move of the new b.csv into place fails
        moves.append(Path(dst))
        if Path(dst) == tmp_path / "b.csv" and Path(src).read_text() == "b":
            raise OSError(errno.EIO, "Input/output error")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OutputError, match="Input/output error"):
        write_files({tmp_path / "a.csv": _text("a"), tmp_path / "b.csv": _text("b")},
                    overwrite=True, replaces=[tmp_path / "old.png"])
    monkeypatch.setattr(os, "replace", real)
    assert tmp_path / "a.csv" in moves  # a.csv had been moved in before b.csv failed
    assert _listing(tmp_path) == ["a.csv", "b.csv", "old.png"]
    for name in ("a.csv", "b.csv", "old.png"):
        assert (tmp_path / name).read_text() == f"earlier {name}"


def test_a_folder_in_the_way_is_an_error_even_with_overwrite(tmp_path):
    (tmp_path / "a.csv").mkdir()
    with pytest.raises(OutputError) as e:
        refuse_existing([tmp_path / "a.csv"], overwrite=True)
    assert e.value.errno == errno.EISDIR and e.value.filename == str(tmp_path / "a.csv")
    with pytest.raises(OutputError):
        write_files({tmp_path / "b.csv": _text("b"), tmp_path / "a.csv": _text("a")},
                    overwrite=True)
    assert _listing(tmp_path) == ["a.csv"] and not any((tmp_path / "a.csv").iterdir())


def test_an_output_folder_that_is_a_file_is_an_output_error(tmp_path):
    (tmp_path / "out").write_text("a file")
    with pytest.raises(OutputError) as e:
        write_files({tmp_path / "out" / "a.csv": _text("a")})
    assert e.value.filename == str(tmp_path / "out" / "a.csv")
    assert (tmp_path / "out").read_text() == "a file"


# --------------------------------------------------------------------------- lsc.plots.save_all
@pytest.fixture(scope="module")
def result():
    import lsc
    from lsc import data
    return lsc.solve(data.load("default"))


def test_save_all_refuses_an_earlier_run_unless_overwrite(result, tmp_path):
    pytest.importorskip("matplotlib")
    from lsc import plots
    files = plots.save_all(result, tmp_path)
    before = {f: f.read_bytes() for f in files}
    (tmp_path / "ifd.png").write_bytes(b"earlier")
    with pytest.raises(OutputExistsError) as e:
        plots.save_all(result, tmp_path)
    assert set(e.value.paths) == set(files)
    assert (tmp_path / "ifd.png").read_bytes() == b"earlier"
    assert plots.save_all(result, tmp_path, overwrite=True) == files
    assert {f: f.read_bytes() for f in files}[tmp_path / "ifd.png"] == before[tmp_path / "ifd.png"]
    assert _listing(tmp_path) == sorted(plots.FILES)


def test_save_all_writes_all_three_figures_or_none(result, tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    from lsc import plots

    def broken(result, ax=None):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(plots, "ifd_loop", broken)
    with pytest.raises(OutputError) as e:
        plots.save_all(result, tmp_path / "figs")
    assert e.value.filename == str(tmp_path / "figs" / "ifd.png")
    assert _listing(tmp_path) == []


def test_python_writers_refuse_an_existing_file_unless_overwrite(tmp_path):
    """The Python API's file writers (SweepResult.to_csv, plots.sweep_metric/tornado(file=),
    Comparison.to_csv/to_json, FitResult.to_json/to_toml) used to write over an existing file
    without a word: now they refuse it, leaving it untouched, unless ``overwrite=True``."""
    import lsc
    from lsc import data, plots
    from lsc.analysis import compare, read_channels
    from lsc.outputs import OutputExistsError

    s = lsc.sweep(data.load("default"), {"vehicles.0.speed": [4.0, 6.0]})
    test = read_channels(data.path("default").parent / "synthetic_test.csv")
    comparison = compare(lsc.solve(data.load("default")), test)
    writers = {
        "sweep.csv": lambda p, **kw: s.to_csv(p, **kw),
        "sweep.png": lambda p, **kw: plots.sweep_metric(s, file=p, **kw),
        "comparison.csv": lambda p, **kw: comparison.to_csv(p, **kw),
        "comparison.json": lambda p, **kw: comparison.to_json(p, **kw),
    }
    for name, write in writers.items():
        path = tmp_path / name
        path.write_bytes(b"earlier")
        with pytest.raises(OutputExistsError):
            write(path)
        assert path.read_bytes() == b"earlier", name
        assert write(path, overwrite=True) == path and path.read_bytes() != b"earlier", name


def test_fit_writers_refuse_an_existing_file_unless_overwrite(tmp_path):
    """FitResult.to_json and to_toml (the fitted scene) refuse an existing file too."""
    import lsc
    from lsc import data
    from lsc.analysis import fit, read_channels
    from lsc.outputs import OutputExistsError

    test = read_channels(data.path("default").parent / "synthetic_test.csv")
    result = fit(data.load("default"), test, ["contacts.0.unloading.restitution"])
    for name, write in {"fit.json": result.to_json, "fitted.toml": result.to_toml}.items():
        path = tmp_path / name
        path.write_bytes(b"earlier")
        with pytest.raises(OutputExistsError):
            write(path)
        assert path.read_bytes() == b"earlier"
        write(path, overwrite=True)
        assert path.read_bytes() != b"earlier"
    assert lsc.Scene.load(tmp_path / "fitted.toml").name == result.scene.name
