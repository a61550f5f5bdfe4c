"""Golden snapshots a person can read: one brick per line, and a summary of what changed.

A snapshot is plain JSON. Its brick graphs are objects keyed by brick id, and each brick
is written on one line, so that a diff names the brick::

    "L05.1": {"level": 5, "state": "frozen", "position_mm": [75.2, 0.0, 36.0], "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0], ...}

:func:`summarize` compares two snapshots and says, per brick, what changed
(``L05.1: x 75.2 -> 70.2 mm; frozen -> active``); the pytest plugin prints it before
the line diff.

Source: stackdsl's own (the brick graph of docs/design.md).

>>> text = dumps({"scenario": "s", "final_graph": {"b1": {"state": "frozen", "position_mm": [1.0, 2.0, 4.0]}}})
>>> print(text)
{
  "scenario": "s",
  "final_graph": {
    "b1": {"state": "frozen", "position_mm": [1.0, 2.0, 4.0]}
  }
}
>>> moved = text.replace("[1.0, 2.0, 4.0]", "[6.0, 2.0, 4.0]").replace("frozen", "active")
>>> summarize(text, moved)
['final_graph b1: x 1.0 -> 6.0 mm; frozen -> active']
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

#: Keys of a snapshot whose values are brick graphs (brick id -> brick).
GRAPHS = ("collapse_graph", "final_graph")
_AXES = ("x", "y", "z")
_ANGLES = ("yaw", "pitch", "roll")


def dumps(data: dict[str, Any]) -> str:
    """Snapshot data as JSON text: top-level keys one per line, graphs one brick per line.

    Args:
        data: a snapshot (:meth:`stackdsl.Outcome.golden`): plain JSON values.

    Returns:
        The text, ending without a newline; ``json.loads`` of it gives ``data`` back.
    """
    lines = ["{"]
    items = list(data.items())
    for i, (key, value) in enumerate(items):
        comma = "," if i + 1 < len(items) else ""
        if key in GRAPHS and isinstance(value, dict) and value:
            lines.append(f"  {json.dumps(key)}: {{")
            bricks = list(value.items())
            for j, (brick, fields) in enumerate(bricks):
                more = "," if j + 1 < len(bricks) else ""
                lines.append(f"    {json.dumps(brick)}: {json.dumps(fields, ensure_ascii=False)}{more}")
            lines.append(f"  }}{comma}")
        else:
            lines.append(f"  {json.dumps(key)}: {json.dumps(value, ensure_ascii=False)}{comma}")
    lines.append("}")
    return "\n".join(lines)


def summarize(old: str, new: str) -> list[str]:
    """What changed between two snapshot texts, one line per brick or field.

    Args:
        old: the stored snapshot's text.
        new: the text of this run.

    Returns:
        Lines such as ``final_graph L05.1: x 75.2 -> 70.2 mm; frozen -> active``, top-level
        fields first; an empty list when nothing differs or a text is not a snapshot.
    """
    try:
        before, after = json.loads(old), json.loads(new)
    except (TypeError, ValueError):
        return []
    if not isinstance(before, dict) or not isinstance(after, dict):
        return []
    lines = []
    for key in dict.fromkeys([*before, *after]):
        a, b = before.get(key), after.get(key)
        if a == b:
            continue
        if key in GRAPHS and isinstance(a, dict) and isinstance(b, dict):
            lines += [f"{key} {line}" for line in _graph_changes(a, b)]
        elif key in GRAPHS:
            lines.append(f"{key}: {'none' if a is None else len(a)} -> {'none' if b is None else len(b)} bricks")
        else:
            lines.append(f"{key}: {_short(a)} -> {_short(b)}")
    return lines


def _graph_changes(before: dict[str, Any], after: dict[str, Any]) -> list[str]:
    lines = []
    for brick in dict.fromkeys([*before, *after]):
        a, b = before.get(brick), after.get(brick)
        if a == b:
            continue
        if a is None or b is None:
            lines.append(f"{brick}: {'added' if a is None else 'removed'}")
            continue
        lines.append(f"{brick}: " + "; ".join(_brick_changes(a, b)))
    return lines


def _brick_changes(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    changes = _vector("position_mm", _AXES, "mm", a, b) + _vector("yaw_pitch_roll_deg", _ANGLES, "deg", a, b)
    changes += _turn(a.get("quaternion_xyzw"), b.get("quaternion_xyzw"))
    if a.get("state") != b.get("state"):
        changes.append(f"{a.get('state')} -> {b.get('state')}")
    if a.get("rests_on") != b.get("rests_on"):
        changes.append(f"rests on {_supports(a)} -> {_supports(b)}")
    shown = ("state", "position_mm", "yaw_pitch_roll_deg", "quaternion_xyzw", "rests_on")
    for key in dict.fromkeys([*a, *b]):
        if key not in shown and a.get(key) != b.get(key):
            changes.append(f"{key} {_short(a.get(key))} -> {_short(b.get(key))}")
    return changes


def _vector(key: str, names: tuple[str, ...], unit: str, a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    u, v = a.get(key), b.get(key)
    if u == v:
        return []
    if not (isinstance(u, list) and isinstance(v, list) and len(u) == len(v) == len(names)):
        return [f"{key} {_short(u)} -> {_short(v)}"]
    return [f"{name} {p} -> {q} {unit}" for name, p, q in zip(names, u, v) if p != q]


def _turn(u: Any, v: Any) -> list[str]:
    """How far a brick turned between two orientations (quaternions x, y, z, w): ``turned 12.3
    deg``; the values themselves when either is not a quaternion."""
    if u == v:
        return []
    if not (isinstance(u, list) and isinstance(v, list) and len(u) == len(v) == 4):
        return [f"quaternion_xyzw {_short(u)} -> {_short(v)}"]
    from scipy.spatial.transform import Rotation

    angle = (Rotation.from_quat(v) * Rotation.from_quat(u).inv()).magnitude()
    return [f"turned {angle * 180 / math.pi:.1f} deg"]


def _supports(brick: dict[str, Any]) -> str:
    return ", ".join(brick.get("rests_on") or {}) or "nothing"


def _short(value: Any) -> str:
    text = json.dumps(value, ensure_ascii=False)
    return text if len(text) <= 60 else text[:57] + "..."


def golden_dir(test_file: str | Path) -> Path:
    """``golden/`` beside the nearest ``pyproject.toml`` above ``test_file``
    (or beside the test file when there is none)."""
    start = Path(test_file).resolve().parent
    for folder in (start, *start.parents):
        if (folder / "pyproject.toml").is_file():
            return folder / "golden"
    return start / "golden"


def scenario_golden_path(scenario: str | Path) -> Path:
    """Where a scenario file's golden snapshot lives: ``golden/`` (see :func:`golden_dir`),
    then the scenario's folder relative to the project root, then its stem and ``.json``.

    >>> str(scenario_golden_path("scenarios/hard/tall_100.yaml").relative_to(Path.cwd()))
    'golden/scenarios/hard/tall_100.json'
    """
    path = Path(scenario).resolve()
    golden = golden_dir(path)
    try:
        folder = path.parent.relative_to(golden.parent)
    except ValueError:  # a scenario outside the project: beside the project's goldens
        folder = Path(path.parent.name)
    return golden / folder / f"{path.stem}.json"
