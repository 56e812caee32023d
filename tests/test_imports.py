"""`import lsc` loads no heavy optional dependency (DESIGN.md section 3)."""

import subprocess
import sys


def test_import_lsc_does_not_import_jax_diffrax_or_matplotlib():
    code = ("import sys, lsc; "
            "print(' '.join(m for m in ('jax', 'diffrax', 'matplotlib', 'pint') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_solving_a_scene_without_units_imports_none_of_them():
    code = ("import sys, lsc; "
            "lsc.solve({'vehicles': [{'mass': 1000, 'speed': 3}, {'mass': 1000, 'speed': 0}], "
            "'contacts': [{'loading': {'stiffness': 1e5}, 'unloading': {'restitution': 0.5}}]}, "
            "method='scipy'); "
            "print(' '.join(m for m in ('jax', 'diffrax', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
