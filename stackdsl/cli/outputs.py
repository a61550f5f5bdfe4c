"""Where a command writes, checked before anything runs: every output option (``run --record``,
``check --junit-xml`` and ``--report``, ``sweep --out``, ``render``/``animate``/``graph``/``replay
-o``, ``export --mjcf`` and ``--urdf``) goes through :func:`check_outputs`.

An output is refused (exit 2, the option and the path named) when its path is empty; when it
is one of the command's inputs (a scenario, a golden snapshot, a trajectory), by any name; when
two outputs are the same file; when a file output is a folder or an existing file that is not
regular (a FIFO, a device: a FIFO without a reader would block the command forever, and stackdsl
replaces its outputs whole, which it cannot do to a device); when a folder output is a file, or
holds one of the files it would write as something other than a regular file; and when its
folder takes no new file (``/proc``, no permission, a name too long: found by creating a file
of that name there and removing it, said as the system says it with the option,
``stackdsl: PATH: OPTION: reason``).

Source: stackdsl's own.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..lang.errors import ScenarioError
from ..util.files import file_kind
from .args import OptionPathError


@dataclass(frozen=True)
class Output:
    """One output option as given.

    Attributes:
        option: the option's name, ``--junit-xml``.
        path: its value, as given.
        what: what is written there, for messages: ``the JUnit XML file``, ``the report``.
        folder: a folder written into (made if missing), not a file.
        inside: the files a folder output writes into it, by name.
    """

    option: str
    path: str
    what: str
    folder: bool = False
    inside: tuple[str, ...] = ()


@dataclass(frozen=True)
class Input:
    """A file the command reads (it may not exist: a golden snapshot not made yet), and what it
    is, for messages: ``the scenario being run``."""

    path: str | os.PathLike[str]
    what: str


def check_outputs(outputs: Sequence[Output], inputs: Iterable[Input] = ()) -> list[Path]:
    """Check ``outputs`` against each other and against ``inputs`` (see the module); their paths.

    Raises:
        ScenarioError: an output refused, at its path and option.
        OptionPathError: the folder of an output takes no new file (an OSError: its ``filename``
            the output's path, its ``option`` the option).
    """
    read = [i for i in inputs if os.path.lexists(i.path)]
    paths: list[Path] = []
    for n, out in enumerate(outputs):
        if not out.path.strip():
            wanted = f"the folder for {out.what}" if out.folder else f"a path for {out.what}"
            raise ScenarioError(f"the path is empty: give {wanted}", file=out.option)
        path = Path(out.path)
        for given in read if not out.folder else ():  # a folder output that is a file is refused as one below
            if same_place(path, given.path):
                raise _refused(out, f"this is {given.what}: give another file to write")
        for earlier in outputs[:n]:
            if earlier.path.strip() and any(same_place(a, b) for a in _places(out) for b in _places(earlier)):
                raise _refused(out, f"{earlier.option} writes there too: give each output its own path")
        try:
            if out.folder:
                _check_folder(out, path, read)
            else:
                _check_file(out, path)
        except OSError as exc:  # the system's own refusal of the path: said with the option that gave it
            error = OptionPathError(exc.errno, exc.strerror, exc.filename)
            error.option = out.option
            raise error from None
        paths.append(path)
    return paths


def _places(out: Output) -> list[Path]:
    """Where ``out`` writes: its path, and for a folder the files it writes in it."""
    return [Path(out.path), *(Path(out.path) / name for name in out.inside)]


def _refused(out: Output, message: str) -> ScenarioError:
    """The error refusing output ``out``: ``PATH: OPTION: message``."""
    return ScenarioError(message, file=out.path, field=out.option)


def same_place(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether paths ``a`` and ``b`` name one file, by any name (a link, a relative path, a
    hard link), whether or not it exists yet."""
    try:
        if os.path.samefile(a, b):
            return True
    except OSError:  # either is missing or unreadable
        pass
    return os.path.realpath(a) == os.path.realpath(b)


def _check_file(out: Output, path: Path) -> None:
    if path.is_dir():
        raise _refused(out, "this is a folder: give the file to write")
    if path.exists() and not path.is_file():
        raise _refused(out, f"not a regular file: {_kind(path)}; {out.what} is written only to a regular file")
    if not path.parent.is_dir():
        raise _refused(out, f"no such folder for {out.what}")
    _probe(path.parent, path.name, path)


def _check_folder(out: Output, path: Path, read: list[Input]) -> None:
    if path.exists() and not path.is_dir():
        this = "a file" if path.is_file() else _kind(path)
        raise _refused(out, f"{out.what} goes to a folder, and this is {this}")
    if not path.exists():
        above = next((p for p in path.parents if p.exists() or p.is_symlink()), Path("."))
        if not above.is_dir():
            raise _refused(out, f"cannot write {out.what} there: {above} is {'a file' if above.is_file() else _kind(above)}")
        _probe_new_folder(path)
        return
    problem = odd_files(path, out.inside)
    if problem:
        raise _refused(out, problem)
    for name in out.inside:
        for given in read:
            if same_place(path / name, given.path):
                raise _refused(out, f"{name} in it is {given.what}: give another folder to write")
    _probe(path, None, path)


def odd_files(folder: Path, names: Iterable[str]) -> str:
    """Why stackdsl cannot write the files ``names`` into ``folder``: one of them is there as a
    folder or as a file that is not regular (a FIFO, a device); ``''`` when none is."""
    for name in names:
        inside = folder / name
        if inside.is_dir():
            return f"{name} in it is a folder: remove it, or give another folder to write"
        if inside.exists() and not inside.is_file():
            return f"{name} in it is {_kind(inside)}, not a regular file: remove it, or give another folder to write"
    return ""


def _kind(path: Path) -> str:
    """What ``path``, which exists, is: ``a FIFO (named pipe)``."""
    return file_kind(path.stat().st_mode)


def _probe(folder: Path, name: str | None, shown: Path) -> None:
    """Create a file in ``folder`` (named ``name`` when no such entry is there yet: a name the
    system finds too long is found so; else a hidden name) and remove it.

    Raises:
        OSError: the folder takes no new file, with ``shown`` as its file name.
    """
    target = folder / name if name and not os.path.lexists(folder / name) else folder / f".stackdsl-{secrets.token_hex(6)}"
    try:
        fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(shown)) from None
    os.close(fd)
    os.unlink(target)


def _probe_new_folder(path: Path) -> None:
    """Make the missing folder ``path`` (with its missing parents), create a file in it, and
    remove them all again.

    Raises:
        OSError: a folder or the file cannot be made there, with ``path`` as its file name.
    """
    missing = [p for p in (path, *path.parents) if not os.path.lexists(p)]  # the deepest first
    try:
        path.mkdir(parents=True, exist_ok=True)
        _probe(path, None, path)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    finally:
        for folder in missing:
            with contextlib.suppress(OSError):
                folder.rmdir()


def check_default_golden(path: Path | None, other: str = "") -> None:
    """Refuse a golden snapshot read by default (a scenario's own, ``golden/.../NAME.json``, by
    ``replay`` and ``check --report``) that is there and is not a regular file: a FIFO would block
    its reader forever. ``other`` says what else can be done (``or give --golden``).

    Raises:
        ScenarioError: it is a folder, a FIFO, a device.
    """
    if path is not None and path.exists() and not path.is_file():
        raise ScenarioError(
            f"not a regular file: {_kind(path)}; the scenario's golden snapshot is read from here: remove it"
            + (f" {other}" if other else ""),
            file=_shown(path),
        )


def _shown(path: Path) -> str:
    """``path`` relative to the current folder when it is under it (a golden found from a scenario is absolute)."""
    relative = os.path.relpath(path)
    return str(path) if relative.startswith("..") else relative
