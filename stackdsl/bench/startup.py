"""``stackdsl bench startup``: how long the command takes to start, each in a fresh process.

Three rows, each the median of ``repeats`` runs of a new interpreter (no warm import cache
in the process; the operating system's file cache is warm after the first run):
``stackdsl --version``, ``python -c "import stackdsl"`` and a one-file ``stackdsl check``
of a small shipped scenario, beside their targets.

Source: stackdsl's own.
"""

from __future__ import annotations

import importlib.util
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

#: The small scenario a one-file check runs: the shipped ``scenarios/vee_stands.yaml``'s two
#: leaning KAPLA bricks, written out when measured (an installed copy has no scenarios folder).
SMALL = "stackdsl: 1\nname: inverted V, 20 deg\nstructure: {card_house: {levels: 1, angle: 20}}\nexpect: {stands: true}\n"


@dataclass(frozen=True)
class Startup:
    """One row: what ran, its median wall time (s) over ``runs`` and the target (s)."""

    what: str
    median: float
    runs: int
    target: float


def commands(scenario: Path) -> list[tuple[str, list[str], float]]:
    """(label, argv, target in s) of each row; the command is this interpreter's ``stackdsl``."""
    here = [sys.executable, "-m", "stackdsl"]
    entry = Path(sys.executable).with_name("stackdsl")
    command = [str(entry)] if entry.exists() else here
    return [
        ("stackdsl --version", [*command, "--version"], 0.3),
        ("python -c 'import stackdsl'", [sys.executable, "-c", "import stackdsl"], 0.3),
        (f"stackdsl check {scenario.name}", [*command, "check", str(scenario), "-j", "1"], 1.0),
    ]


def measure(repeats: int = 5, scenario: Path | None = None) -> list[Startup]:
    """Each of :func:`commands`, ``repeats`` times after one untimed run; the check of
    ``scenario``, by default :data:`SMALL` written to a temporary ``vee_stands.yaml``.

    Raises:
        subprocess.CalledProcessError: a command failed (a broken install).
    """
    if scenario is None:
        with tempfile.TemporaryDirectory() as folder:
            small = Path(folder) / "vee_stands.yaml"
            small.write_text(SMALL)
            return measure(repeats, small)
    rows = []
    for what, argv, target in commands(scenario):
        subprocess.run(argv, check=True, capture_output=True)
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            subprocess.run(argv, check=True, capture_output=True)
            times.append(time.perf_counter() - start)
        rows.append(Startup(what, statistics.median(times), repeats, target))
    return rows


def format_startup(rows: list[Startup]) -> str:
    """The table: median wall time, target, met or not."""
    lines = ["| command | median wall | target | |", "|---|---:|---:|---|"]
    for r in rows:
        lines.append(f"| {r.what} | {r.median:.2f} s | {r.target:.1f} s | {'met' if r.median < r.target else 'NOT met'} |")
    return "\n".join(lines)


def bytecode_note(sources: list[Path]) -> str | None:
    """A warning when the timings include compiling stackdsl: ``PYTHONDONTWRITEBYTECODE`` is set
    (the commands inherit it) and some of ``sources`` have no compiled bytecode beside them, as
    in an editable install that has never written any; :func:`imported_sources` gives the files
    of the stackdsl and stability modules a one-file check imports. Every start then compiles
    them from source: on a 2-core machine the one-file check took 2.18 s so, 1.47 s with the
    bytecode there. None when the timings are a user's.
    """
    if not os.environ.get("PYTHONDONTWRITEBYTECODE"):
        return None
    missing = [p for p in sources if not _compiled(p)]
    if not missing:
        return None
    return (
        f"note: PYTHONDONTWRITEBYTECODE is set and {len(missing)} of the {len(sources)} modules a check imports have "
        "no up-to-date compiled bytecode: every start above compiled them; unset it and run once to time what an install costs"
    )


def imported_sources(module: ModuleType) -> list[Path]:
    """The source files of the stackdsl and stability modules imported in this process, sorted:
    ``module``'s (which the caller imported: ``stackdsl.cli.check`` for a one-file check) and
    every one imported before it or by it."""
    names = [n for n in sys.modules if n.split(".")[0] in ("stackdsl", "stability")]
    files = {Path(f) for n in names if (f := getattr(sys.modules[n], "__file__", None))}
    return sorted(files | ({Path(module.__file__)} if module.__file__ else set()))


def _compiled(source: Path) -> bool:
    """Whether ``source`` has bytecode Python would use: a cached file whose header (PEP 552:
    flags 0, then the source's modification time and size) matches it."""
    try:
        head = Path(importlib.util.cache_from_source(str(source))).read_bytes()[:16]
        stat = source.stat()
    except OSError:
        return False
    flags, mtime, size = (int.from_bytes(head[i : i + 4], "little") for i in (4, 8, 12))
    return len(head) == 16 and flags == 0 and mtime == int(stat.st_mtime) & 0xFFFFFFFF and size == stat.st_size & 0xFFFFFFFF
