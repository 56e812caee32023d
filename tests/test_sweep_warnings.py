"""A study keeps every member's warnings, those its own ``lsc.solve`` gives, whatever path
solved it (lsc.sweep, lsc.chunks, lsc.solvers.base.Backend.solve_batch). Before, a study
dropped them: near-plastic Hunt–Crossley members reported durations that rounding decided, and
chains whose pairs locked, without a word."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import lsc
from lsc.laws.damping_tails import member_tails
from test_exact_chain_locks import _pushed
from test_fd_step_floor import _scene as hunt_crossley


def _single(scene: dict, path: str, value: float, method: str):
    return lsc.solve(lsc.Scene.load(scene).with_values({path: value}), method=method)


def test_a_batch_member_solved_alone_keeps_its_single_solve_s_warnings():
    """The exact-chain batch hands the members whose pairs may lock (e < 0.05) to the single
    solve, which locks and says so: the sweep's member says it too; the others, none."""
    path, e = "contacts.1.unloading.restitution", [0.1, 0.03, 0.0]
    s = lsc.sweep(_pushed(2e5, 0.1), {path: np.array(e)}, method="exact-chain", progress=False)
    assert s.method == "exact-chain" and list(s.status) == ["ok"] * 3
    for j, value in enumerate(e):
        assert s.warnings[j] == _single(_pushed(2e5, 0.1), path, value, "exact-chain").warnings
    assert s.warnings[0] == ()
    assert "a pressed pair locked" in s.warnings[1][0]
    assert s.stats["warned"] == 2


def test_a_member_solved_one_by_one_keeps_its_warnings():
    """Hunt–Crossley at e = 0.001 (SciPy, one by one): its rebound ended on its damping factor,
    as its own solve says; at e = 0.2 nothing is said."""
    path, e = "contacts.0.restitution", [0.001, 0.2]
    s = lsc.sweep(hunt_crossley(0.2), {path: np.array(e)}, method="scipy", progress=False)
    for j, value in enumerate(e):
        assert s.warnings[j] == _single(hunt_crossley(0.2), path, value, "scipy").warnings
    assert "damping factor (1 + α dD/dt)" in s.warnings[0][0] and s.warnings[1] == ()
    assert s.stats["warned"] == 1


@pytest.mark.parametrize("law", ["hunt-crossley", "brach"])
def test_member_tails_are_the_result_s_damping_tail_warnings(law):
    """What a batch path's members get from their metrics is what the single solve says, word
    for word (every warning of these solves is a damping tail's), member by member."""
    scenes = [hunt_crossley(e) for e in (0.001, 0.02, 0.3, 0.9)]
    for sc in scenes:
        sc["contacts"][0]["law"] = law
        if law == "brach":
            sc["contacts"][0].pop("exponent")
    results = [lsc.solve(sc, method="scipy") for sc in scenes]
    got = member_tails(lsc.Scene.load(scenes[0]),
                       np.stack([r.max_deformation for r in results]),
                       np.stack([r.permanent_deformation for r in results]))
    assert got == [r.warnings for r in results]
    assert got[0] and not got[-1]
    # a failed member (NaN metrics): none
    assert member_tails(lsc.Scene.load(scenes[0]), np.full((1, 1), np.nan),
                        np.full((1, 1), np.nan)) == [()]


def test_the_warnings_column_of_csv_and_dataframe(tmp_path):
    path, e = "contacts.0.restitution", [0.001, 0.2]
    s = lsc.sweep(hunt_crossley(0.2), {path: np.array(e)}, method="scipy", progress=False)
    with open(s.to_csv(tmp_path / "s.csv"), newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [row["warnings"] for row in rows] == ["\n".join(w) for w in s.warnings]
    assert rows[0]["warnings"].startswith("contact 0 (hunt-crossley)")
    df = s.to_dataframe()
    assert list(df["warnings"]) == [rows[0]["warnings"], ""]


def test_the_warnings_of_a_study_written_to_parquet(tmp_path):
    pytest.importorskip("pyarrow")
    path, e = "contacts.0.restitution", np.array([0.001, 0.2, 0.002])
    memory = lsc.sweep(hunt_crossley(0.2), {path: e}, method="scipy", progress=False)
    f = lsc.sweep(hunt_crossley(0.2), {path: e}, method="scipy", progress=False,
                  out=tmp_path / "s.parquet")
    assert list(f.warnings) == list(memory.warnings)
    assert f.stats["warned"] == memory.stats["warned"] == 2


def test_the_cli_summary_counts_the_members_with_warnings(tmp_path, capsys):
    from lsc.cli import main
    from lsc.toml_text import to_toml

    scene = tmp_path / "hc.toml"
    scene.write_text(to_toml(hunt_crossley(0.2)))
    assert main(["sweep", str(scene), "--param", "contacts.0.restitution=0.001,0.2",
                 "--method", "scipy", "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    out = capsys.readouterr().out
    assert "2 members by scipy" in out
    assert ", 1 with warnings (see the warnings column)" in out


def test_the_html_summary_lists_the_members_with_warnings():
    s = lsc.sweep(hunt_crossley(0.2), {"contacts.0.restitution": np.array([0.2, 0.001])},
                  method="scipy", progress=False)
    html = s._repr_html_()
    assert "<b>members with warnings</b>" in html
    assert "<li>member 1: contact 0 (hunt-crossley)" in html and "member 0:" not in html


def test_a_monte_carlo_summary_says_how_many_members_have_warnings():
    from lsc.analysis.uncertainty import monte_carlo

    mc = monte_carlo(hunt_crossley(0.2), {"contacts.0.restitution": {"uniform": [0.001, 0.5]}},
                     40, seed=3, method="scipy", progress=False)
    warned = [j for j, w in enumerate(mc.sweep.warnings) if w]
    assert warned and mc.sweep.stats["warned"] == len(warned)
    assert (f"{len(warned)} members with warnings (their own solves', in sweep.warnings and "
            f"the warnings column), the first: member {warned[0]}: contact 0 (hunt-crossley)"
            in mc.summary())
