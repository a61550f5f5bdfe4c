"""The ``stackdsl`` console script: :func:`stackdsl.cli.main.main`, loaded with Ctrl-C held back.

The command's modules pull in numpy, scipy, pybullet and shapely, which takes about 0.7 s.
A KeyboardInterrupt raised in the middle of that import breaks it in ways no handler can
catch cleanly (a C extension's initialisation reports it as an ImportError; the
interpreter may end by the signal after the message), so Ctrl-C is only noted while the
modules load, and ends the command as it does later: "stackdsl: interrupted", exit 130.
``stackdsl --version`` alone is answered before any of them loads.

A check of a folder or of several files that may run in parallel (``-j`` above 1, or ``auto``
with a second core free) starts its worker processes first (:func:`spare_workers`): they load
their modules on the other cores while this one loads its own, about 1 s each, instead of after
it. ``-j auto`` is decided then, once: a spare worker loading is itself a busy task.
Source: stackdsl's own.
"""

from __future__ import annotations

import os
import signal
import sys
from typing import Any

#: Exit status on Ctrl-C (as :data:`stackdsl.cli.main.INTERRUPTED`).
INTERRUPTED = 130


def main() -> int:
    """Load the command, then run it unless Ctrl-C came meanwhile; returns the exit status."""
    if sys.argv[1:] == ["--version"]:
        from ._version import version

        print(f"stackdsl {version()}")
        return 0
    pressed: list[int] = []

    def note(signum: int, frame: Any) -> None:
        pressed.append(signum)

    previous = signal.signal(signal.SIGINT, note)
    try:
        sys.argv[1:] = spare_workers(sys.argv[1:])
        from .cli.main import main as run
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed:
        print("stackdsl: interrupted", file=sys.stderr)
        return INTERRUPTED
    return run()


def spare_workers(args: list[str]) -> list[str]:
    """For ``stackdsl check`` of a folder or of two or more scenario files with more than one
    job (``-j N``, ``--jobs N``, or ``auto``, the default: one per free core), start the worker
    processes now (:func:`stackdsl.batch.pool.start_spares`); returns ``args``, with ``-j auto``
    replaced by the number it came to. The value of an option (``--report DIR``,
    :func:`stackdsl.cli.main.value_options`) is not a path. Anything else: ``args`` as given,
    nothing started."""
    words = [a for a in args if not a.startswith("-")]
    if not words or words[0] != "check":
        return args
    from .cli.main import value_options

    valued = value_options("check")
    at = args.index("check") + 1
    rest, jobs, given, paths = args[at:], "auto", None, []
    skip = False
    for i, arg in enumerate(rest):
        if skip:
            skip = False
        elif arg in ("-j", "--jobs") and i + 1 < len(rest):
            jobs, given, skip = rest[i + 1], (i, 2), True
        elif arg.startswith("--jobs="):
            jobs, given = arg[len("--jobs=") :], (i, 1)
        elif arg.startswith("-j") and len(arg) > 2:
            jobs, given = arg[2:], (i, 1)
        elif arg in valued:
            skip = True
        elif not arg.startswith("-"):
            paths.append(arg)
    if not any(os.path.isdir(p) for p in paths) and sum(p.endswith((".yaml", ".yml")) for p in paths) < 2:
        return args
    if jobs.strip().lower() == "auto":
        from .batch.address import free_cores

        count = free_cores()
        if given is not None:
            rest = rest[: given[0]] + rest[given[0] + given[1] :]
        args, jobs = [*args[:at], "--jobs", str(count), *rest], str(count)
    from .batch.address import cores

    if not jobs.strip().isdigit() or not 2 <= int(jobs) <= cores():  # more than the cores is refused later
        return args
    from .batch.pool import start_spares

    start_spares(int(jobs) - 1, load_check)
    return args


def load_check() -> None:
    """Import what a check's runs need (a spare worker's load, :func:`spare_workers`)."""
    from .batch import check_sweep  # noqa: F401
