"""Fan-out: many independent runs shared between this process and a pool of workers.

Starting a worker is not free: a spawned process imports pybullet, numpy, scipy, shapely and
pydantic before it can run anything (about 0.5 s of CPU on the machine this was measured
on, longer when the cores are busy). So:

- when the estimated work (:attr:`stackdsl.Program.wall_estimate`) is below :data:`STARTUP`, or one job is asked
  for, every run happens in this process, in the order given;
- otherwise ``jobs - 1`` worker processes are started and this process works too: it runs
  the cheapest runs left while the workers, as each one reports itself ready, are handed
  the longest ones. No run waits on a worker that is still starting, so a parallel check
  costs at most the CPU the workers' start-up takes from this one.

A command that will fan out may start its workers before it has loaded its own modules
(:func:`start_spares`, from the ``stackdsl`` console script): they then load side by side with
it, on the other cores, and the first :class:`Workers` adopts them.

Results come back as each run finishes. Closing the iterator early (or an exception in
this process) cancels what has not started and stops the workers.

Every worker is guarded from its first instruction on (:mod:`stackdsl.batch.guard`): it ends with
this process, never sees Ctrl-C and has its address space limited. Each runs one task at a
time on a pipe of its own, so a worker that dies (killed, a segmentation fault in the engine,
out of memory) loses that one task, reported as :class:`WorkerDied`, and the others go on; a
task still running ``limit`` seconds after it was handed over ends its worker and is
reported as :class:`WorkerTimedOut`. (``concurrent.futures``' pool breaks as a whole when one
worker dies; pools that share one pipe between workers can be left locked by a worker killed
while writing.)

Source: stackdsl's own.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import multiprocessing.context
import os
import signal
import time
import traceback
from collections import deque
from collections.abc import Callable, Generator, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, wait
from dataclasses import dataclass, field
from itertools import islice
from typing import Any, TypeVar

from .guard import MEMORY_LIMIT, SPAWN

T = TypeVar("T")

#: Seconds of estimated work below which no worker process is started.
STARTUP = 1.0

#: Workers started before anything asked for them (:func:`start_spares`), with the memory limit
#: each was given, for the next :class:`Workers` to adopt.
_SPARES: list[tuple[_Worker, int | None]] = []


class WorkerLost(RuntimeError):
    """A task's worker ended before it returned a result; the message is one line."""


class WorkerDied(WorkerLost):
    """A worker died running a task: ``signal`` is the signal that killed it (None when it
    exited, with ``exitcode``)."""

    def __init__(self, exitcode: int | None) -> None:
        self.exitcode = exitcode
        self.signal = -exitcode if exitcode is not None and exitcode < 0 else None
        if self.signal is not None:
            try:
                name = signal.Signals(self.signal).name
            except ValueError:
                name = "unknown"
            how = f"{name}, signal {self.signal}"
        else:
            how = f"exit status {exitcode}"
        super().__init__(f"worker died ({how})")

    def __reduce__(self) -> tuple[Any, ...]:
        return type(self), (self.exitcode,)


class WorkerTimedOut(WorkerLost):
    """A task was still running ``limit`` seconds after it was handed to its worker, which
    was stopped."""

    def __init__(self, limit: float) -> None:
        self.limit = limit
        super().__init__(f"still running after {limit:g} s, worker stopped")

    def __reduce__(self) -> tuple[Any, ...]:
        return type(self), (self.limit,)


class RemoteTraceback(Exception):
    """The traceback, as text, of an exception raised in a worker (its ``__cause__``)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def fan_out(
    fn: Callable[..., T],
    tasks: Iterable[tuple[Any, ...]],
    costs: Sequence[float] | float,
    jobs: int,
    *,
    limit: float | None = None,
    lost: Callable[[tuple[Any, ...], WorkerLost], T] | None = None,
    here: bool = True,
) -> Generator[T, None, None]:
    """``fn(*task)`` for every task, yielded as each finishes.

    Args:
        fn: a module-level function (it is pickled to the workers), as are the tasks.
        tasks: a sequence with ``costs``, or, with one cost for all, any iterable, read
            only as tasks are handed out (a generator of a million is never a list).
        costs: one estimate per task, or one for every task (seconds,
            :attr:`stackdsl.Program.wall_estimate`).
        jobs: runs at the same time, this process included (>= 1).
        limit: wall seconds a worker may spend on one task before it is stopped (None: no
            limit). Tasks run in this process are not limited here.
        lost: ``lost(task, error)`` is yielded for a task whose worker died or was stopped
            (``error`` a :class:`WorkerDied` or :class:`WorkerTimedOut`); a new worker takes
            the dead one's place while tasks remain. None: the error is raised.
        here: this process runs tasks too (``jobs - 1`` workers); False: ``jobs`` workers run
            them and this process only hands them out and collects, so that a worker that
            finishes never waits for this one to finish a task of its own (for many tasks of
            about the same size, such as a sweep's batches).

    Raises:
        ValueError: ``jobs`` below 1, or one cost a task for tasks that are not a sequence.
        whatever ``fn`` raises, when its result is reached (from a worker, with the worker's
        traceback as a :class:`RemoteTraceback` cause); :class:`WorkerLost` when a worker
        is lost and ``lost`` is None.
    """
    if jobs < 1:
        raise ValueError(f"jobs must be at least 1, not {jobs}")
    pending = _Pending(tasks, costs, enough=jobs)
    workers = min(jobs, pending.known) - (1 if here or jobs == 1 else 0)
    if workers < 1 or pending.cost < STARTUP:
        for task in pending.in_order():
            yield fn(*task)
        return
    pool = Workers(workers, warm=fn)
    try:
        running: dict[int, tuple[Any, ...]] = {}
        while pending or running:
            # this process waits for a worker unless it has a task of its own to run meanwhile
            finished = pool.collect(timeout=0 if pending and (here or pool.ready) else None)
            yield from _results(finished, running, pool, pending, lost)
            while pending and pool.ready:
                task = pending.longest()
                running[pool.submit(fn, *task, limit=limit)] = task
            if pending and here:
                yield fn(*pending.cheapest())
    finally:
        pool.stop()


def _results(
    finished: list[Done],
    running: dict[int, tuple[Any, ...]],
    pool: Workers,
    pending: _Pending,
    lost: Callable[[tuple[Any, ...], WorkerLost], T] | None,
) -> Generator[T, None, None]:
    """The result of each of the ``finished`` tasks (:meth:`Workers.collect`), each taken out of
    ``running`` (by ticket); a lost worker's task as ``lost`` says (a new worker in its place
    while ``pending`` has tasks to hand out).

    Raises:
        whatever the task raised in its worker; :class:`WorkerLost` when ``lost`` is None.
    """
    for done in finished:
        task = running.pop(done.ticket)
        if isinstance(done.error, WorkerLost):
            if pending:
                pool.add()
            if lost is None:
                raise done.error
            yield lost(task, done.error)
        else:
            yield done.value()


class _Pending:
    """The tasks not yet handed out. Tasks with a cost each are sorted, longest first; tasks of
    one cost are read from their iterable only as far as needed: enough for ``enough`` workers
    and :data:`STARTUP` seconds of work, then one at a time."""

    def __init__(self, tasks: Iterable[tuple[Any, ...]], costs: Sequence[float] | float, enough: int) -> None:
        self._given: Sequence[tuple[Any, ...]] = ()
        self._lazy = isinstance(costs, (int, float))
        if isinstance(costs, (int, float)):
            self._rest: Iterator[tuple[Any, ...]] = iter(tasks)
            self._head: deque[tuple[Any, ...]] = deque()
            for task in self._rest:
                self._head.append(task)
                if len(self._head) >= enough and len(self._head) * costs >= STARTUP:
                    break
            self.cost = len(self._head) * costs
        else:
            if not isinstance(tasks, Sequence):
                raise ValueError("a cost for each task needs the tasks as a sequence")
            order = sorted(range(len(tasks)), key=lambda i: -costs[i])
            self._head = deque(tasks[i] for i in order)
            self._rest = iter(())
            self._given = tasks
            self.cost = sum(costs)
        #: tasks known so far (all of them when they came with costs)
        self.known = len(self._head)

    def __bool__(self) -> bool:
        if not self._head:
            self._head.extend(islice(self._rest, 1))
        return bool(self._head)

    def longest(self) -> tuple[Any, ...]:
        """The next task to hand out (call only when this is true)."""
        return self._head.popleft()

    def cheapest(self) -> tuple[Any, ...]:
        """The cheapest task left, for this process to run (the next one, for tasks of one cost)."""
        return self.longest() if self._lazy else self._head.pop()

    def in_order(self) -> Iterator[tuple[Any, ...]]:
        """Every task in the order given (for a run all in this process; read only once)."""
        if not self._lazy:
            yield from self._given
            return
        yield from self._head
        yield from self._rest


def on_executor(
    executor: Executor, fn: Callable[..., T], tasks: Iterable[tuple[Any, ...]], *, window: int | None = None
) -> Generator[T, None, None]:
    """``fn(*task)`` for every task on a caller's executor, yielded as each finishes; closing
    the iterator cancels what has not started.

    ``window``: at most this many tasks submitted and not yet back; the tasks are read from
    their iterable as results come in (None: all submitted at once).
    """
    stream = iter(tasks)
    running = {executor.submit(fn, *task) for task in islice(stream, window)}
    try:
        while running:
            done, running = wait(running, return_when=FIRST_COMPLETED)
            running |= {executor.submit(fn, *task) for task in islice(stream, len(done))}
            for future in done:
                yield future.result()
    finally:
        for future in running:
            future.cancel()


@dataclass
class Done:
    """A task a worker finished: its ``ticket`` (from :meth:`Workers.submit`) and what it
    returned, or the exception it raised or the :class:`WorkerLost` that ended it."""

    ticket: int
    result: Any = None
    error: BaseException | None = None

    def value(self) -> Any:
        """The result, or raise the error."""
        if self.error is not None:
            raise self.error
        return self.result


@dataclass(eq=False)
class _Worker:
    process: multiprocessing.process.BaseProcess
    conn: multiprocessing.connection.Connection
    ready: bool = False
    ticket: int | None = None
    limit: float | None = None
    deadline: float = float("inf")
    pid: int = field(init=False)

    def __post_init__(self) -> None:
        self.pid = self.process.pid or 0


class Workers:
    """Spawned worker processes (see the module's description), each running one task at a
    time on a pipe of its own; this process is their only client and polls them.

    ``ready`` counts the workers that have imported stackdsl and have no task;
    :meth:`stop` ends them all at once (a task in progress is abandoned).

    Args:
        count: workers to start.
        memory_limit: bytes of address space per worker (None: no limit).
        warm: a module-level function each worker imports, with its module and what that
            imports, before it says it is ready, so that its first task does not pay for the
            imports (:func:`fan_out` passes the function its tasks run: a check's judge); None:
            nothing more than the pool's own.
    """

    def __init__(self, count: int, memory_limit: int | None = MEMORY_LIMIT, warm: Callable[..., Any] | None = None) -> None:
        self._memory_limit = memory_limit
        self._warm = warm
        self._workers: list[_Worker] = []
        self._tickets = 0
        self._stopped = False
        for _ in range(count):
            self.add()

    @property
    def ready(self) -> int:
        """Workers started and idle."""
        return sum(w.ready and w.ticket is None for w in self._workers)

    @property
    def busy(self) -> int:
        """Workers running a task."""
        return sum(w.ticket is not None for w in self._workers)

    @property
    def pids(self) -> list[int]:
        """The workers' process ids."""
        return [w.pid for w in self._workers]

    def add(self) -> None:
        """Start one more worker, or adopt a spare one of the same memory limit that is still
        alive (:func:`start_spares`)."""
        while _SPARES:
            spare, limit = _SPARES.pop(0)
            if limit == self._memory_limit and spare.process.exitcode is None:
                self._workers.append(spare)
                return
            _terminate([spare.process])
            spare.conn.close()
        self._workers.append(_start(self._warm, self._memory_limit))

    def submit(self, fn: Callable[..., Any], *args: Any, limit: float | None = None) -> int:
        """Hand ``fn(*args)`` to a ready worker; returns its ticket (see :meth:`collect`).

        Raises:
            RuntimeError: no worker is ready.
        """
        worker = next((w for w in self._workers if w.ready and w.ticket is None), None)
        if worker is None:
            raise RuntimeError("no worker is ready")
        self._tickets += 1
        worker.ticket, worker.limit = self._tickets, limit
        worker.deadline = time.monotonic() + limit if limit is not None else float("inf")
        try:
            worker.conn.send((fn, args))
        except (OSError, ValueError):  # it died while idle; collect() will report the task
            pass
        return self._tickets

    def run(self, fn: Callable[..., T], *args: Any, limit: float | None = None) -> T:
        """``fn(*args)`` on a worker, waiting for it to be ready and for the result."""
        while not self.ready:
            if not self._workers:
                raise WorkerLost("no worker left")
            self.collect(timeout=None)
        ticket = self.submit(fn, *args, limit=limit)
        while True:
            for done in self.collect(timeout=None):
                if done.ticket == ticket:
                    return done.value()  # type: ignore[no-any-return]

    def collect(self, timeout: float | None = 0) -> list[Done]:
        """Count the workers that have become ready and return the tasks that ended, waiting
        up to ``timeout`` seconds (None: until something happens) for either."""
        if not self._workers:
            return []
        now = time.monotonic()
        nearest = min(w.deadline for w in self._workers) - now
        wait = max(0.0, min(nearest, timeout if timeout is not None else float("inf")))
        handles: list[Any] = [w.conn for w in self._workers] + [w.process.sentinel for w in self._workers]
        ready = set(multiprocessing.connection.wait(handles, None if wait == float("inf") else wait))
        finished: list[Done] = []
        for worker in list(self._workers):
            if worker.conn in ready:
                try:
                    message = worker.conn.recv()
                except Exception:  # died while writing, or a result that cannot be read
                    self._end(worker, finished, died=True)
                    continue
                if message[0] == "ready":
                    worker.ready = True
                else:
                    ticket, worker.ticket, worker.deadline = worker.ticket, None, float("inf")
                    finished.append(Done(ticket or 0, *_unpack(message)))
            elif worker.process.sentinel in ready:
                self._end(worker, finished, died=True)
            elif worker.ticket is not None and time.monotonic() >= worker.deadline:
                self._end(worker, finished, died=False)
        return finished

    def _end(self, worker: _Worker, finished: list[Done], died: bool) -> None:
        self._workers.remove(worker)
        _terminate([worker.process])
        worker.conn.close()
        if worker.ticket is None:
            return
        if died:
            error: WorkerLost = WorkerDied(worker.process.exitcode)
        else:
            error = WorkerTimedOut(worker.limit or 0.0)
        finished.append(Done(worker.ticket, error=error))

    def stop(self) -> None:
        """End every worker now (SIGTERM, then SIGKILL for one that lingers)."""
        workers, self._workers = self._workers, []
        _terminate([w.process for w in workers])
        for w in workers:
            w.conn.close()


def start_spares(count: int, load: Callable[[], object], memory_limit: int | None = MEMORY_LIMIT) -> None:
    """Start ``count`` workers now, each calling ``load`` (a module-level function, in a module
    that imports little: it is pickled by name, and the worker imports what it needs) before it
    says it is ready, for the next :class:`Workers` to adopt in place of starting its own (the
    ``stackdsl`` console script, for a check of more than one file that may run in parallel,
    before it loads its own modules: both load at once, on two cores). Spares never adopted are
    daemons: they end with this process. Source: stackdsl's own."""
    _SPARES.extend((_start(None, memory_limit, load), memory_limit) for _ in range(count))


def _start(warm: Callable[..., Any] | None, memory_limit: int | None, load: Callable[[], object] | None = None) -> _Worker:
    """A new worker process (:func:`_serve`), guarded, warmed by ``warm`` and ``load``."""
    ours, theirs = multiprocessing.Pipe()
    process = SPAWN.Process(target=_serve, args=(theirs, warm, load), daemon=True, name="stackdsl-worker")
    process.memory_limit = memory_limit
    process.start()
    theirs.close()
    return _Worker(process, ours)


def _unpack(message: tuple[Any, ...]) -> tuple[Any, BaseException | None]:
    if message[0] == "ok":
        return message[1], None
    error, text = message[1], message[2]
    if text:
        error.__cause__ = RemoteTraceback(text)
    return None, error


def _terminate(processes: Sequence[multiprocessing.process.BaseProcess]) -> None:
    for process in processes:
        if process.exitcode is None:
            process.terminate()
    for process in processes:
        process.join(5)
        if process.exitcode is None:
            process.kill()
            process.join()


def _serve(
    conn: multiprocessing.connection.Connection,
    warm: Callable[..., Any] | None = None,
    load: Callable[[], object] | None = None,
) -> None:
    """A worker's loop: say it is ready, then run each task sent and send back ``('ok', result)``
    or ``('raised', exception, traceback text)``, until the pipe closes. ``warm`` (see
    :class:`Workers`) is not called: it came pickled by name, so its module was imported before
    this runs; ``load`` (:func:`start_spares`) is called first."""
    if load is not None:
        load()
    conn.send(("ready", os.getpid()))
    while True:
        try:
            fn, args = conn.recv()
        except (EOFError, OSError):
            return
        try:
            reply: tuple[Any, ...] = ("ok", fn(*args))
        except BaseException as exc:
            reply = ("raised", exc, traceback.format_exc())
        try:
            conn.send(reply)
        except (EOFError, OSError):
            return
        except Exception as exc:  # a result or an exception that cannot be pickled
            conn.send(("raised", RuntimeError(f"{type(exc).__name__}: {exc}"), traceback.format_exc()))
