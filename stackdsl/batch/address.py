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

_HOST_PORT = re.compile(r"(?:tcp://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?):([0-9]{1,5})")


def cores() -> int:
    """The processors this process may run on (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def free_cores(load: float | None = None) -> int:
    """The cores not busy with other work: :func:`cores` less the 1-minute load average
    (``os.getloadavg``; ``load`` to give it), rounded, at least 1. ``-j auto`` runs this many
    processes, so that on a busy machine a check does not fight other work for the same cores.

    >>> free_cores(load=0.0) == cores(), free_cores(load=1e9)
    (True, 1)
    """
    if load is None:
        try:
            load = os.getloadavg()[0]
        except OSError:  # no load average here: every core
            load = 0.0
    return max(1, min(cores(), cores() - round(load)))


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
