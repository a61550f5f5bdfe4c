"""pytest plugin: the ``golden`` fixture, syrupy snapshots stored in the project's ``golden/``.

Installed with stackdsl (entry point ``pytest11``). ``pytest --snapshot-update``
rewrites the snapshots. Needs syrupy (``pip install 'stackdsl[test]'``).

Source: DESIGN.md (conventions: golden snapshots), syrupy.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

try:
    from syrupy.extensions.json import JSONSnapshotExtension
except ImportError:  # pragma: no cover - syrupy is a test extra
    JSONSnapshotExtension = None


def golden_dir(test_file: str | Path) -> Path:
    """``golden/`` beside the nearest ``pyproject.toml`` above ``test_file``
    (or beside the test file when there is none)."""
    start = Path(test_file).resolve().parent
    for folder in (start, *start.parents):
        if (folder / "pyproject.toml").is_file():
            return folder / "golden"
    return start / "golden"


def round_floats(data: Any, path: Any) -> Any:
    """syrupy matcher: floats to 6 decimals, so that last-bit noise never shows as a diff.

    Not a tolerance: stackdsl's snapshot data is rounded to 0.1 mm already.
    """
    return round(data, 6) + 0.0 if isinstance(data, float) else data


if JSONSnapshotExtension is not None:

    class GoldenSnapshotExtension(JSONSnapshotExtension):
        """syrupy JSON snapshots in the project's top-level ``golden/`` folder."""

        @classmethod
        def dirname(cls, *, test_location) -> str:
            return str(golden_dir(test_location.filepath))


@pytest.fixture
def golden(snapshot):
    """A syrupy snapshot assertion that stores JSON under ``golden/`` with floats rounded."""
    if JSONSnapshotExtension is None:  # pragma: no cover
        pytest.fail("the golden fixture needs syrupy: pip install 'stackdsl[test]'")
    return snapshot.with_defaults(extension_class=GoldenSnapshotExtension, matcher=round_floats)
