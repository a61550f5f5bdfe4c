"""The pytest plugin's collection hint: ``pytest mine/`` collects no scenario file outside the
folders of the ``stackdsl_paths`` ini option, and the summary says how to collect them.

Source: stackdsl's own.
"""

from __future__ import annotations

import os
import re
import shlex
from itertools import islice
from pathlib import Path

import pytest

from ..verdicts.snapshot import scenario_golden_path

#: The scenario folder when a project names none in ``stackdsl_paths``.
DEFAULT_FOLDERS = ["scenarios"]


def scenario_folders(config: pytest.Config) -> list[str]:
    """The folders ``stackdsl_paths`` names (relative to the rootdir), else :data:`DEFAULT_FOLDERS`."""
    named: list[str] = config.getini("stackdsl_paths")
    return named or DEFAULT_FOLDERS


#: The suffixes of scenario files the plugin collects.
SUFFIXES = (".yaml", ".yml")
#: At most this many YAML files under a path given to pytest are read for the collection hint.
HINT_FILES = 1000


def _looks_like_scenario(path: Path) -> bool:
    """Whether a YAML file starts a stackdsl scenario: a top-level ``stackdsl:`` key in its first 4 KiB."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096).decode("utf-8", "replace")
    except OSError:
        return False
    return re.search(r"^\ufeff?stackdsl\s*:", head, flags=re.M) is not None


#: Where the collected test items are (set when collection ends), for :func:`uncollected`.
_COLLECTED = pytest.StashKey[list[Path]]()


def remember_collected(session: pytest.Session) -> None:
    """Keep where the session's test items are (the plugin's ``pytest_collection_finish``)."""
    session.config.stash[_COLLECTED] = [Path(item.path).resolve() for item in session.items]


def uncollected(config: pytest.Config, ran: list[Path] | None = None) -> list[tuple[str, list[Path]]]:
    """The paths given on pytest's command line (not its ``testpaths``) that gave no test item
    and hold scenario files outside the folders of ``stackdsl_paths`` (so not collected): each
    as the ``stackdsl_paths`` value that would collect it (relative to the rootdir) and the
    scenario files it holds. ``ran``: files whose tests reported (under pytest-xdist the items
    are collected by the workers, and the main process sees their reports only)."""
    if config.args_source != pytest.Config.ArgsSource.ARGS:
        return []
    roots = [(config.rootpath / p).resolve() for p in scenario_folders(config)]
    collected = [*config.stash.get(_COLLECTED, []), *(ran or [])]
    found = []
    for arg in config.args:
        path = Path(config.invocation_params.dir, arg.split("::", 1)[0]).resolve()
        if any(path.is_relative_to(root) for root in roots) or any(item.is_relative_to(path) for item in collected):
            continue
        scenarios = _scenarios_outside(path, roots)
        if scenarios:
            folder = path if path.is_dir() else path.parent
            found.append((Path(os.path.relpath(folder, config.rootpath)).as_posix(), scenarios))
    return found


def _scenarios_outside(path: Path, roots: list[Path]) -> list[Path]:
    """The scenario files at ``path`` (a file, or a folder's YAML files, at most :data:`HINT_FILES`
    of each suffix) that are not below any of the folders ``roots``."""
    if path.is_dir():
        files = [f for suffix in SUFFIXES for f in islice(path.rglob(f"*{suffix}"), HINT_FILES)]
    else:
        files = [path] if path.suffix in SUFFIXES and path.is_file() else []
    return [f for f in files if not any(f.is_relative_to(r) for r in roots) and _looks_like_scenario(f)]


def collection_hint(config: pytest.Config, ran: list[Path] | None = None) -> list[str]:
    """The lines of the hint for :func:`uncollected` paths (none: no hint): what each holds, the
    command that collects it, the ``pyproject.toml`` line that keeps it, and where their goldens
    go once that file is written when it moves them (:func:`goldens_moved`)."""
    missed = uncollected(config, ran)
    if not missed:
        return []
    configured = ", ".join(scenario_folders(config)) or "none"
    lines = [
        f"{folder}/ holds {len(files)} scenario file{'s' * (len(files) != 1)}, and pytest collects them only below "
        f"stackdsl_paths (now: {configured})"
        for folder, files in missed
    ]
    everything = ", ".join(f'"{folder}"' for folder, _ in missed)
    if len(missed) == 1:  # the arguments as given: the command runs from the folder pytest ran in
        lines.append(f"run: {shlex.join(['pytest', *config.args, '-o', f'stackdsl_paths={missed[0][0]}'])}")
    here = Path(config.invocation_params.dir).resolve()
    if config.rootpath.resolve() != here:  # a value relative to the working folder would miss
        lines.append(f"(stackdsl_paths are relative to the rootdir {config.rootpath}, not to the folder pytest ran in)")
    pyproject = config.rootpath / "pyproject.toml"
    shown = os.path.relpath(pyproject, here)
    lines.append(f"for good, in {shown}: [tool.pytest.ini_options] stackdsl_paths = [{everything}]")
    moved = goldens_moved(config.rootpath, [f for _, files in missed for f in files])
    if moved:
        (old, new), written = moved[0], [m for m in moved if m[0].is_file()]
        lines.append(
            f"a new {shown} also moves where their goldens go (golden/ beside the nearest pyproject.toml above a "
            f"file, else beside the file): {os.path.relpath(old, here)} -> {os.path.relpath(new, here)}"
            + (", ..." if len(moved) > 1 else "")
            + (
                f"; move the {len(written)} golden{'s' * (len(written) != 1)} written so far (each item names its own)"
                if written
                else ""
            )
        )
    return lines


def goldens_moved(root: Path, files: list[Path]) -> list[tuple[Path, Path]]:
    """The scenario files among ``files`` whose golden a ``pyproject.toml`` written in the folder
    ``root`` would move: each as (where its golden is now, where it would be)."""
    moved = []
    for file in files:
        old, new = scenario_golden_path(file), scenario_golden_path(file, project=root)
        if old != new:
            moved.append((old, new))
    return sorted(moved)
