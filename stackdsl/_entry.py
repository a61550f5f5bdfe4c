"""The ``stackdsl`` console script: :func:`stackdsl._cli.main`, loaded under a Ctrl-C guard.

The command's modules pull in numpy, scipy, pybullet and shapely, which takes about 0.7 s.
Ctrl-C in that time ends the command as it does later, "stackdsl: interrupted" and exit
130, not with a traceback from the import machinery. Source: stackdsl's own.
"""

from __future__ import annotations

import sys

#: Exit status on Ctrl-C (as :data:`stackdsl._cli.INTERRUPTED`).
INTERRUPTED = 130


def main() -> int:
    """Load the command and run it; returns the exit status."""
    try:
        from ._cli import main as run
    except KeyboardInterrupt:
        print("stackdsl: interrupted", file=sys.stderr)
        return INTERRUPTED
    return run()
