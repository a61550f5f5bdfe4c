"""No module of stackdsl/ or stability/ imports another by a string (``importlib.import_module``,
``__import__``): lint-imports and tests/test_design.py's cycle check read import statements, and an
import by string walks past both (the pool's worker imported ``stackdsl.batch.judge`` so, closing a
circle of four modules; the startup bench imported ``stackdsl.cli.check`` so, from a floor below).

The one allowed: the package's own ``__getattr__`` (PEP 562), which loads a public name's module
on first use from ``stackdsl._HOME`` (tests/test_api.py checks each name there)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ALLOWED = {("stackdsl/__init__.py", "__getattr__")}


def string_imports(source: str) -> list[tuple[int, str]]:
    """(line, the function it is in or ``<module>``) of every call of ``import_module`` or
    ``__import__``, by any name (``importlib.import_module``, ``import_module``, ``builtins.__import__``)."""
    found = []

    def visit(node: ast.AST, where: str) -> None:
        for child in ast.iter_child_nodes(node):
            inside = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) else where
            if isinstance(child, ast.Call):
                func = child.func
                name = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else ""
                if name in ("import_module", "__import__"):
                    found.append((child.lineno, where))
            visit(child, inside)

    visit(ast.parse(source), "<module>")
    return found


def test_the_scan_finds_an_import_by_string_however_it_is_written():
    source = (
        "import importlib\nfrom importlib import import_module\n"
        "def serve():\n    importlib.import_module('stackdsl.batch.judge')\n"
        "x = import_module('a.b')\ny = __import__('os')\n"
    )
    assert string_imports(source) == [(4, "serve"), (5, "<module>"), (6, "<module>")]
    assert string_imports("import importlib.util\nspec = importlib.util.find_spec('mujoco')\n") == []


def test_no_module_imports_another_by_a_string():
    found = []
    for top in ("stackdsl", "stability"):
        for path in sorted((ROOT / top).rglob("*.py")):
            name = str(path.relative_to(ROOT))
            found += [
                f"{name}:{line} in {where}" for line, where in string_imports(path.read_text()) if (name, where) not in ALLOWED
            ]
    assert found == []


def test_the_allowed_one_is_still_there():
    """An allowance for code that is gone would let a new import by string in its place pass unseen."""
    for name, where in ALLOWED:
        assert where in [w for _, w in string_imports((ROOT / name).read_text())], (name, where)
