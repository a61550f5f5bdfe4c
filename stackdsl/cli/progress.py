"""Lines printed as work finishes, under a live progress line on a terminal.

On a terminal (and not under CI, where ``CI=true``) a rich progress line stays at the bottom,
with the time left, and each line printed goes above it; elsewhere (a pipe, a file, a CI log,
pytest's capture) lines are printed plainly, one at a time, flushed, with no progress bar, and
a line on standard error every :data:`EVERY` seconds says how far the work is
(``sweep: 120 of 2000 done (6%), 45 s, about 12 min left``), so that a long sweep piped to a
file or run in CI does not look stuck. A ``status`` callable, asked as often, says why the
work is not moving (a Dask scheduler with no worker): its text replaces the time left.

Source: stackdsl's own, on rich.progress.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
from collections.abc import Callable, Mapping
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


#: Seconds between two progress lines on standard error when there is no live progress line
#: (``STACKDSL_PROGRESS_SECONDS`` sets it; 0 turns them off).
EVERY = 10.0


#: Seconds: the shortest and the longest wait between two progress lines that
#: ``STACKDSL_PROGRESS_SECONDS`` may set (1e-9 printed 800 lines a second; 1e10 and inf
#: overflowed the progress thread's wait, a traceback on standard error).
SHORTEST, LONGEST = 0.1, 86400.0


def progress_seconds() -> float:
    """:data:`EVERY`, or ``STACKDSL_PROGRESS_SECONDS`` when it is set (:func:`interval`)."""
    return interval(os.environ.get("STACKDSL_PROGRESS_SECONDS", ""))


def interval(text: str) -> float:
    """Seconds between two progress lines for ``text`` (``STACKDSL_PROGRESS_SECONDS``'s value):
    a number brought within :data:`SHORTEST` and :data:`LONGEST`, 0 or less for no lines;
    :data:`EVERY` when empty or not a number (nan too).

    >>> interval("inf"), interval("1e-9"), interval("0"), interval("nan"), interval("")
    (86400.0, 0.1, 0.0, 10.0, 10.0)
    """
    text = text.strip()
    try:
        every = float(text) if text else EVERY
    except ValueError:
        return EVERY
    if math.isnan(every):
        return EVERY
    return 0.0 if every <= 0.0 else min(max(every, SHORTEST), LONGEST)


def progress_text(
    description: str, done: int, total: int, elapsed: float, status: str | None = None, left: float | None = None
) -> str:
    """A progress line: ``'sweep: 120 of 2000 done (6%), 45 s, about 12 min left'`` (the time
    left ``left``, seconds, when known; else from the rate so far; none before the first item is
    done); a ``status`` (why nothing moves) in place of the time left.

    >>> progress_text("sweep", 120, 2000, 45.0)
    'sweep: 120 of 2000 done (6%), 45 s, about 12 min left'
    >>> progress_text("check", 0, 29, 10.0)
    'check: 0 of 29 done (0%), 10 s'
    >>> progress_text("sweep", 120, 2000, 45.0, "no worker connected to the scheduler: waiting")
    'sweep: 120 of 2000 done (6%), 45 s; no worker connected to the scheduler: waiting'
    >>> progress_text("compare", 1, 4, 3.0, left=100.0)
    'compare: 1 of 4 done (25%), 3 s, about 2 min left'
    """
    share = done / total if total else 1.0
    text = f"{description}: {done} of {total} done ({share:.0%}), {_duration(elapsed)}"
    if status:
        text += f"; {status}"
    elif said := time_left(done, total, elapsed, left):
        text += f", {said}"
    return text


def time_left(done: int, total: int, elapsed: float, left: float | None = None) -> str:
    """``'about 12 min left'``: ``left`` seconds when known, else from the rate of items so far;
    ``''`` before the first item is done and after the last; once ``left`` has counted down to
    nothing with items still running, ``'longer than estimated'`` (not "about 0 s left" for the
    minutes a slow last run may take).

    >>> time_left(120, 2000, 45.0), time_left(1, 4, 3.0, left=100.0), time_left(0, 4, 3.0)
    ('about 12 min left', 'about 2 min left', '')
    >>> time_left(3, 4, 30.0, left=0.0)
    'longer than estimated'
    """
    if not 0 < done < total:
        return ""
    if left is not None and left < 0.5:
        return "longer than estimated"
    return f"about {_duration(left if left is not None else elapsed * (total - done) / done)} left"


class Remaining:
    """The seconds left of runs each weighed by the compiler's estimate of its wall time,
    corrected by the runs done: the estimate of a run is scaled by how long the done runs of its
    kind (its engine and mode) took against theirs (the estimate is good to a factor of about
    two, and errs differently in each mode), and unscaled while none of its kind is done; the
    sum is divided by how many ran at once so far (their seconds over the wall time), and counts
    down from the last run done.

    Args:
        estimates: each run's estimated seconds, by a key whose items after the first name its
            kind (``(file, backend, mode)``).

    Source: stackdsl's own.

    >>> r = Remaining({("a", "pybullet", "tuned"): 10.0, ("b", "pybullet", "tuned"): 20.0, ("a", "mujoco", "tuned"): 4.0})
    >>> r.seconds(0.0) is None
    True
    >>> r.finish(("a", "pybullet", "tuned"), took=5.0, at=5.0)  # its kind runs in half its estimate
    >>> r.seconds(elapsed=5.0), r.seconds(elapsed=9.0)  # 20 s x 0.5, and 4 s as estimated; 4 s later
    (14.0, 10.0)
    """

    def __init__(self, estimates: Mapping[tuple[str, ...], float]) -> None:
        self._left = dict(estimates)
        self._kinds: dict[tuple[str, ...], tuple[float, float]] = {}  # kind -> (seconds taken, estimated)
        self._busy = 0.0
        self._at = 0.0  # seconds from the start when the last run was done

    def finish(self, key: tuple[str, ...], took: float, at: float) -> None:
        """Run ``key`` is done, ``at`` seconds from the start; it took ``took`` seconds."""
        self._at = max(self._at, at)
        estimated = self._left.pop(key, None)
        took = max(took, 0.0)
        self._busy += took
        if estimated is not None and estimated > 0:
            spent, guessed = self._kinds.get(key[1:], (0.0, 0.0))
            self._kinds[key[1:]] = (spent + took, guessed + estimated)

    def seconds(self, elapsed: float) -> float | None:
        """Seconds left, ``elapsed`` seconds after the start; None before a run is done."""
        if not self._kinds:
            return None
        total = 0.0
        for key, estimated in self._left.items():
            spent, guessed = self._kinds.get(key[1:], (1.0, 1.0))
            total += estimated * spent / guessed
        at_once = max(1.0, self._busy / self._at) if self._at > 0 else 1.0
        return max(0.0, total / at_once - max(0.0, elapsed - self._at))


def _duration(seconds: float) -> str:
    """``45 s``, ``12 min``, ``2.5 h``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class Lines:
    """A context manager that prints lines as work finishes, counting ``total`` items.

    Args:
        total: how many items the work has (for the progress line).
        description: what is going on, shown in front of the progress line.
        file: where lines go (default: standard output).
        live: show the live progress line (default: :func:`is_live` of ``file``).
        every: without the live line, seconds between two progress lines on standard error
            (default: :func:`progress_seconds`; 0: none).
        status: asked at each progress line (and every second on the live line): None while
            the work moves, else why it does not, said on the progress line. It must not
            wait (it runs on the progress thread).
        remaining: the time left of the items, each weighed by its estimate (:class:`Remaining`;
            each :meth:`advance` names the item and how long it took); None: from the rate of
            items so far, each alike.
    """

    def __init__(
        self,
        total: int,
        description: str,
        file: IO[str] | None = None,
        live: bool | None = None,
        every: float | None = None,
        status: Callable[[], str | None] | None = None,
        remaining: Remaining | None = None,
    ) -> None:
        self.file = file if file is not None else sys.stdout
        self.remaining = remaining
        self.live = is_live(self.file) if live is None else live
        self.total, self.description, self.done = total, description, 0
        self.every = progress_seconds() if every is None else every
        self.status = status
        self._started = time.monotonic()
        self._stop = threading.Event()
        self._ticker: threading.Thread | None = None
        self._progress: Progress | None = None
        self._task = None
        if self.live:  # rich only on a terminal (a pipe, a file or CI never loads it)
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                Progress,
                SpinnerColumn,
                TextColumn,
                TimeElapsedColumn,
            )

            console = Console(file=self.file, force_terminal=True, highlight=False, emoji=False, markup=False)
            self._progress = Progress(
                SpinnerColumn(),
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.fields[count]}"),
                TimeElapsedColumn(),
                TextColumn("{task.fields[left]}"),
                console=console,
                transient=True,
            )
            self._task = self._progress.add_task(description, total=total, count=f"0/{total}", left="")

    def __enter__(self) -> Lines:
        self._started = time.monotonic()
        if self._progress is not None:
            self._progress.start()
            self._ticker = threading.Thread(target=self._tick_live, name="stackdsl-progress", daemon=True)
            self._ticker.start()
        elif self.every > 0 and self.total > 0:
            self._ticker = threading.Thread(target=self._tick, name="stackdsl-progress", daemon=True)
            self._ticker.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None) -> None:
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
        if self._progress is not None:
            self._progress.stop()

    def _tick(self) -> None:
        """Every :attr:`every` seconds until the work ends, a progress line on standard error."""
        while not self._stop.wait(self.every):
            status = self.status() if self.status is not None else None
            elapsed = time.monotonic() - self._started
            text = progress_text(self.description, self.done, self.total, elapsed, status, self._left(elapsed))
            try:
                print(text, file=sys.stderr, flush=True)
            except (OSError, ValueError):  # standard error closed: nothing more to say
                return

    def _tick_live(self) -> None:
        """Every second until the work ends, the status in the live line's description, and the
        time left (:func:`time_left`, the same as the plain lines say)."""
        while not self._stop.wait(1.0):
            self._show()

    def _show(self) -> None:
        """The live line's status, count and time left, now."""
        if self._progress is None or self._task is None:
            return
        status = self.status() if self.status is not None else None
        self._progress.update(
            self._task,
            description=f"{self.description} ({status})" if status else self.description,
            count=f"{self.done}/{self.total}",
            left=time_left(self.done, self.total, time.monotonic() - self._started, self._left()),
        )

    def _left(self, elapsed: float | None = None) -> float | None:
        """Seconds left by :attr:`remaining`, or None (then the rate of items says it)."""
        if self.remaining is None:
            return None
        return self.remaining.seconds(time.monotonic() - self._started if elapsed is None else elapsed)

    def line(self, text: str) -> None:
        """Print ``text`` (above the progress line when live)."""
        if self._progress is not None:
            self._progress.console.print(text, soft_wrap=True)
        else:
            print(text, file=self.file, flush=True)

    def advance(self, items: int = 1, key: tuple[str, ...] | None = None, took: float = 0.0) -> None:
        """Count ``items`` more as done; ``key``: the item of :attr:`remaining` done, which took
        ``took`` seconds."""
        self.done += items
        if self.remaining is not None and key is not None:
            self.remaining.finish(key, took, time.monotonic() - self._started)
        if self._progress is not None and self._task is not None:
            self._progress.advance(self._task, items)
            self._show()
