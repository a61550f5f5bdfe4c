"""Argument types and exit statuses of the ``stackdsl`` command. Each type turns one option's
text into a value or raises ``argparse.ArgumentTypeError`` (argparse then exits 2 with the
message).

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import re
import tempfile
from pathlib import Path

from ..lang.errors import one_line

#: The lines of the exit status that every command shares: bad input, bugs, signals.
_OTHER_STATUSES = """\
  2    bad input: a scenario file, a path or an option (nothing is simulated then), or a path
       the system refused (full disk, name too long, not a folder, no permission)
  3    internal error: a bug, out of memory, a worker died (one line; --debug shows the traceback)
  130  interrupted (Ctrl-C)
  141  the output pipe was closed early (as by | head); nothing more is printed"""


def exit_status(zero: str, one: str | None) -> str:
    """The ``exit status:`` epilog of a command: what 0 means for it, what 1 means (``one``, its
    lines wrapped and indented as they print; None: the command never exits 1), then the statuses
    every command shares. Each command's words are its own, not another's text edited: an edit
    that no longer matches leaves the other's words in place, unseen."""
    ones = f"  1    {one}\n" if one is not None else ""
    return f"exit status:\n  0    {zero}\n{ones}{_OTHER_STATUSES}"


EXIT_STATUS = exit_status(
    "every expectation held",
    "an expectation failed, a run ended undecided (INCONCLUSIVE: a brick still moved at its end;\n"
    "       a longer settle decides it), or a run reached its --timeout",
)
#: ``check``'s and ``compare``'s, which honour the files' skip and xfail marks and judge sweeps.
CHECK_STATUS = f"""\
exit status:
  0    every expectation held, or the run was skipped (SKIP) or failed as its file's xfail mark
       expects (XFAIL), or passed under a mark that is not strict (XPASS)
  1    an expectation failed, a run or a sweep's statistic was INCONCLUSIVE (a brick still moved
       at the run's end: a longer settle decides it; the statistic's 95% interval decided neither
       way: more samples would), a strict xfail passed, or a run reached its --timeout
{_OTHER_STATUSES}"""

#: The commands of ``stackdsl`` and each one's line in ``stackdsl --help``, in that order. Only the
#: command given is built in full, so that its modules alone load (:func:`command_of`).
COMMANDS = {
    "check": "run scenario files or folders and check their expectations",
    "compare": "run scenario files or folders in every mode and print one table",
    "compile": "print the program a scenario compiles to",
    "run": "run one scenario and print its timeline and outcome",
    "render": "draw a picture of a run: bricks coloured by state, with a scale bar",
    "animate": "make a clip of a run (GIF or MP4)",
    "graph": "plot the brick graph: rests-on edges, load shares, centres of mass against support polygons",
    "replay": "write an interactive 3D replay of a run: one HTML page (three.js, no network)",
    "view": "run a scenario live in MuJoCo's viewer, bricks coloured by state (needs a display)",
    "export": "write the bricks at one moment of a run as MuJoCo XML (MJCF) or URDF",
    "sweep": "run every sample of a scenario's sweep: per-sample files, a summary a grid cell, verdicts, plots",
    "search": "ask where it breaks: a threshold along one field, or counterexamples to the expectation",
    "bench": "speed against error: every engine setting on the same scenes (long)",
    "schema": "print the JSON Schema of scenario files (for editors)",
}


def command_of(argv: list[str]) -> str | None:
    """The command ``argv`` names: its first word that is not an option (the command's own
    options come after it), or None.

    >>> command_of(["--debug", "check", "scenarios/"]), command_of(["--version"])
    ('check', None)
    """
    return next((a for a in argv if not a.startswith("-")), None)


#: Ends the one line of an internal error.
HINT = " (run with --debug for the traceback)"

#: errno values of an OS refusing a path the user gave (exit 2, not a bug): no space, quota,
#: name too long, not a folder, a folder, no permission, read-only, no such file, too many links.
REFUSED = frozenset(
    getattr(errno, name)
    for name in (
        "ENOSPC",
        "EDQUOT",
        "EIO",
        "ENAMETOOLONG",
        "ENOTDIR",
        "EISDIR",
        "EACCES",
        "EPERM",
        "EROFS",
        "ENOENT",
        "ELOOP",
        "EEXIST",
    )
    if hasattr(errno, name)
)


class OptionPathError(OSError):
    """An OS error on the path given to an option (an output that the system refuses, found
    before anything runs): :func:`refused` names ``option`` after the path."""

    option: str = ""


def refused(exc: OSError) -> str | None:
    """One line for an OS error on a path (``"stackdsl: /full/disk.png: No space left on device"``;
    with the option that gave the path after it, for an :class:`OptionPathError`), or None when
    it is not one the user can fix (then it is a bug). Source: stackdsl's own.

    >>> refused(OSError(errno.ENAMETOOLONG, "File name too long", "x" * 5))
    'stackdsl: xxxxx: File name too long'
    >>> given = OptionPathError(errno.ENOENT, "No such file or directory", "/proc/x")
    >>> given.option = "--out"
    >>> refused(given)
    'stackdsl: /proc/x: --out: No such file or directory'
    """
    if exc.errno not in REFUSED:
        return None
    where = one_line(str(exc.filename)) if exc.filename is not None else ""
    if where and getattr(exc, "option", ""):
        where = f"{where}: {getattr(exc, 'option', '')}"
    reason = exc.strerror or os.strerror(exc.errno or 0)
    return f"stackdsl: {where}: {reason}" if where else f"stackdsl: {reason}"


#: Exit statuses (see :data:`EXIT_STATUS`).
OK, FAILED, BAD_INPUT, INTERNAL, INTERRUPTED, BROKEN_PIPE = 0, 1, 2, 3, 130, 141


def positive_number(text: str, unit: str) -> float:
    """``text`` as a finite number above 0 of ``unit`` (``'seconds'``, ``'frames a second'``).

    Raises:
        argparse.ArgumentTypeError: anything else.
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of {unit}") from None
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"{text} is not a number of {unit} above 0")
    return value


def timeout_type(text: str) -> float:
    """``--timeout``: wall seconds, a number above 0."""
    return positive_number(text, "seconds")


def rate_type(text: str) -> float:
    """``--rate``: frames a simulated second, a number above 0."""
    return positive_number(text, "frames a second")


def fps_type(text: str) -> float:
    """``--fps``: frames a second of a clip, 1 to 120.

    Raises:
        argparse.ArgumentTypeError: anything else.
    """
    fps = positive_number(text, "frames a second")
    if not 1 <= fps <= 120:
        raise argparse.ArgumentTypeError(f"{text} is not from 1 to 120 frames a second")
    return fps


def jobs_type(text: str) -> int:
    """``-j``: ``'auto'`` (one per free core: :func:`stackdsl.batch.address.free_cores`) or a
    whole number from 1 to the number of cores.

    Raises:
        argparse.ArgumentTypeError: anything else (a usage error, exit 2).
    """
    from ..batch.address import cores as available
    from ..batch.address import free_cores

    cores = available()
    if text.strip().lower() == "auto":
        return free_cores()
    try:
        jobs = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number or 'auto'") from None
    if not 1 <= jobs <= cores:
        raise argparse.ArgumentTypeError(f"{jobs} is not from 1 to {cores} (this machine's cores) or 'auto'")
    return jobs


def perturb_type(text: str) -> int:
    """``--perturb``: a whole number of perturbed reruns a scenario, 1 to :data:`MAX_PERTURB`.

    Raises:
        argparse.ArgumentTypeError: anything else (a usage error, exit 2).
    """
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number of reruns") from None
    if not 1 <= count <= MAX_PERTURB:
        raise argparse.ArgumentTypeError(f"{count} is not from 1 to {MAX_PERTURB} reruns a scenario")
    return count


#: The most perturbed reruns ``check --perturb`` makes of each scenario.
MAX_PERTURB = 100


def at_type(text: str) -> str | float:
    """``--at``: ``collapse``, ``end`` or a number of seconds at or above 0.

    Raises:
        argparse.ArgumentTypeError: anything else (a usage error, exit 2).
    """
    word = text.strip().lower()
    if word in ("collapse", "end"):
        return word
    try:
        seconds = float(word.removesuffix("s").strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not 'collapse', 'end' or a number of seconds") from None
    if not 0 <= seconds < math.inf:
        raise argparse.ArgumentTypeError(f"{text} is not a number of seconds at or above 0")
    return seconds + 0.0  # -0 is 0


def output_folder(given: str | None, prefix: str) -> Path:
    """The folder a command writes into: ``given``, or else a new one made for this run in the
    temporary directory (``tempfile.mkdtemp``: this user's only, mode 0700, an unpredictable
    name starting ``prefix``), never a shared, predictable path another user could plant a
    symlink at. Source: stackdsl's own.

    Raises:
        OSError: the temporary directory cannot take a new folder.
    """
    return Path(given) if given else Path(tempfile.mkdtemp(prefix=prefix))


def seed_type(text: str) -> int:
    """``--seed``: a whole number, 0 or more, in the digits 0-9 (Python's ``int`` reads other
    scripts' digits too, which a file's seed may not have), at most :data:`SEED_DIGITS` of them."""
    shown = repr(text) if len(text) <= 40 else f"{text[:20]!r}... ({len(text)} characters)"
    if not re.fullmatch(r"\s*\+?[0-9]+\s*", text, flags=re.ASCII):
        raise argparse.ArgumentTypeError(f"a seed is a whole number, 0 or more, in the digits 0-9, not {shown}")
    if len(text.strip().lstrip("+").lstrip("0")) > SEED_DIGITS:
        raise argparse.ArgumentTypeError(f"a seed has at most {SEED_DIGITS} digits, not {shown}")
    return int(text)


#: Most digits of a ``--seed`` (numpy's SeedSequence takes any size; a longer one is a slip).
SEED_DIGITS = 40


def add_seed(p: argparse.ArgumentParser) -> None:
    """The ``--seed N`` of the commands that read scenarios: it replaces each file's ``seed``."""
    p.add_argument(
        "--seed",
        type=seed_type,
        metavar="N",
        help="replace the file's seed: its random draws (sample k draws from the k-th child of N) and placement error",
    )


def add_engine_overrides(p: argparse.ArgumentParser, modes: list[str], models: list[str], backends: list[str]) -> None:
    """``--mode``, ``--model`` and ``--backend``: each replaces the scenario's own (choices as given)."""
    p.add_argument("--mode", choices=modes, help="override the scenario's engine mode")
    p.add_argument("--model", choices=models, help="override the scenario's stability model")
    p.add_argument("--backend", choices=backends, help="override the scenario's engine")


def dask_address(text: str) -> str:
    """``--dask``'s type: a usage error (exit 2) for an empty or malformed address."""
    from ..batch.address import parse_address

    try:
        return parse_address(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_executor(p: argparse.ArgumentParser) -> None:
    """Where the runs of ``sweep`` and ``search`` go: ``-j N`` processes or ``--dask ADDRESS``, one of the two."""
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "-j",
        "--jobs",
        type=jobs_type,
        default="auto",
        help="processes, this one included (default: auto, one per free core: the cores less the tasks other processes run now)",
    )
    where.add_argument(
        "--dask",
        metavar="ADDRESS",
        type=dask_address,
        help="run on a Dask cluster: a scheduler's address (tcp://host:8786) or local:N (N up to the cores)",
    )
