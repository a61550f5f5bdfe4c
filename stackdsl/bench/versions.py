"""The engine versions a benchmark ran on, beside the ones ``constraints.txt`` was measured with.

Every ``stackdsl bench`` command that runs an engine (all but ``solve``) prints
:func:`version_line` first, so that a number in its output can be told apart from one
measured on another engine version.

Source: stackdsl's own.
"""

from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

#: The engines whose versions shape the numbers (docs/design.md, "Engine facts").
ENGINES = ("pybullet", "mujoco")
#: The repository's constraints file beside the package (absent from an installed copy, which
#: looks in the working folder: :func:`constraints_file`).
CONSTRAINTS = Path(__file__).resolve().parents[2] / "constraints.txt"


def constraints_file() -> Path:
    """The constraints file to compare with: the source checkout's (an editable install), else
    the one in the working folder (a clone installed with ``pip install .``, run from its root)."""
    return CONSTRAINTS if CONSTRAINTS.is_file() else Path.cwd() / "constraints.txt"


def installed_versions() -> dict[str, str | None]:
    """Each of :data:`ENGINES` -> its installed version, or None when it is not installed."""
    found: dict[str, str | None] = {}
    for name in ENGINES:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = None
    return found


def constrained_versions(path: Path | None = None) -> dict[str, str]:
    """The ``name==version`` lines of a constraints file, names lower-cased; {} when absent.

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = Path(d) / "c.txt"
    ...     _ = p.write_text("# engines\\npybullet==3.2.7\\nPint==0.25\\n")
    ...     constrained_versions(p)
    {'pybullet': '3.2.7', 'pint': '0.25'}
    """
    path = constraints_file() if path is None else path
    if not path.is_file():
        return {}
    pins = re.findall(r"^\s*([A-Za-z0-9_.-]+)\s*==\s*([^\s#;]+)", path.read_text(), flags=re.M)
    return {name.lower(): version for name, version in pins}


def version_line(path: Path | None = None) -> str:
    """``'engines: pybullet 3.2.7, mujoco 4.0.0 (the versions of constraints.txt)'``, or the
    differences from constraints.txt (``path``, by default :func:`constraints_file`) when
    there are any."""
    installed = installed_versions()
    pinned = constrained_versions(path)
    shown = ", ".join(f"{n} {v or 'not installed'}" for n, v in installed.items())
    if not pinned:
        return f"engines: {shown} (no constraints.txt here to compare with)"
    differ = [f"{n} {v} (measured with {pinned[n]})" for n, v in installed.items() if v and n in pinned and v != pinned[n]]
    if differ:
        return f"engines: {shown}; NOT the versions of constraints.txt: {', '.join(differ)}"
    return f"engines: {shown} (the versions of constraints.txt)"
