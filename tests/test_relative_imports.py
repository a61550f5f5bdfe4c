"""Every relative import in the package names a module that exists, the imports inside
functions too (which run only when their function does): moving the pytest plugin into a
package of its own left two of them one level short, and only a slow test ran one."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def unresolved(source: str, package: str) -> list[tuple[int, str]]:
    """(line, module) of each relative import in ``source`` (a module of ``package``) that
    names no module."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.level:
            parts = package.split(".")
            base = parts[: len(parts) - (node.level - 1)]
            target = ".".join(base + ([node.module] if node.module else []))
            if not base or not _exists(target):
                out.append((node.lineno, target))
    return out


def _exists(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:  # a parent that is no package
        return False


def test_every_relative_import_names_a_module():
    missing = []
    for top in ("stackdsl", "stability"):
        for path in sorted((ROOT / top).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            package = ".".join(parts[:-1])
            missing += [(str(path.relative_to(ROOT)), line, target) for line, target in unresolved(path.read_text(), package)]
    assert missing == []


def test_an_import_one_level_short_is_found():
    inside = "def f():\n    from .batch.sweep import run_sweep\n"
    assert unresolved(inside, "stackdsl.pytest_plugin") == [(2, "stackdsl.pytest_plugin.batch.sweep")]
    assert unresolved(inside.replace(".batch", "..batch"), "stackdsl.pytest_plugin") == []
