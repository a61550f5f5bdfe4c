"""Fan-out: many independent runs shared between this process and a pool of workers.

Starting a worker is not free: a spawned process imports pybullet, numpy, scipy, shapely and
pydantic before it can run anything (about 0.5 s of CPU on the machine this was measured
on, longer when the cores are busy). So:

- when the estimated work (:func:`estimate`) is below :data:`STARTUP`, or one job is asked
  for, every run happens in this process, in the order given;
- otherwise ``jobs - 1`` worker processes are started and this process works too: it runs
  the cheapest runs left while the workers, as each one reports itself ready, are handed
  the longest ones. No run waits on a worker that is still starting, so a parallel check
  costs at most the CPU the workers' start-up takes from this one.

Results come back as each run finishes. Closing the iterator early (or an exception in
this process) cancels what has not started and stops the workers.

Source: stackdsl's own.
"""

from __future__ import annotations

import importlib
import multiprocessing
import os
import signal
from collections import deque
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, as_completed, wait
from typing import Any, TypeVar

from ._program import Launch, Program

T = TypeVar("T")

#: Seconds of estimated work below which no worker process is started.
STARTUP = 1.0

#: Wall seconds per brick of an extension-mode run (the extension skips the steps in
#: which every brick is frozen, so its cost follows the bricks, not the steps).
EXTENSION_PER_BRICK = 4e-3
#: Wall seconds per physics step of an extension-mode run.
EXTENSION_PER_STEP = 2e-6
#: Wall seconds per step, brick and solver iteration of a raw or tuned run.
ENGINE_PER_ITERATION = 1.2e-7


def estimate(program: Program) -> float:
    """A rough guess of a run's wall time in seconds, from the Program alone.

    Raw and tuned runs step every body every step: steps x bricks x solver iterations.
    Extension runs skip the steps in which everything is frozen: bricks, plus a little per
    step. The constants were fitted on the shipped scenarios (``scenarios/``) on a 2-core
    machine; a guess good to a factor of a few, used to order runs (longest first) and to
    decide whether workers are worth starting. Source: stackdsl's own.
    """
    bricks = len(program.placements) + len(program.fixtures) + sum(isinstance(a, Launch) for a in program.actions)
    steps = program.duration / program.engine.timestep
    if program.engine.mode == "extension":
        return bricks * EXTENSION_PER_BRICK + steps * EXTENSION_PER_STEP
    return steps * bricks * program.engine.solver_iterations * ENGINE_PER_ITERATION


def fan_out(fn: Callable[..., T], tasks: Sequence[tuple], costs: Sequence[float], jobs: int) -> Generator[T, None, None]:
    """``fn(*task)`` for every task, yielded as each finishes.

    Args:
        fn: a module-level function (it is pickled to the workers), as are the tasks.
        costs: one estimate per task (seconds, see :func:`estimate`).
        jobs: runs at the same time, this process included (>= 1).

    Raises:
        whatever ``fn`` raises, when its result is reached; concurrent.futures'
        BrokenProcessPool when a worker dies.
    """
    if jobs < 1:
        raise ValueError(f"jobs must be at least 1, not {jobs}")
    workers = min(jobs, len(tasks)) - 1
    if workers < 1 or sum(costs) < STARTUP:
        for task in tasks:
            yield fn(*task)
        return
    by_cost = sorted(range(len(tasks)), key=lambda i: -costs[i])
    pending = deque(tasks[i] for i in by_cost)  # longest first
    pool = Workers(workers)
    try:
        running: set[Future] = set()
        while pending or running:
            pool.poll()
            done = {f for f in running if f.done()}
            running -= done
            for f in done:
                yield f.result()
            while pending and len(running) < pool.ready:
                running.add(pool.submit(fn, *pending.popleft()))
            if pending:
                yield fn(*pending.pop())  # the cheapest, here
            elif running:
                wait(running, return_when=FIRST_COMPLETED)
    finally:
        pool.stop()


def on_executor(executor: Executor, fn: Callable[..., T], tasks: Sequence[tuple]) -> Generator[T, None, None]:
    """``fn(*task)`` for every task on a caller's executor, yielded as each finishes;
    closing the iterator cancels what has not started."""
    futures = [executor.submit(fn, *task) for task in tasks]
    try:
        for future in as_completed(futures):
            yield future.result()
    finally:
        for future in futures:
            future.cancel()


class Workers:
    """A spawn process pool whose workers each report when they are ready to run.

    ``ready`` counts the workers that have imported stackdsl; :meth:`stop` cancels what
    is queued and terminates the workers at once (a run in progress is abandoned).
    """

    def __init__(self, count: int) -> None:
        context = multiprocessing.get_context("spawn")
        self._signals = context.SimpleQueue()
        self._pool = ProcessPoolExecutor(count, mp_context=context, initializer=_start_worker, initargs=(self._signals,))
        self.ready = 0
        for _ in range(count):  # the pool starts a process for each task that finds none idle
            self._pool.submit(os.getpid)

    def poll(self) -> None:
        """Count the workers that have become ready since the last call."""
        while not self._signals.empty():
            self._signals.get()
            self.ready += 1

    def submit(self, fn: Callable[..., T], *args: Any) -> Future:
        return self._pool.submit(fn, *args)

    def stop(self) -> None:
        terminate = getattr(self._pool, "terminate_workers", None)  # Python 3.14
        if terminate is not None:
            terminate()
        else:  # no public way before 3.14: cancel what is queued, end the processes
            processes = list((getattr(self._pool, "_processes", None) or {}).values())
            self._pool.shutdown(wait=False, cancel_futures=True)
            for process in processes:
                process.terminate()
            for process in processes:
                process.join()
        self._signals.close()


def _start_worker(signals: Any) -> None:
    """Worker initializer: Ctrl-C is the parent's to handle; import what runs use, then say so."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    importlib.import_module("stackdsl._check")
    signals.put(os.getpid())
