"""Values in messages as a scenario file writes them: ``true``, ``null``, ``.nan``, not Python's
``True``, ``None``, ``nan``.

>>> spelled(True), spelled(None), spelled(float("nan")), spelled(-float("inf")), spelled("5")
('true', 'null', '.nan', '-.inf', "'5'")
>>> spelled([1, False, {"a": None}])
"[1, false, {'a': null}]"
>>> spelled("x" * 80, limit=10)
"'xxxxxxxxx… (82 characters)"

Source: stackdsl's own.
"""

from __future__ import annotations

import math
from typing import Any


def spelled(value: Any, limit: int = 0) -> str:
    """``value`` in YAML's spelling of its scalars (text quoted as Python quotes it), cut to
    about ``limit`` characters when ``limit`` is given."""
    text = _spelled(value)
    return text if not limit or len(text) <= limit else f"{text[:limit]}… ({len(text)} characters)"


def _spelled(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return ".nan" if math.isnan(value) else ".inf" if value > 0 else "-.inf"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_spelled(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_spelled(k)}: {_spelled(v)}" for k, v in value.items()) + "}"
    return repr(value)
