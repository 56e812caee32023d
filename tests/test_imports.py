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


def _modules_after(code: str) -> str:
    """What a fresh interpreter prints after running ``code`` (a line of Python)."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


def test_subpackages_are_attributes_of_lsc_loaded_on_first_use():
    heavy = "' '.join(m for m in ('jax', 'diffrax', 'matplotlib') if m in sys.modules)"
    code = ("import sys, lsc; "
            "print([m in sys.modules for m in ('lsc.analysis', 'lsc.plots', 'lsc.data')]); "
            "print(sorted({'analysis', 'plots', 'data'} & set(dir(lsc)))); "
            "a, p, d = lsc.analysis, lsc.plots, lsc.data; "
            "print([m in sys.modules for m in ('lsc.analysis', 'lsc.plots', 'lsc.data')]); "
            "print(a.fit.__module__.startswith('lsc.analysis'), callable(p.figure_writers), "
            "'default' in d.names()); "
            f"print(repr({heavy}))")
    before, listed, after, usable, heavy_loaded = _modules_after(code).splitlines()
    assert before == "[False, False, False]"
    assert listed == "['analysis', 'data', 'plots']"
    assert after == "[True, True, True]"
    assert usable == "True True True"
    assert heavy_loaded == "''"


def test_an_unknown_attribute_of_lsc_is_an_attribute_error():
    out = _modules_after("import lsc\ntry:\n    lsc.analyses\nexcept AttributeError as e:\n"
                         "    print(e)")
    assert out == "module 'lsc' has no attribute 'analyses'"
