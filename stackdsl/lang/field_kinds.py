"""The kind of quantity of a scenario's field by its path, and whether a path names one field.

``timing.interval`` is a time: the unit check of ``require:`` and of a sweep's ``expect.cells``
conditions (:func:`stackdsl.lang.expressions.check_kinds`) reads the kinds here. ``timing`` and
``actions.0`` are no field but a whole section and a whole action (:func:`whole_of`): a grid key
or a distribution names one field inside them.

Source: stackdsl's own.
"""

from __future__ import annotations

import re
import types
import typing
from typing import Any

from pydantic import BaseModel

from .errors import FieldPath
from .schema import Scenario, Structure
from .schema_layouts import BrickPlacement
from .schema_parts import Part
from .units import angle, angular_speed, density, frequency, length, speed, split_quantity, time

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


def whole_of(path: FieldPath) -> str | None:
    """What ``path`` (a grid key's or a distribution's field path; a part named by its name or
    index) names when it is no one field but a whole section, item or list of them, said for a
    message (``"the whole timing section"``, ``"a whole action"``, ``"the whole list of
    bricks"``); None when it names one field (a number, a word, a list of numbers, or one value a
    file writes as a mapping, such as a target: :attr:`StrictModel.one_value`) or a path the
    language does not have (said elsewhere).

    >>> whole_of(("timing",)), whole_of(("actions", 0)), whole_of(("structure", "left"))
    ('the whole timing section', 'a whole action', 'a whole part')
    >>> whole_of(("structure", "bricks")), whole_of(("structure", "bricks", 0)), whole_of(("materials", "pine"))
    ('the whole list of bricks', 'a whole brick', 'a whole material')
    >>> whole_of(("actions", 0, "push", "target")), whole_of(("structure", "bricks", 0, "at")), whole_of(("x",))
    (None, None, None)
    """
    node: Any = Scenario
    for seg in path:
        node = _step(node, seg)
        if node is None:
            return None
    for member in _members(node):
        if _section(member):
            return f"the whole {path[0]} section" if len(path) == 1 else f"a whole {_noun(member)}"
        origin = typing.get_origin(member)
        if origin in (list, dict):
            items = [m for m in _members(typing.get_args(member)[-1]) if _section(m)]
            if items:
                return f"the whole {path[0]} section" if len(path) == 1 else f"the whole list of {_noun(items[0])}s"
    return None


def a_field_in(path: FieldPath, data: Any = None) -> FieldPath:
    """One field inside what ``path`` names (a whole section or item: :func:`whole_of`), as the
    rest of its path, to suggest in a message: the first number, quantity or list of them the
    file writes there (``data``, the file's value at ``path``), else the first field the language
    gives it (``("shake", "amplitude")`` inside an action that is a shake; ``("interval",)``
    inside ``timing``).

    >>> a_field_in(("actions", 0), {"shake": {"at": "after level 3", "amplitude": "5 mm"}})
    ('shake', 'amplitude')
    >>> a_field_in(("timing",)), a_field_in(("structure", "left"), {"name": "left", "tower": {"levels": 3}})
    (('interval',), ('tower', 'levels'))
    """
    out: list[str | int] = []
    for _ in range(12):  # a few steps reach a field in any section of the language
        here = (*path, *out)
        if out and whole_of(here) is None:
            return tuple(out)
        written = _written_step(here, data)
        if written is not None:
            key, data = written
            out.append(key)
            continue
        data = None  # nothing written here: the language's first field
        step = _language_step(here)
        if step is None:
            break
        out.append(step)
    return tuple(out)


def _written_step(here: FieldPath, data: Any) -> tuple[str | int, Any] | None:
    """The step :func:`a_field_in` takes into what the file writes at ``here`` (``data``): a
    list's first item, else a mapping's first number or quantity (or list of them), else its first
    section or list; with the value there. ``None`` when the file writes nothing to step into."""
    if isinstance(data, list) and data:
        return 0, data[0]
    if isinstance(data, dict) and data:
        keys = [k for k in data if isinstance(k, (str, int))]
        plain = [k for k in keys if _plain(data[k]) and whole_of((*here, k)) is None]
        inner = [k for k in keys if isinstance(data[k], (dict, list)) and whole_of((*here, k)) is not None]
        if plain or inner:
            key = (plain or inner)[0]
            return key, data[key]
    return None


def _language_step(here: FieldPath) -> str | int | None:
    """The step :func:`a_field_in` takes into what the language gives ``here`` when the file
    writes nothing: the first item of a list or mapping, else the model's first required number,
    then any number, any field that is one value, any field. ``None`` when there is no step."""
    node: Any = Scenario
    for seg in here:
        node = _step(node, seg)
    model = next((m for m in _members(node) if _section(m)), None)
    if model is None:
        items = [typing.get_args(m)[-1] for m in _members(node) if typing.get_origin(m) in (list, dict)]
        return 0 if items else None
    fields = {f: info for f, info in model.model_fields.items() if not (model is Structure and f == "parts")}
    leaves = [f for f in fields if whole_of((*here, f)) is None]
    numbers = [f for f in leaves if not _wordy(fields[f].annotation)]
    step: str = next(iter([f for f in numbers if fields[f].is_required()] + numbers + leaves + list(fields)))
    return step


def _plain(value: Any) -> bool:
    """A number or a quantity, or a list of them: what a sweep varies, as a file writes it."""
    if isinstance(value, list):
        return bool(value) and all(_plain(v) for v in value)
    if isinstance(value, bool):
        return False
    try:
        split_quantity(value)
    except ValueError:
        return False
    return True


def _wordy(annotation: Any) -> bool:
    """Whether a field takes words only (a name, a brick type, a mode), not numbers."""
    return all(
        m is str
        or typing.get_origin(m) is typing.Literal
        or (typing.get_origin(m) in (list, tuple) and all(a is Ellipsis or _wordy(a) for a in typing.get_args(m)))
        for m in _members(annotation)
    )


def _members(annotation: Any) -> list[Any]:
    """The types ``annotation`` may be, through Annotated, Optional and unions (a list, a dict or
    a tuple is one member, not opened)."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _members(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return [m for arg in typing.get_args(annotation) for m in _members(arg) if m is not type(None)]
    return [annotation]


def _step(node: Any, seg: str | int) -> Any:
    """The type of ``seg`` inside a value of type ``node``, None when it has none."""
    for member in _members(node):
        if member is Structure and (isinstance(seg, int) or seg not in Structure.model_fields):
            return Part  # a part as written: structure[0] or structure.left
        if isinstance(member, type) and issubclass(member, BaseModel):
            if isinstance(seg, str) and seg in member.model_fields:
                return member.model_fields[seg].annotation
            continue
        origin, args = typing.get_origin(member), typing.get_args(member)
        if origin is list and isinstance(seg, int):
            return args[0]
        if origin is tuple and isinstance(seg, int) and args:
            return args[0] if args[-1] is Ellipsis else args[seg] if seg < len(args) else None
        if origin is dict:
            return args[1]
    return None


def _section(member: Any) -> bool:
    """Whether ``member`` is a model a file writes as a section of fields (not one value)."""
    return isinstance(member, type) and issubclass(member, BaseModel) and not getattr(member, "one_value", False)


def _noun(model: type[BaseModel]) -> str:
    """A model's name as a word: ``CardHouse`` -> ``card house``; a placed brick is a ``brick``."""
    return "brick" if model is BrickPlacement else re.sub(r"(?<!^)(?=[A-Z])", " ", model.__name__).lower()


__all__ = ["a_field_in", "field_kind", "whole_of"]
