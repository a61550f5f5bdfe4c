"""Worker processes guarded from birth.

Every stackdsl worker (:mod:`stackdsl.batch.pool`'s and the ones :data:`SPAWN` starts for others,
such as ``stackdsl bench``'s pool) is guarded from its first instruction on:

- it ends with this process: on Linux, for a worker started from the main thread, the
  kernel kills it when its parent dies, whatever the parent died of, SIGKILL included
  (``prctl(PR_SET_PDEATHSIG)``); otherwise a thread polls the parent's id once a second
  (the kernel's signal follows the starting *thread*: a pool's worker started by the pool's
  own thread would be killed when that thread ends, maybe holding the pool's queue lock);
- it never sees Ctrl-C (SIGINT is blocked while it is started and ignored in it): the
  terminal's Ctrl-C is this process's to handle, and it stops the workers;
- its address space is limited to :data:`MEMORY_LIMIT` (``RLIMIT_AS``), so that a run that
  grows without bound fails alone (a MemoryError, or the worker dies) instead of the
  machine swapping.

Source: stackdsl's own.
"""

from __future__ import annotations

import ctypes
import multiprocessing.context
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

#: Wall seconds a scenario may run before it is stopped (``--timeout``): generous, about 25
#: times the slowest shipped scenario in raw mode, and short enough that a careless scene (a
#: 40-level tower in tuned mode, about 5 minutes) ends with a verdict within two minutes.
TIMEOUT = 100.0
#: Bytes of address space a worker may map (``RLIMIT_AS``): 4 GiB, about ten times what a
#: worker maps after running a 30-level tower (about 0.4 GiB, most of it the libraries).
#: A worker that had already mapped more than a quarter of it at start (many cores' worth
#: of math-library threads) gets that much plus 3 GiB instead.
MEMORY_LIMIT = 4 * 2**30

#: Linux's prctl option that sends a signal to a process when its parent dies.
PR_SET_PDEATHSIG = 1


@contextmanager
def interrupts_blocked() -> Iterator[None]:
    """Hold Ctrl-C off the processes started in the ``with`` block until they ignore it
    themselves: in the main thread SIGINT is ignored for the block (a new program keeps an
    ignored signal ignored, and CPython then installs no KeyboardInterrupt handler for it);
    in any thread it is blocked in the calling thread (a spawned child does not keep a blocked
    mask: its ``SigBlk`` in /proc is empty, and a Ctrl-C 0.2 s into ``stackdsl check`` stopped a
    worker loading its modules with a "Fatal Python error" and a traceback). A Ctrl-C that
    comes within the block itself, a few milliseconds, is lost. Source: stackdsl's own."""
    ignored = None
    if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is not None:
        ignored = signal.signal(signal.SIGINT, signal.SIG_IGN)
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT}) if hasattr(signal, "pthread_sigmask") else None
    try:
        yield
    finally:
        if previous is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)
        if ignored is not None:
            signal.signal(signal.SIGINT, ignored)


class GuardedProcess(multiprocessing.context.SpawnProcess):
    """A spawned process that ends with its parent, ignores Ctrl-C and has its address
    space limited to ``memory_limit`` bytes (class default :data:`MEMORY_LIMIT`; None: no
    limit). See the module's description."""

    memory_limit: int | None = MEMORY_LIMIT
    parent: int | None = None
    from_main_thread = True

    def start(self) -> None:
        self.parent = os.getpid()
        self.from_main_thread = threading.current_thread() is threading.main_thread()
        with interrupts_blocked():
            super().start()

    def run(self) -> None:
        guard_worker(self.parent, self.memory_limit, self.from_main_thread)
        try:
            super().run()
        except Exception as exc:  # one line, as the command's own internal errors (traceback: --debug)
            if os.environ.get("STACKDSL_TRACEBACK", "") not in ("", "0"):
                raise
            message = (str(exc).splitlines() or [""])[0]
            hint = "(run with --debug for the traceback)"
            print(f"stackdsl: internal error in a worker: {type(exc).__name__}: {message} {hint}", file=sys.stderr, flush=True)
            sys.exit(1)


class GuardedContext(multiprocessing.context.SpawnContext):
    """The spawn context whose processes (and so whose pools' workers) are
    :class:`GuardedProcess` es."""

    Process = GuardedProcess


#: The multiprocessing context every stackdsl worker is started from.
SPAWN = GuardedContext()


def guard_worker(parent: int | None, memory_limit: int | None, from_main_thread: bool = True) -> None:
    """In a worker: ignore Ctrl-C, end with ``parent`` (a process id), limit the address
    space to ``memory_limit`` bytes (see :data:`MEMORY_LIMIT`); ``from_main_thread``: the
    worker was started by the parent's main thread (so the kernel may watch the parent)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if parent is not None:
        _end_with_parent(parent, from_main_thread)
    if memory_limit is not None:
        _limit_memory(memory_limit)


def _end_with_parent(parent: int, from_main_thread: bool) -> None:
    watched = False
    if sys.platform.startswith("linux") and from_main_thread:
        try:
            watched = ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0
        except (OSError, AttributeError):
            watched = False
    if os.getppid() != parent:  # the parent died before the watch began
        os._exit(1)
    if not watched:
        threading.Thread(target=_watch_parent, args=(parent,), name="stackdsl-parent-watch", daemon=True).start()


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(1)


def limit_memory(limit: int = MEMORY_LIMIT) -> None:
    """Limit this process's address space to ``limit`` bytes (``RLIMIT_AS``; raised to what is
    already mapped plus 3 GiB when that is more), so that a request that grows without bound
    ends in a MemoryError instead of the machine swapping. Nothing happens where the limit
    cannot be set. Source: stackdsl's own."""
    _limit_memory(limit)


def _limit_memory(limit: int) -> None:
    try:
        import resource
    except ImportError:  # pragma: no cover (Windows)
        return
    mapped = _mapped_bytes()
    if mapped > limit // 4:
        limit = mapped + 3 * 2**30
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    soft = limit if hard == resource.RLIM_INFINITY else min(limit, hard)
    try:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    except (ValueError, OSError):
        pass


def _mapped_bytes() -> int:
    """This process's address space in bytes (``VmSize``), 0 where /proc is missing."""
    try:
        with open(f"/proc/{os.getpid()}/status") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0
