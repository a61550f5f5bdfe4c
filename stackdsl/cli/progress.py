"""Lines printed as work finishes, under a live progress line on a terminal.

On a terminal (and not under CI, where ``CI=true``) a rich progress line stays at the bottom
and each line printed goes above it; elsewhere (a pipe, a file, a CI log, pytest's capture)
lines are printed plainly, one at a time, flushed, with no progress bar.

Source: stackdsl's own, on rich.progress.
"""

from __future__ import annotations

import os
import sys
from types import TracebackType
from typing import IO, TYPE_CHECKING

if TYPE_CHECKING:
    from rich.progress import Progress


def is_live(stream: IO[str]) -> bool:
    """True when ``stream`` is a terminal that can show a live progress line: a tty, not
    under CI (``CI`` set to true or 1), not ``TERM=dumb``."""
    if os.environ.get("CI", "").strip().lower() in ("true", "1", "yes"):
        return False
    if os.environ.get("TERM") == "dumb":
        return False
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


class Lines:
    """A context manager that prints lines as work finishes, counting ``total`` items.

    Args:
        total: how many items the work has (for the progress line).
        description: what is going on, shown in front of the progress line.
        file: where lines go (default: standard output).
        live: show the live progress line (default: :func:`is_live` of ``file``).
    """

    def __init__(self, total: int, description: str, file: IO[str] | None = None, live: bool | None = None) -> None:
        self.file = file if file is not None else sys.stdout
        self.live = is_live(self.file) if live is None else live
        self._progress: Progress | None = None
        self._task = None
        if self.live:  # rich only on a terminal (a pipe, a file or CI never loads it)
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

            console = Console(file=self.file, force_terminal=True, highlight=False, emoji=False, markup=False)
            self._progress = Progress(
                SpinnerColumn(),
                TextColumn("{task.description}"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
                console=console,
                transient=True,
            )
            self._task = self._progress.add_task(description, total=total)

    def __enter__(self) -> Lines:
        if self._progress is not None:
            self._progress.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None) -> None:
        if self._progress is not None:
            self._progress.stop()

    def line(self, text: str) -> None:
        """Print ``text`` (above the progress line when live)."""
        if self._progress is not None:
            self._progress.console.print(text, soft_wrap=True)
        else:
            print(text, file=self.file, flush=True)

    def advance(self, items: int = 1) -> None:
        """Count ``items`` more as done."""
        if self._progress is not None and self._task is not None:
            self._progress.advance(self._task, items)
