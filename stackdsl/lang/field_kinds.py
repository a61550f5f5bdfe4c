"""The kind of quantity of a scenario's field, by its path in a condition.

``timing.interval`` is a time: the unit check of ``require:`` and of a sweep's ``expect.cells``
conditions (:func:`stackdsl.lang.expressions.check_kinds`) reads the kinds here.

Source: stackdsl's own.
"""

from __future__ import annotations

import typing
from typing import Any

from pydantic import BaseModel

from .schema import Scenario, Structure
from .schema_parts import Part
from .units import angle, angular_speed, density, frequency, length, speed, time

_CONVERTED = {length: "length", time: "time", speed: "speed", angular_speed: "per time", frequency: "per time"}
_CONVERTED |= {density: "density", angle: "angle"}


def field_kind(name: str) -> str:
    """The kind of quantity (:data:`stackdsl.lang.expressions.KINDS`) of a scene's field by its
    path in a condition (``timing.interval``: a time), from the unit conversion its type makes;
    "" for a field that converts none (a count, a probability) or a path that names none.

    >>> field_kind("timing.interval"), field_kind("structure.tower.spacing"), field_kind("actions.0.shake.frequency")
    ('time', 'length', 'per time')
    >>> field_kind("structure.left.tower.shift.2"), field_kind("structure.tower.levels"), field_kind("nothing.here")
    ('length', '', '')
    """
    model: Any = Scenario
    info = None
    for seg in name.split("."):
        if seg.isdigit():
            continue
        if model is Structure and seg not in Structure.model_fields:
            model = Part  # a part's name
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or seg not in model.model_fields:
            return ""
        info = model.model_fields[seg]
        model = next((m for m in _inner(info.annotation) if isinstance(m, type) and issubclass(m, BaseModel)), None)
    return "" if info is None else _converted([info.annotation, *info.metadata])


def _inner(annotation: Any) -> list[Any]:
    """The types inside ``annotation`` (through Optional, unions, list, dict, tuple, Annotated)."""
    args = typing.get_args(annotation)
    if typing.get_origin(annotation) is typing.Annotated:
        return _inner(args[0])
    return [t for arg in args for t in _inner(arg)] if args else [annotation]


def _converted(items: list[Any]) -> str:
    """The kind of the first unit conversion found among ``items`` (types and their metadata): a
    validator that is one of the units' converters, or closes over one (a bounded quantity)."""
    for item in items:
        if typing.get_args(item):  # Annotated (its type, then its metadata), a union, a container
            found = _converted(list(typing.get_args(item)))
        else:
            func = getattr(item, "func", None)
            cells = [c.cell_contents for c in getattr(func, "__closure__", None) or ()]
            found = next((kind for f in (func, *cells) for convert, kind in _CONVERTED.items() if f is convert), "")
        if found:
            return found
    return ""


__all__ = ["field_kind"]
