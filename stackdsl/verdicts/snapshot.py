"""Golden snapshots a person can read: one brick per line, and a summary of what changed.

A snapshot is plain JSON. Its brick graphs are objects keyed by brick id, and each brick
is written on one line, so that a diff names the brick::

    "L05.1": {"level": 5, "state": "frozen", "position_mm": [75.2, 0.0, 36.0], "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0], ...}

:func:`summarize` compares two snapshots and names only what changed, by key: per field
(``certificate.margin_mm: 1.5 -> 0.1``) and per brick (``L05.1: x 75.2 -> 70.2 mm; frozen ->
active; rests on L04.1: area 576.0 -> 540.2 mm^2``); the pytest plugin prints it before the line
diff.

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
    """What changed between two snapshot texts, one line per brick or field, naming only what
    differs, by its key.

    Args:
        old: the stored snapshot's text.
        new: the text of this run.

    Returns:
        Lines such as ``certificate.margin_mm: 1.5 -> 0.1`` or ``final_graph L05.1: x 75.2 ->
        70.2 mm; frozen -> active; rests on L04.1: area 576.0 -> 540.2 mm^2``, in the snapshot's
        order; an empty list when nothing differs or a text is not a snapshot. A value that did
        not change is never shown as changed (no ``X -> X``).

    >>> before = {"certificate": {"verdict": "stands", "kind": "equilibrium", "bricks": [], "margin_mm": 1.5}}
    >>> after = {"certificate": {"verdict": "stands", "kind": "equilibrium", "bricks": [], "margin_mm": 0.1}}
    >>> summarize(dumps(before), dumps(after))
    ['certificate.margin_mm: 1.5 -> 0.1']
    """
    try:
        before, after = json.loads(old), json.loads(new)
    except (TypeError, ValueError):
        return []
    if not isinstance(before, dict) or not isinstance(after, dict):
        return []
    lines = []
    for key in dict.fromkeys([*before, *after]):
        a, b = before.get(key, _MISSING), after.get(key, _MISSING)
        if _same(a, b):
            continue
        if key in GRAPHS and isinstance(a, dict) and isinstance(b, dict):
            lines += [f"{key} {line}" for line in _graph_changes(a, b)]
        elif key in GRAPHS:
            lines.append(f"{key}: {_bricks(a)} -> {_bricks(b)}")
        else:
            lines += [f"{where}: {change}" for where, change in _changes(key, a, b)]
    return lines


class _Missing:
    """A key one snapshot has and the other has not."""

    def __repr__(self) -> str:
        return "missing"


_MISSING: Any = _Missing()
#: A list of numbers is shown element by element up to this many changed elements; more are counted.
_ELEMENTS_SHOWN = 3


def _same(a: Any, b: Any) -> bool:
    """The same as the snapshot text has them (``1`` and ``1.0`` differ there; so does what is
    shown of them)."""
    return a is b or _text(a) == _text(b)


def _changes(where: str, a: Any, b: Any) -> list[tuple[str, str]]:
    """The differences between two JSON values at ``where`` (a dotted key path), each as
    (path, ``old -> new``): objects key by key, lists of ids by what was added and removed,
    other lists of equal length element by element, never a pair that looks the same."""
    if _same(a, b):
        return []
    if isinstance(a, dict) or isinstance(b, dict):
        if not (isinstance(a, dict) and isinstance(b, dict)) and len(_text(a)) + len(_text(b)) <= 2 * _WIDTH:
            return [(where, _pair(a, b))]
        u = a if isinstance(a, dict) else dict.fromkeys(b, a)  # none before (or after): each key from none
        v = b if isinstance(b, dict) else dict.fromkeys(a, b)
        return [
            change
            for key in dict.fromkeys([*u, *v])
            for change in _changes(f"{where}.{key}", u.get(key, _MISSING), v.get(key, _MISSING))
        ]
    if isinstance(a, list) and isinstance(b, list):
        return _list_changes(where, a, b)
    return [(where, _pair(a, b))]


def _list_changes(where: str, a: list[Any], b: list[Any]) -> list[tuple[str, str]]:
    """The changes from list ``a`` to list ``b`` at ``where``: the ids that came and went, a
    length that changed, or each element that differs (counted when many scalars do)."""
    if (a or b) and all(isinstance(x, str) for x in (*a, *b)) and set(a) != set(b):  # ids: what came and went
        return [(where, _came_and_went(a, b))]
    if len(a) != len(b):
        return [(where, _resized(a, b))]
    changed = [i for i, (u, v) in enumerate(zip(a, b)) if not _same(u, v)]
    if all(_scalar(u) and _scalar(v) for u, v in zip(a, b)) and len(changed) > _ELEMENTS_SHOWN:
        first = ", ".join(f"[{i}] {_pair(a[i], b[i])}" for i in changed[:_ELEMENTS_SHOWN])
        return [(where, f"{len(changed)} of {len(a)} differ ({first}, ...)")]
    return [change for i in changed for change in _changes(f"{where}[{i}]", a[i], b[i])]


def _came_and_went(a: list[str], b: list[str]) -> str:
    """``'added L03.1; removed L01.2'``: the ids of ``b`` not in ``a``, and of ``a`` not in ``b``."""
    gone, came = [x for x in a if x not in b], [x for x in b if x not in a]
    said = ([f"added {_ids(came)}"] if came else []) + ([f"removed {_ids(gone)}"] if gone else [])
    return "; ".join(said)


def _resized(a: list[Any], b: list[Any]) -> str:
    """A list whose length changed: both whole when short, else their lengths alone."""
    if len(_text(a)) + len(_text(b)) > 2 * _WIDTH:
        return f"{len(a)} -> {len(b)} items"
    return _pair(a, b)


def _ids(ids: list[str]) -> str:
    shown = ", ".join(ids[:_IDS_SHOWN])
    return shown + (f" and {len(ids) - _IDS_SHOWN} more" if len(ids) > _IDS_SHOWN else "")


#: At most this many ids of a list are named as added or removed.
_IDS_SHOWN = 6


def _scalar(value: Any) -> bool:
    return value is None or isinstance(value, (bool, int, float, str))


#: The widest value shown whole; a longer one is cut around where the two differ.
_WIDTH = 60


def _text(value: Any) -> str:
    return "missing" if value is _MISSING else json.dumps(value, ensure_ascii=False)


def _pair(a: Any, b: Any, unit: str = "") -> str:
    """``old -> new`` (with ``unit``), each side cut to what differs when they are long: the
    common start and end are left out (``...``), so the difference always shows."""
    u, v = _text(a), _text(b)
    if len(u) > _WIDTH or len(v) > _WIDTH:
        start = 0
        while start < min(len(u), len(v)) and u[start] == v[start]:
            start += 1
        end = 0
        while end < min(len(u), len(v)) - start and u[-1 - end] == v[-1 - end]:
            end += 1
        start = max(0, start - 10)  # a little context before the first difference
        end = max(0, end - 10)
        u, v = (_cut(text, start, len(text) - end) for text in (u, v))
    return f"{u} -> {v}{' ' + unit if unit else ''}"


def _cut(text: str, start: int, stop: int) -> str:
    middle = text[start:stop]
    if len(middle) > _WIDTH:
        middle = middle[: _WIDTH - 3] + "..."
    return ("..." if start else "") + middle + ("..." if stop < len(text) else "")


def _bricks(graph: Any) -> str:
    if graph is _MISSING:
        return "missing"
    if not isinstance(graph, dict):
        return "none" if graph is None else _text(graph)
    return f"{len(graph)} brick{'s' * (len(graph) != 1)}"


def _graph_changes(before: dict[str, Any], after: dict[str, Any]) -> list[str]:
    lines = []
    for brick in dict.fromkeys([*before, *after]):
        a, b = before.get(brick), after.get(brick)
        if _same(a, b):
            continue
        if a is None or b is None:
            lines.append(f"{brick}: {'added' if a is None else 'removed'}")
            continue
        if not isinstance(a, dict) or not isinstance(b, dict):
            lines.append(f"{brick}: {_pair(a, b)}")
            continue
        changes = _brick_changes(a, b)
        if changes:  # (none: the same fields in another order)
            lines.append(f"{brick}: " + "; ".join(changes))
    return lines


#: Brick fields said in words, in this order; any other field is named by its key.
_SHOWN = ("position_mm", "yaw_pitch_roll_deg", "quaternion_xyzw", "state", "level", "rests_on")


def _brick_changes(a: dict[str, Any], b: dict[str, Any]) -> list[str]:
    changes = _vector("position_mm", _AXES, "mm", a, b, named="")
    changes += _vector("yaw_pitch_roll_deg", _ANGLES, "deg", a, b, named="")
    changes += _turn(a.get("quaternion_xyzw", _MISSING), b.get("quaternion_xyzw", _MISSING))
    if not _same(a.get("state", _MISSING), b.get("state", _MISSING)):
        changes.append(f"{_word(a.get('state', _MISSING))} -> {_word(b.get('state', _MISSING))}")
    if not _same(a.get("level", _MISSING), b.get("level", _MISSING)):
        changes.append(f"level {_pair(a.get('level', _MISSING), b.get('level', _MISSING))}")
    changes += _supports(a.get("rests_on", _MISSING), b.get("rests_on", _MISSING))
    for key in dict.fromkeys([*a, *b]):
        if key in _SHOWN:
            continue
        u, v = a.get(key, _MISSING), b.get(key, _MISSING)
        if isinstance(u, list) and isinstance(v, list) and len(u) == len(v) == 3:
            changes += _vector(key, _AXES, "", a, b, named=key)
        else:
            changes += [f"{where} {change}" for where, change in _changes(key, u, v)]
    return changes


def _word(value: Any) -> str:
    return value if isinstance(value, str) else _text(value)


def _vector(key: str, names: tuple[str, ...], unit: str, a: dict[str, Any], b: dict[str, Any], named: str) -> list[str]:
    """The components of a vector field that changed, ``x 75.2 -> 70.2 mm`` (``named``: the
    field's key before each, as ``com_above_mm x 52.0 -> 53.2``)."""
    u, v = a.get(key, _MISSING), b.get(key, _MISSING)
    if _same(u, v):
        return []
    prefix = f"{named} " if named else ""
    if not (isinstance(u, list) and isinstance(v, list) and len(u) == len(v) == len(names)):
        return [f"{key} {_pair(u, v)}"]
    return [f"{prefix}{name} {_pair(p, q, unit)}" for name, p, q in zip(names, u, v) if not _same(p, q)]


def _turn(u: Any, v: Any) -> list[str]:
    """How far a brick turned between two orientations (quaternions x, y, z, w): ``turned 12.3
    deg``; the components that changed when the turn is too small to show in tenths of a degree,
    or when either is not a quaternion."""
    if _same(u, v):
        return []
    if isinstance(u, list) and isinstance(v, list) and len(u) == len(v) == 4:
        from scipy.spatial.transform import Rotation

        try:
            angle = math.degrees((Rotation.from_quat(v) * Rotation.from_quat(u).inv()).magnitude())
        except ValueError:  # a zero quaternion: no turn to speak of
            angle = 0.0
        if f"{angle:.1f}" != "0.0":
            return [f"turned {angle:.1f} deg"]
        return [f"quaternion_xyzw {name} {_pair(p, q)}" for name, p, q in zip("xyzw", u, v) if not _same(p, q)]
    return [f"quaternion_xyzw {_pair(u, v)}"]


#: How the fields of a support are said: the key's words and unit.
_SUPPORT_FIELDS = {"area_mm2": ("area", "mm^2"), "load_share": ("load share", "")}


def _supports(a: Any, b: Any) -> list[str]:
    """What changed in what a brick rests on: a support gained or lost, or a support's contact
    area or load share, ``rests on L01.1: area 576.0 -> 540.2 mm^2``."""
    if _same(a, b):
        return []
    before = a if isinstance(a, dict) else {}
    after = b if isinstance(b, dict) else {}
    if (a not in (None, _MISSING) and not isinstance(a, dict)) or (b not in (None, _MISSING) and not isinstance(b, dict)):
        return [f"rests_on {_pair(a, b)}"]
    changes = []
    for support in dict.fromkeys([*before, *after]):
        u, v = before.get(support), after.get(support)
        if _same(u, v):
            continue
        if u is None:
            changes.append(f"now rests on {support}{_contact(v)}")
        elif v is None:
            changes.append(f"no longer rests on {support}{_contact(u)}")
        elif isinstance(u, dict) and isinstance(v, dict):
            said = []
            for key in dict.fromkeys([*u, *v]):
                p, q = u.get(key, _MISSING), v.get(key, _MISSING)
                if _same(p, q):
                    continue
                name, unit = _SUPPORT_FIELDS.get(key, (key, ""))
                said.append(f"{name} {_pair(p, q, unit)}")
            changes.append(f"rests on {support}: {', '.join(said)}")
        else:
            changes.append(f"rests on {support}: {_pair(u, v)}")
    if not changes:  # nothing and an empty object: no support either way, but not the same text
        changes.append(f"rests_on {_pair(a, b)}")
    return changes


def _contact(support: Any) -> str:
    """`` (area 576.0 mm^2, load share 0.5)``: a support's fields, for one gained or lost."""
    if not isinstance(support, dict) or not support:
        return ""
    said = []
    for key, value in support.items():
        name, unit = _SUPPORT_FIELDS.get(key, (key, ""))
        said.append(f"{name} {_text(value)}{' ' + unit if unit else ''}")
    return f" ({', '.join(said)})"


def golden_dir(test_file: str | Path, project: str | Path | None = None) -> Path:
    """``golden/`` beside the nearest ``pyproject.toml`` above ``test_file``
    (or beside the test file when there is none).

    ``project``: a folder above the file taken to hold a ``pyproject.toml`` too (where the
    goldens would go once one is written there).
    """
    start = Path(test_file).resolve().parent
    assumed = Path(project).resolve() if project is not None else None
    for folder in (start, *start.parents):
        if folder == assumed or (folder / "pyproject.toml").is_file():
            return folder / "golden"
    return start / "golden"


def scenario_golden_path(scenario: str | Path, project: str | Path | None = None) -> Path:
    """Where a scenario file's golden snapshot lives: ``golden/`` (see :func:`golden_dir`,
    and its ``project``), then the scenario's folder relative to the project root, then its
    stem and ``.json``.

    >>> str(scenario_golden_path("scenarios/hard/tall_100.yaml").relative_to(Path.cwd()))
    'golden/scenarios/hard/tall_100.json'
    """
    path = Path(scenario).resolve()
    golden = golden_dir(path, project)
    try:
        folder = path.parent.relative_to(golden.parent)
    except ValueError:  # a scenario outside the project: beside the project's goldens
        folder = Path(path.parent.name)
    return golden / folder / f"{path.stem}.json"
