"""stackdsl's installed version, read without importing anything heavy (``--version``).

Source: stackdsl's own.
"""

from __future__ import annotations

from importlib import metadata


def version() -> str:
    """The installed stackdsl's version (``importlib.metadata``), or ``'unknown'``."""
    try:
        return metadata.version("stackdsl")
    except metadata.PackageNotFoundError:
        return "unknown"
