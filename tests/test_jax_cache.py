"""The persistent JAX compilation cache (lsc.solvers.jax_setup): where it lives, how it is turned
off, and that a second ``lsc run --method diffrax`` process loads what the first compiled."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("diffrax")

from lsc.solvers import jax_setup  # noqa: E402
from helpers import subprocess_env  # noqa: E402


@pytest.mark.parametrize("value", ["0", "", "off", " OFF "])
def test_lsc_jax_cache_turns_the_cache_off(monkeypatch, value):
    monkeypatch.setenv("LSC_JAX_CACHE", value)
    assert jax_setup.cache_dir() is None
    assert jax_setup.enable_compilation_cache() is None


def test_lsc_jax_cache_names_the_folder(monkeypatch, tmp_path):
    monkeypatch.setenv("LSC_JAX_CACHE", str(tmp_path / "here"))
    assert jax_setup.cache_dir() == tmp_path / "here"


@pytest.mark.skipif(sys.platform in ("win32", "darwin"), reason="the XDG rule is the Linux one")
def test_default_folder_is_in_the_users_cache(monkeypatch, tmp_path):
    monkeypatch.delenv("LSC_JAX_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert jax_setup.cache_dir() == tmp_path / "lsc" / "jax"


def _run_diffrax(out: Path, cache: Path) -> dict:
    env = subprocess_env(LSC_JAX_CACHE=str(cache))
    p = subprocess.run([sys.executable, "-m", "lsc", "run", "--method", "diffrax", "--no-plots",
                        "--out", str(out)], env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    return json.loads((out / "summary.json").read_text())


def test_a_second_diffrax_run_loads_the_compiled_solver_from_the_cache(tmp_path):
    cache = tmp_path / "jax-cache"
    first = _run_diffrax(tmp_path / "first", cache)
    assert any(cache.iterdir())  # the first process wrote its executables
    second = _run_diffrax(tmp_path / "second", cache)
    # what is left of the second's compile time is tracing and lowering, not XLA compilation
    assert second["stats"]["compile_time"] < 0.5 * first["stats"]["compile_time"]
    assert second["metrics"]["delta_v"] == first["metrics"]["delta_v"]  # the same solver
