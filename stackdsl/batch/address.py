"""A Dask address as ``stackdsl sweep --dask`` takes it, checked before anything connects.

``local:N`` starts N single-threaded worker processes here, N from 1 to the machine's cores
(as ``-j`` is capped); ``tcp://HOST:PORT`` (or ``HOST:PORT``) is a running scheduler's.
``tls://`` needs Dask's certificate settings, which stackdsl does not pass, so it is refused.

>>> parse_address(" tcp://127.0.0.1:8786 ")
'tcp://127.0.0.1:8786'
>>> parse_address("local:1")
'local:1'
>>> parse_address("local:²")
Traceback (most recent call last):
...
ValueError: local:N needs N, a whole number of worker processes from 1 to ..., not '²'

Source: stackdsl's own.
"""

from __future__ import annotations

import os
import re
import time

_HOST_PORT = re.compile(r"(?:tcp://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?):([0-9]{1,5})")


def cores() -> int:
    """The processors this process may run on (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def free_cores(load: float | None = None) -> int:
    """The cores not busy with other work: :func:`cores` less how many other tasks run now
    (:func:`busy`; ``load`` to give it), rounded, at least 1. ``-j auto`` runs this many
    processes, so that on a busy machine a check does not fight other work for the same cores.

    >>> free_cores(load=0.0) == cores(), free_cores(load=1e9)
    (True, 1)
    """
    if load is None:
        load = busy()
    return max(1, min(cores(), cores() - round(load)))


def busy(samples: int = 3, gap: float = 0.01) -> float:
    """How many tasks of other processes are running on this machine now: the median, over
    ``samples`` reads ``gap`` seconds apart, of the kernel's count of runnable tasks
    (``/proc/loadavg``'s fourth field) less this process's own; where there is no such count,
    the 1-minute load average (``os.getloadavg``), and 0 where there is neither.

    The load average is a mean over the last minute: a command run just before (the install
    before a check) left it at 0.6 to 1.0 on an idle 2-core machine, and ``-j auto`` then ran
    one process where two cores were free (the shipped folder: 16.4 s against 13.6 s at
    ``-j 2``). Source: stackdsl's own.
    """
    counts = []
    for i in range(max(1, samples)):
        if i:
            time.sleep(gap)
        running = _running_others()
        if running is None:
            try:
                return float(os.getloadavg()[0])
            except OSError:  # no load average here: every core
                return 0.0
        counts.append(running)
    return float(sorted(counts)[len(counts) // 2])  # the median of an odd count; the upper one of an even


def _running_others() -> int | None:
    """Runnable tasks on this machine now (``/proc/loadavg``) less this process's own runnable
    threads (at least this one, which reads); None where ``/proc`` has no such count."""
    try:
        with open("/proc/loadavg", encoding="ascii") as f:
            running = int(f.read().split()[3].split("/")[0])
        own = 0
        for task in os.listdir("/proc/self/task"):
            with open(f"/proc/self/task/{task}/stat", encoding="ascii") as f:
                own += f.read().rsplit(")", 1)[1].split()[0] == "R"  # the state follows the (name)
    except (OSError, ValueError, IndexError):
        return None
    return max(0, running - max(own, 1))


def parse_address(text: str) -> str:
    """``text`` as an address Dask can take: stripped, ``local:N`` or ``tcp://HOST:PORT``.

    Raises:
        ValueError: empty, malformed, ``tls://``, a port outside 1-65535, or ``local:N`` with
            N not a whole number from 1 to :func:`cores`; the message says which.
    """
    address = text.strip()
    if not address:
        raise ValueError("give a scheduler's address (tcp://HOST:PORT) or local:N")
    if address.startswith("local:"):
        count = address.removeprefix("local:")
        most = cores()
        if not re.fullmatch(r"[0-9]{1,4}", count) or not 1 <= int(count) <= most:
            raise ValueError(f"local:N needs N, a whole number of worker processes from 1 to {most}, not {count!r}")
        return address
    if address.startswith("tls://"):
        raise ValueError(
            "tls:// needs Dask's certificate settings, which stackdsl does not pass: use tcp:// on a trusted network"
        )
    match = _HOST_PORT.fullmatch(address)
    if match is None:
        raise ValueError(f"{address!r} is not an address: give tcp://HOST:PORT or local:N")
    if not 1 <= int(match.group(2)) <= 65535:
        raise ValueError(f"port {match.group(2)} is not from 1 to 65535")
    return address if address.startswith("tcp://") else f"tcp://{address}"
