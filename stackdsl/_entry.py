"""The ``stackdsl`` console script: :func:`stackdsl.cli.main.main`, loaded with Ctrl-C held back.

The command's modules pull in numpy, scipy, pybullet and shapely, which takes about 0.7 s.
A KeyboardInterrupt raised in the middle of that import breaks it in ways no handler can
catch cleanly (a C extension's initialisation reports it as an ImportError; the
interpreter may end by the signal after the message), so Ctrl-C is only noted while the
modules load, and ends the command as it does later: "stackdsl: interrupted", exit 130.
``stackdsl --version`` alone is answered before any of them loads.
Source: stackdsl's own.
"""

from __future__ import annotations

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
        from .cli.main import main as run
    finally:
        signal.signal(signal.SIGINT, previous)
    if pressed:
        print("stackdsl: interrupted", file=sys.stderr)
        return INTERRUPTED
    return run()
