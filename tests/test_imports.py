"""`import lsc` loads no heavy optional dependency (DESIGN.md section 3)."""

import ast
import subprocess
import sys
from pathlib import Path


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


def test_the_diffrax_declaration_imports_no_scipy_integrator():
    """Reading the diffrax backend's declaration (what ``auto`` and a sweep's keyword check do)
    loads neither JAX nor SciPy's integrators: the integrators' feature set is declared apart
    from the SciPy backend (it cost a diffrax sweep ~40 MB and a cold sweep ~0.8 s)."""
    code = ("import sys, lsc.solvers as s; d = s.backend('diffrax'); "
            "assert {'law:brach', 'effect:brake', 'effect:post-failure'} <= d.solves; "
            "print(' '.join(m for m in ('jax', 'scipy.integrate') if m in sys.modules))")
    assert _modules_after(code) == ""


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


# --------------------------------------------------------------------------- import circles
PACKAGE = Path(__file__).resolve().parents[1] / "lsc"


def _modules() -> dict[str, tuple[Path, bool]]:
    """Every module of lsc/: dotted name -> (file, is a package's ``__init__``)."""
    out = {}
    for file in PACKAGE.rglob("*.py"):
        parts = list(file.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_package else parts)] = (file, is_package)
    return out


def _runs_on_import(tree: ast.Module) -> list[ast.stmt]:
    """The statements of a module that run when it is imported: its top level, ``if``/``try``/
    ``with`` blocks and class bodies, not function bodies nor ``if TYPE_CHECKING:`` blocks."""
    todo, out = list(tree.body), []
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            todo.extend(node.orelse)
            continue
        out.append(node)
        for field in ("body", "orelse", "finalbody", "handlers"):
            todo.extend(getattr(node, field, None) or [])
    return out


def _imported(node, module: str, is_package: bool, modules) -> set[str]:
    """The lsc modules an ``import`` / ``from ... import`` statement names (a package's
    ``__init__`` only where a name is taken from it: Python imports the parents of a module
    first, and a parent part-way through its own import is no circle)."""
    if isinstance(node, ast.Import):
        return {a.name for a in node.names if a.name in modules}
    if not isinstance(node, ast.ImportFrom):
        return set()
    base = module.split(".")[: len(module.split(".")) - (not is_package) - max(node.level - 1, 0)]
    target = node.module if node.level == 0 else ".".join(base + ([node.module] if node.module
                                                                   else []))
    named = {f"{target}.{a.name}" if f"{target}.{a.name}" in modules else target
             for a in node.names}  # a submodule, or a name defined in the module ``target``
    return named & set(modules)


def import_graph(function_level: bool = False) -> dict[str, set[str]]:
    """lsc module -> the lsc modules it imports when it is imported (``function_level``: or
    anywhere in it, function bodies included)."""
    modules = _modules()
    graph = {}
    for name, (file, is_package) in modules.items():
        tree = ast.parse(file.read_text(encoding="utf-8"))
        nodes = ast.walk(tree) if function_level else _runs_on_import(tree)
        graph[name] = set().union(*(_imported(n, name, is_package, modules) for n in nodes)) - {name}
    return graph


def import_circles(graph) -> list[set[str]]:
    """The strongly connected components of ``graph`` with more than one module (each holds
    an import circle)."""
    index, low, stack, circles = {}, {}, [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while not component or v not in component:
                component.add(stack.pop())
            if len(component) > 1:
                circles.append(component)

    for v in graph:
        if v not in index:
            visit(v)
    return circles


def test_the_import_graph_walker_finds_a_circle():
    assert import_circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [{"a", "b", "c"}]
    assert import_graph()["lsc"] >= {"lsc.api", "lsc.errors", "lsc.sweep"}


def test_no_module_of_lsc_imports_itself_back_at_import_time():
    assert import_circles(import_graph()) == []


def test_the_command_line_modules_are_in_no_import_circle_even_through_function_imports():
    cli = {"lsc.cli", "lsc.cli_common", "lsc.analysis.cli"}
    assert [c for c in import_circles(import_graph(function_level=True)) if c & cli] == []
