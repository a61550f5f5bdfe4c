"""The pytest plugin's golden files, read with care: a golden that cannot be one (a FIFO, a folder,
below a file, not UTF-8, not JSON, nested too deep) or that sits where another project layout puts
goldens is one line in the item's failure, never a traceback or a hang, and never overwritten.

Source: stackdsl's own.
"""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..verdicts.snapshot import golden_dir

#: A golden larger than this is not one stackdsl wrote (a 400-brick tower's is about 0.3 MB).
MAX_BYTES = 16 * 2**20  # as stackdsl.draw.replay.MAX_GOLDEN_BYTES: a 15 MiB one peaks at 224 MB read
#: A golden nested deeper than this is not one stackdsl wrote (a scenario's nests 5 levels).
MAX_DEPTH = 100
#: What to do with a golden whose text is not a snapshot.
REDO = "restore it, or delete it and rerun with --snapshot-update to write it anew"

Show = Callable[[Path], str]


class BadGolden(Exception):
    """A golden snapshot that cannot be read as one: its message names it and says why."""


def _kind(mode: int) -> str:
    for test, name in (
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
    ):
        if test(mode):
            return name
    return "not a regular file"


def _file_above(stored: Path) -> Path | None:
    """The nearest existing folder of ``stored`` that is not a folder (a file), or None."""
    for folder in stored.parents:
        try:
            mode = os.stat(folder).st_mode
        except (FileNotFoundError, NotADirectoryError):
            continue  # not there (yet), or below a file further up
        except OSError:
            return None  # unreadable: said when the golden itself is read
        return None if stat.S_ISDIR(mode) else folder
    return None


def read_golden_text(stored: Path, show: Show = os.path.relpath) -> str | None:
    """A golden file's text (newlines as in Python's text mode), or None when there is none yet.

    Raises:
        BadGolden: the path cannot hold a golden (a folder above it is a file; it is a folder, a
            FIFO or a device: it is never opened, so a FIFO never blocks), cannot be read, is
            larger than :data:`MAX_BYTES`, or is not UTF-8 text.
    """
    where = show(stored)
    above = _file_above(stored)
    if above is not None:
        raise BadGolden(f"{where} cannot be a golden snapshot: {show(above)} is a file, not a folder: move that file away")
    try:
        mode = os.stat(stored).st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise BadGolden(f"{where} cannot be read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise BadGolden(f"{where} is a folder, not a golden snapshot: remove it")
    if not stat.S_ISREG(mode):
        raise BadGolden(f"{where} is {_kind(mode)}, not a golden snapshot: remove it")
    try:  # never blocks, even when the file became a FIFO since
        fd = os.open(stored, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise BadGolden(f"{where} cannot be read: {exc.strerror or exc}") from None
    with open(fd, "rb") as f:
        opened = os.fstat(f.fileno())
        if not stat.S_ISREG(opened.st_mode):
            raise BadGolden(f"{where} is {_kind(opened.st_mode)}, not a golden snapshot: remove it")
        data = f.read(MAX_BYTES + 1)
    if len(data) > MAX_BYTES:
        raise BadGolden(f"{where} is not a golden snapshot: larger than {MAX_BYTES // 2**20} MiB; {REDO}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise BadGolden(
            f"{where} is not a golden snapshot: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}); {REDO}"
        ) from None
    return text.replace("\r\n", "\n").replace("\r", "\n")


def _depth(value: Any) -> int:
    """How deep a JSON value nests (a scalar: 0), without recursion."""
    deepest, todo = 0, [(value, 0)]
    while todo:
        item, depth = todo.pop()
        if isinstance(item, (dict, list)):
            deepest = max(deepest, depth + 1)
            if depth + 1 > MAX_DEPTH:
                break
            todo += [(x, depth + 1) for x in (item.values() if isinstance(item, dict) else item)]
    return deepest


def golden_problem(stored: Path, show: Show = os.path.relpath) -> str:
    """What makes ``stored`` no scenario golden snapshot, as a line naming it
    (:func:`read_golden_text`'s reasons, or its text is not JSON, nests deeper than
    :data:`MAX_DEPTH`, or is not a JSON object); ``""`` when it is one or there is none yet."""
    try:
        text = read_golden_text(stored, show)
    except BadGolden as exc:
        return str(exc)
    if text is None:
        return ""
    where = show(stored)
    try:
        data = json.loads(text)
    except RecursionError:
        return f"{where} is not a golden snapshot: JSON nested too deep (more than {MAX_DEPTH} levels); {REDO}"
    except ValueError as exc:
        said = f"line {exc.lineno}, column {exc.colno}: {exc.msg}" if isinstance(exc, json.JSONDecodeError) else str(exc)
        return f"{where} is not a golden snapshot: not JSON ({said}); {REDO}"
    if _depth(data) > MAX_DEPTH:
        return f"{where} is not a golden snapshot: JSON nested too deep (more than {MAX_DEPTH} levels); {REDO}"
    if not isinstance(data, dict):
        kind = {list: "an array", str: "a string", bool: "a boolean", type(None): "null"}.get(type(data), "a number")
        return f"{where} is not a golden snapshot: its JSON is {kind}, not an object; {REDO}"
    return ""


def golden_elsewhere(source: Path, name: str, expected: Path) -> Path | None:
    """Where a golden of ``source`` (a scenario file or a test module) is stored under another
    project layout, when none is at ``expected``: goldens go to ``golden/`` beside the nearest
    ``pyproject.toml`` (or beside the file when there is none), mirroring the file's folder from
    there, so a ``pyproject.toml`` written, moved or removed moves where they are looked for.
    Each folder above the file is tried as that project root (``name``: the golden's file or
    folder name there); None when none holds it."""
    folder = Path(source).resolve().parent
    for top in (folder, *folder.parents):
        candidate = top / "golden" / folder.relative_to(top) / name
        if candidate != expected and _exists(candidate):
            return candidate
    return None


def _exists(path: Path) -> bool:
    try:
        os.stat(path)
    except OSError:  # not there, below a file, or unreadable: no golden to point to
        return False
    return True


def where_goldens_go(source: Path, show: Show) -> str:
    """Why a file's goldens are where they are expected, in words."""
    root = golden_dir(source).parent
    if (root / "pyproject.toml").is_file():
        return f"goldens go to golden/ beside the nearest pyproject.toml above the file, {show(root / 'pyproject.toml')}"
    return "with no pyproject.toml above the file, goldens go to golden/ beside it"
