"""The pybullet client a run simulates in: :func:`direct_client`, a DIRECT client kept from run
to run in each process.

pybullet facts this module encodes (measured with pybullet 3.2.7):

* Connecting a DIRECT client costs 8 to 13 ms; ``resetSimulation`` empties one in 1.6 to 5 ms,
  and an emptied client simulates as a new one does, bitwise. ``resetSimulation`` keeps the
  timestep and the substeps (the world sets them at every start).
* Removing the bodies one by one instead is cheaper but not bitwise: five shipped scenes ended
  otherwise after others had run.
* A client prints to the C-level stdout and stderr when it connects.
* A new client has TinyRenderer loaded (the plugin behind ``getCameraImage``), which builds a
  visual shape for every body created: with it the ground plane costs 0.55 ms to create, without
  it 0.12 ms, and a brick 90 us against 83 us. stackdsl renders nothing through pybullet, so
  :func:`direct_client` unloads it; the physics does not read it (the goldens are unchanged).
* ``BulletClient.__del__`` at the interpreter's very end may find pybullet gone.

Source: stackdsl's own.
"""

from __future__ import annotations

import atexit
import ctypes
import fcntl
import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def quiet_c_output() -> Iterator[None]:
    """Silence C-level stdout and stderr (pybullet prints 'argv[0]=' and its build time).

    Either may be closed (``2>&-``: Python's ``sys.stderr`` is then None, and descriptor 2
    free): it is closed again afterwards, and nothing is flushed into it.
    """
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = {fd: _duplicate(fd) for fd in (1, 2)}  # None: closed
    devnull = os.open(os.devnull, os.O_WRONLY)  # lands on 1 or 2 when one of them is closed
    for fd in (1, 2):
        if fd != devnull:
            os.dup2(devnull, fd)
    try:
        yield
    finally:
        ctypes.CDLL(None).fflush(None)  # C stdio may still hold what pybullet printed
        for fd, copy in saved.items():
            if copy is None:
                os.close(fd)  # closed before: closed again
            else:
                os.dup2(copy, fd)
                os.close(copy)
        if devnull not in saved:
            os.close(devnull)


def _duplicate(fd: int) -> int | None:
    """A copy of descriptor ``fd`` above the standard three (so that it is not taken for a
    closed one of them), or None when ``fd`` is closed."""
    try:
        return fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 3)
    except OSError:
        return None


RENDERER = "tinyRendererPlugin"
"""The name of pybullet's static renderer plugin, which :func:`direct_client` unloads."""

_SPARE: list[tuple[int, Any]] = []  # (process id, client) of finished runs, for the next run
_SPARE_LOCK = threading.Lock()


@atexit.register
def _disconnect_spare() -> None:
    """Disconnect the kept client while pybullet is still loaded (its ``__del__`` at the very end
    of the interpreter finds the module gone and prints an ignored exception)."""
    with _SPARE_LOCK:
        for pid, client in _SPARE:
            if pid == os.getpid():
                client.disconnect()
        _SPARE.clear()


@contextmanager
def direct_client() -> Iterator[Any]:
    """An empty pybullet DIRECT client (``BulletClient``): the one the last run in this process
    finished with, emptied (``resetSimulation``), else a new one. It is kept for the next run
    when the block ends without an exception, and disconnected when one is raised.

    Connecting costs 8 to 13 ms and emptying 1.6 to 5 ms, a run of three bricks 30 ms; an
    emptied client simulates as a new one does, bitwise (engine parameters a run changes are
    set by :class:`stackdsl.engines.pybullet.world.PyBulletWorld` at the start of every run).
    Source: stackdsl's own.
    """
    with _SPARE_LOCK:
        spare = [c for pid, c in _SPARE if pid == os.getpid()]  # a forked child connects anew
        _SPARE.clear()
    client = spare.pop() if spare else None
    if client is None:
        with quiet_c_output():
            import pybullet
            from pybullet_utils.bullet_client import BulletClient

            client = BulletClient(connection_mode=pybullet.DIRECT)
        renderer = client.loadPlugin(RENDERER)  # a loaded plugin's id; -1 in a build without it
        if renderer >= 0:
            client.unloadPlugin(renderer)
    else:
        client.resetSimulation()  # here, not when the last run ended: part of this run's time
    try:
        yield client
    except BaseException:
        client.disconnect()
        raise
    with _SPARE_LOCK:
        if _SPARE:  # another thread's run kept one: one is enough
            client.disconnect()
        else:
            _SPARE.append((os.getpid(), client))
