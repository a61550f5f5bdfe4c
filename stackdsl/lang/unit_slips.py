"""Unit slips: a bare number in a length field that is implausible in metres, most likely
millimetres written without their unit (``collapse_threshold: 4``, ``at: [0, 48, 4]``).

A bare number in a scenario is SI, so ``4`` is four metres. A value out of the field's range is
refused, and the refusal says so (:func:`stackdsl.lang.units.within`); one within the range but far
beyond what a scene of bricks uses is run as written, with a warning (:class:`UnitSlipWarning`)
at its file:line:col naming the value in millimetres.

Source: stackdsl's own.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

from .errors import FieldPath, ScenarioWarning, SourceMap, format_path
from .units import bare

#: Length fields (their paths, ``#`` for any list index, ``*`` for any name) and the largest bare
#: number of metres that is plausible there; beyond it, the value in millimetres is meant.
_LAYOUT: dict[str, float] = {  # the fields of a structure's layout (its own, or a part's)
    "bricks[#].at[#]": 10.0,  # a room-sized scene
    "tower.origin[#]": 10.0,
    "card_house.origin[#]": 10.0,
    "wall.origin[#]": 10.0,
    "pyramid.origin[#]": 10.0,
    "dominoes.origin[#]": 10.0,
    "tower.spacing": 1.0,
    "card_house.spacing": 1.0,
    "dominoes.spacing": 1.0,
    "dominoes.radius": 10.0,  # an arc across a room
    "wall.joint": 1.0,
    "pyramid.joint": 1.0,
    "tower.shift": 1.0,
    "tower.shift[#]": 1.0,
    "tower.shifts[#]": 1.0,
    "tower.shifts[#][#]": 1.0,
}
PLAUSIBLE: dict[str, float] = {
    "brick_types.*.size[#]": 1.0,  # a brick side of a metre or more
    **{f"structure.{k}": v for k, v in _LAYOUT.items()},
    **{f"structure[#].{k}": v for k, v in _LAYOUT.items()},  # a part of a list
    **{f"structure.*.{k}": v for k, v in _LAYOUT.items()},  # a part of a map
    "structure[#].origin[#]": 10.0,
    "structure.*.origin[#]": 10.0,
    "impacts[#].target.point[#]": 10.0,
    "impacts[#].distance": 1.0,
    "collapse_threshold": 0.1,
}
_PATTERNS = [
    (re.compile("^" + re.escape(k).replace(r"\#", "[0-9]+").replace(r"\*", "[^.\\[]+") + "$"), v) for k, v in PLAUSIBLE.items()
]


class UnitSlipWarning(ScenarioWarning):
    """A bare number of metres in a length field that is probably millimetres; ``str()`` is the
    whole message, ``file:line:col: warning: field: ...``."""


def unit_slips(data: Any, source: SourceMap) -> list[str]:
    """The unit slips of a scenario's plain data (read from ``source``), one message each, in
    file order: ``t.yaml:3:20: warning: collapse_threshold: 4 is read as 4 m (a bare number is
    metres); did you mean '4 mm'?``."""
    found = []
    for path, value in _leaves(data, ()):
        if not _slip(path, value):
            continue
        name = format_path(path)
        error = source.error(path, "")
        where = source.file if error.line is None else f"{source.file}:{error.line}:{error.column}"
        found.append(
            (
                error.line or 0,
                error.column or 0,
                f"{where}: warning: {name}: {value:g} is read as {value:g} m (a bare number is metres); "
                f"did you mean '{value:g} mm'?",
            )
        )
    return [text for *_, text in sorted(found)]


def _slip(path: FieldPath, value: Any) -> bool:
    """Whether a bare ``value`` at ``path`` is a length implausible in metres (see :data:`PLAUSIBLE`)."""
    name = format_path(path)
    limit = next((v for pattern, v in _PATTERNS if pattern.match(name)), None)
    return limit is not None and bare(value) and limit < abs(value) and abs(value) / 1000 <= limit


def metres_written(data: Any, path: FieldPath = ()) -> Any:
    """``data`` (a scenario as plain data, SI numbers) with each bare length that would read as a
    unit slip written with its unit, ``"1000.0 m"``: what :meth:`Scenario.to_yaml` writes, so that
    a scenario built in Python reads back without a warning it did not ask for."""
    if isinstance(data, dict):
        return {key: metres_written(value, (*path, str(key))) for key, value in data.items()}
    if isinstance(data, list):
        return [metres_written(value, (*path, i)) for i, value in enumerate(data)]
    return f"{float(data)!r} m" if _slip(path, data) else data


def _leaves(data: Any, path: FieldPath) -> Iterator[tuple[FieldPath, Any]]:
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _leaves(value, (*path, str(key)))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            yield from _leaves(value, (*path, i))
    else:
        yield path, data


__all__ = ["PLAUSIBLE", "UnitSlipWarning", "metres_written", "unit_slips"]
