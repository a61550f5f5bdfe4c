"""pydantic's validation errors as one :class:`ScenarioError`, each at its YAML node (the
references the schema cannot check, :func:`stackdsl.lang.schema.reference_errors`, among them).

Unknown keys come first (with the closest allowed key), then the rest in file order; a
discriminated union's tag, which pydantic puts in an error's location, is taken out so the
location is the field as written.

Source: stackdsl's own (errors at file:line:col), after Tavern.
"""

from __future__ import annotations

import dataclasses
import difflib
import re
import types
import typing
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails

from .errors import FieldPath, ScenarioError, SourceMap
from .expectations import CollapseLevel, CollapseStatistic
from .grammar import BODY_ID
from .schema import REFERENCE_ERROR, Scenario, Structure
from .schema_parts import NAME as PART_NAME
from .schema_parts import Part
from .spelling import spelled


def first_error(
    exc: ValidationError,
    source: SourceMap,
    relocate: typing.Callable[[FieldPath], FieldPath | None] | None = None,
    note: str = "",
) -> ScenarioError:
    """The first of pydantic's errors as a ScenarioError: unknown keys first, then by position
    (an error at a field that ``relocate`` moves is placed at the node it gives, after ``note``)."""
    error = _first_error_here(exc, source)
    if relocate is None:
        return error
    for err in exc.errors(include_url=False):
        moved = relocate(_untagged(tuple(err["loc"])))
        if moved is not None:  # in the words the field itself would be refused in
            message = _one_error(err, dataclasses.replace(source, moved=())).message
            return source.error(moved, f"{note}: {message}" if note else message)
    return error


def _first_error_here(exc: ValidationError, source: SourceMap) -> ScenarioError:
    """Pydantic's errors as one ScenarioError: unknown keys first, then by position, the first
    with the others after it (:meth:`ScenarioError.with_others`)."""
    errors = exc.errors(include_url=False)
    typo_parents = {tuple(e["loc"][:-1]) for e in errors if e["type"] == "extra_forbidden"}
    errors = [e for e in errors if not (e["type"] == "missing" and tuple(e["loc"][:-1]) in typo_parents)]
    errors = _fitting_members(_last_missing_items(errors), source)

    def order(err: ErrorDetails) -> tuple[bool, int, int]:
        # An unknown key usually is a typo of a missing one: report it first.
        where = source.error(err["loc"], "")
        return err["type"] != "extra_forbidden", where.line or 0, where.column or 0

    errors.sort(key=order)
    groups: dict[tuple[str, int | None, int | None, str], list[tuple[ErrorDetails, ScenarioError]]] = {}
    for err in errors:
        error = _one_error(err, source)
        own = error.message if err["type"] == REFERENCE_ERROR else ""  # not a union's member: said on its own
        groups.setdefault((error.field, error.line, error.column, own), []).append((err, error))
    found = [_merged(group) for group in groups.values()]  # a union's members each refuse the same node
    return found[0].with_others(found[1:])


def _short_list(err: ErrorDetails) -> bool:
    """Is this the refusal of a list too short for its fixed number of items (pydantic's
    ``missing`` at an item's index)?"""
    return err["type"] == "missing" and bool(err["loc"]) and isinstance(err["loc"][-1], int)


def _last_missing_items(errors: list[ErrorDetails]) -> list[ErrorDetails]:
    """A list too short by several items is refused once, at its last missing item (whose index
    tells how many items it needs)."""
    last: dict[tuple[str | int, ...], int] = {}
    for err in errors:
        if _short_list(err):
            parent = tuple(err["loc"][:-1])
            last[parent] = max(last.get(parent, -1), int(err["loc"][-1]))
    return [e for e in errors if not _short_list(e) or last[tuple(e["loc"][:-1])] == e["loc"][-1]]


def _fitting_members(errors: list[ErrorDetails], source: SourceMap) -> list[ErrorDetails]:
    """Of the members of a plain union that refused one node, the refusals of the members the
    value has the shape of, when there are any: ``at: {after_level: 0}`` is a mapping of
    ``after_level``, and only the level's bound is said, not also that it is no number and no
    ``{after: ...}``. A member misfits when the value is not its kind (an error at its root
    other than its own check) or has keys it lacks or lacks keys it needs. Errors outside a
    union, and unions where every member misfits (``direction: up``), are kept as they are.
    Source: stackdsl's own."""
    members: dict[FieldPath, dict[str, list[ErrorDetails]]] = {}
    for err in errors:
        split = _member_split(_untagged(tuple(err["loc"])), source)
        if split is not None:
            members.setdefault(split[0], {}).setdefault(split[1], []).append(err)
    dropped: set[int] = set()
    for by_member in members.values():
        dropped |= _misfits(by_member, source)
    return [e for e in errors if id(e) not in dropped]


def _misfits(by_member: dict[str, list[ErrorDetails]], source: SourceMap) -> set[int]:
    """The ids of the refusals to drop of one union's members (``by_member``: member name -> its
    refusals of the node): those of the members the value does not have the shape of, when one
    has it; when none has, those of all but the members the value is the kind of with the fewest
    keys out of place; none when one member alone refused it."""
    if len(by_member) < 2:
        return set()
    fits = {m: not any(_misfit(e, source) for e in errs) for m, errs in by_member.items()}
    if any(fits.values()):
        return {id(e) for m, errs in by_member.items() if not fits[m] for e in errs}
    # none fits: of the members the value is the kind of, those with the fewest keys out of place
    # ({after_level: 2, extra: 1} is a level with one key too many, not a previous action with three)
    keys = {
        m: sum(e["type"] == "extra_forbidden" or e["type"] == "missing" for e in errs)
        for m, errs in by_member.items()
        if not any(_wrong_kind(e, source) for e in errs)
    }
    if not keys:
        return set()
    fewest = min(keys.values())
    return {id(e) for m, errs in by_member.items() if keys.get(m) != fewest for e in errs}


def _member_split(loc: FieldPath, source: SourceMap) -> tuple[FieldPath, str] | None:
    """(the union's node, the member's name) of an error inside a plain union's member, or None."""
    for i, seg in enumerate(loc):
        if _is_member(seg) and (*loc[:i], seg) not in source.values:
            return loc[:i], str(seg)
    return None


def _wrong_kind(err: ErrorDetails, source: SourceMap) -> bool:
    """Does this refusal say the value is not its member's kind (a mapping where a number goes)?"""
    split = _member_split(_untagged(tuple(err["loc"])), source)
    at_root = split is not None and len(_untagged(tuple(err["loc"]))) == len(split[0]) + 1
    return at_root and err["type"] not in ("value_error", "assertion_error")


def _misfit(err: ErrorDetails, source: SourceMap) -> bool:
    """Does this refusal say the value is not of its member's shape (see :func:`_fitting_members`)?"""
    if err["type"] == "extra_forbidden" or (err["type"] == "missing" and not _short_list(err)):
        return True  # a list too short is still a list: the member's kind
    split = _member_split(_untagged(tuple(err["loc"])), source)
    at_root = split is not None and len(_untagged(tuple(err["loc"]))) == len(split[0]) + 1
    return at_root and err["type"] not in ("value_error", "assertion_error")


def _merged(group: list[tuple[ErrorDetails, ScenarioError]]) -> ScenarioError:
    """One error for the refusals of one node by the members of a union: a member whose own check
    refused the value (it had that member's shape: ``[0, 0, 0]`` for a direction) says why alone;
    otherwise what each member expects, joined ("'+x', '-x', '+y' or '-y', or a list").

    >>> a = ({"type": "literal_error"}, ScenarioError("Input should be 'x' or 'y', got 'up'", field="d"))
    >>> b = ({"type": "tuple_type"}, ScenarioError("Input should be a valid tuple, got 'up'", field="d"))
    >>> _merged([a, b]).message
    "expected 'x' or 'y', or a valid tuple, got 'up'"
    """
    if len(group) == 1:
        return group[0][1]
    if all(d["type"] == "extra_forbidden" for d, _ in group):  # one key no member has: what any of them allows
        key = str(group[0][0]["loc"][-1])
        allowed = sorted({f for d, _ in group for f in fields_at(tuple(d["loc"])[:-1])})
        close = difflib.get_close_matches(key, allowed, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else f"; allowed: {', '.join(allowed)}"
        first = group[0][1]
        return ScenarioError(
            f"unknown key {key!r}{hint}",
            file=first.file,
            line=first.line,
            column=first.column,
            field=first.field,
            source_line=first.source_line,
        )
    own = [e for d, e in group if d["type"] in ("value_error", "assertion_error")]
    if own:
        return own[0]
    first = group[0][1]
    got = ""
    parts: list[str] = []
    for _, e in group:
        text = e.message
        if ", got " in text:
            text, got = text.rsplit(", got ", 1)
        text = text.removeprefix("Input should be ").removeprefix("expected ")
        if text not in parts:
            parts.append(text)
    message = "expected " + ", or ".join(parts) + (f", got {got}" if got else "")
    return ScenarioError(
        message,
        file=first.file,
        line=first.line,
        column=first.column,
        field=first.field,
        source_line=first.source_line,
    )


def _one_error(err: ErrorDetails, source: SourceMap) -> ScenarioError:
    """One of pydantic's errors as a ScenarioError at its node, in the language's words."""
    tagged = tuple(err["loc"])
    loc = _without_members(_untagged(tagged), source)
    if err["type"] == "extra_forbidden":
        return _unknown_key(tagged, loc, source)
    if _short_list(err):  # said at the list: 'direction[2]: required field is missing' read as a key
        needed = int(err["loc"][-1]) + 1
        return source.error(loc[:-1], f"expected a list of {needed} items, got {shown(err['input'])}")
    if err["type"] == "missing":
        message = "required field is missing"
        if loc == ("stackdsl",):
            message += "; a scenario file starts with 'stackdsl: 1' (the format version)"
        return source.error(loc, message)
    if not loc:
        return source.error(loc, "a scenario file is a mapping of fields, starting with 'stackdsl: 1'")
    if err["type"] == "model_type":  # pydantic's words name our classes ("instance of Probability")
        allowed = fields_at(tagged)
        message = "expected a mapping" + (f" of {', '.join(allowed)}" if allowed else "")
    elif err["type"] in ("too_long", "too_short") and isinstance(err["input"], (list, dict)):  # pydantic: 'after validation'
        return _wrong_length(err, loc, source)
    elif err["type"] == "finite_number":  # pydantic: "Input should be a finite number, got nan"
        kind = "a whole number" if _whole(tagged) else "a number"
        return source.error(loc, f"expected {kind}, got {shown(err.get('input'))} (not finite)")
    elif err["type"] in ("literal_error", "enum"):  # pydantic: "Input should be 'flat' or 'edge'"
        return source.error(loc, _choice(err))
    elif err["type"] == "string_type" and isinstance(err.get("input"), dict) and "brick type" in (_description(tagged) or ""):
        # a size written where a type's name goes (`pusher: {size: [...]}`): where sizes go
        message = "expected the name of a brick type (kapla, or a name under brick_types:, where its size goes)"
    elif err["type"] in _PLAIN:  # pydantic's words for a type, in the language's
        message = _PLAIN[err["type"]](err.get("ctx", {}))
    else:
        message = err["msg"].removeprefix("Value error, ").replace("a valid tuple", "a list")  # YAML has lists
    if "input" in err and err["type"] not in ("value_error", REFERENCE_ERROR):
        message += _got(err["type"], err["input"])
    return source.error(loc, message, at_key=tagged[-1:] == ("[key]",))  # a refused key, at the key


def _unknown_key(tagged: tuple[Any, ...], loc: FieldPath, source: SourceMap) -> ScenarioError:
    """A key the schema does not have at ``loc`` (``tagged``: pydantic's location), at the key:
    the allowed key it is closest to, else every allowed one, and the key beside it whose field
    it is when it was written level with that key instead of under it."""
    key = str(loc[-1])
    message = f"unknown key {key!r}"
    allowed = fields_at(tagged[:-1])
    close = difflib.get_close_matches(key, allowed, n=1)
    message += f"; did you mean {close[0]!r}?" if close else f"; allowed: {', '.join(allowed)}"
    # a field of a key beside it, written level with it: `push:` and then `target:` under `- `
    owners = [f for f in allowed if not close and key in fields_at((*tagged[:-1], f))]
    written = [f for f in owners if (*loc[:-1], f) in source.keys]
    if written or len(owners) == 1:
        owner = (written or owners)[0]
        message += f" ({key!r} is a field of {owner!r}: indent it under '{owner}:')"
    return source.error(loc, message, at_key=True)


def _wrong_length(err: ErrorDetails, loc: FieldPath, source: SourceMap) -> ScenarioError:
    """A list or mapping with too many or too few items, said with how many it may have (exactly,
    for the schema's tuples); too many, at the first item too many when the file shows it."""
    ctx = err.get("ctx", {})
    most = err["type"] == "too_long"
    limit = ctx.get("max_length" if most else "min_length")
    exactly = most and ctx.get("field_type") == "Tuple"  # the schema's tuples have a fixed length ([x, y])
    bound = "" if exactly else "at most " if most else "at least "
    kind = "mapping" if isinstance(err["input"], dict) else "list"
    message = f"expected a {kind} of {bound}{limit} item{'s' * (limit != 1)}"
    if most and not exactly and isinstance(limit, int) and len(err["input"]) > limit:  # at the first item too many
        first = list(err["input"])[limit] if kind == "mapping" else limit
        where = (*loc, first)
        if where in source.values or where in source.keys:
            return source.error(where, f"{message}: this is item {limit + 1} of {len(err['input'])}", at_key=kind == "mapping")
    about = _description(tuple(err["loc"])) if exactly else None  # what the fixed items are: "[x, y]"
    return source.error(loc, f"{message}, got {shown(err['input'])}" + (f": {about}" if about else ""))


def _description(loc: FieldPath) -> str | None:
    """The schema's description of the field at ``loc`` (a pydantic location, tags included),
    or None."""
    model = model_at(loc[:-1])
    field = model.model_fields.get(str(loc[-1])) if model is not None and loc else None
    return field.description if field is not None else None


def _got(kind: str, given: Any) -> str:
    """What the file gave instead, for the end of an error's message (``kind``: pydantic's error
    type): a mapping, a list and its items, or the value; a YAML word read as a boolean, said so."""
    if isinstance(given, dict):
        said = ", got a mapping"
    elif isinstance(given, list):
        said = f", got a list: {shown(given)}"
    else:
        said = f", got {shown(given)}"
    if kind == "string_pattern_mismatch" and isinstance(given, str):
        said += _not_ascii(given)
    if kind == "string_type" and isinstance(given, bool):  # yes, no, on, off
        said += ": YAML reads an unquoted yes, no, on, off, true or false as true or false; quote it"
    return said


def _whole(loc: FieldPath) -> bool:
    """Is the field at ``loc`` (a pydantic location, tags included) a whole number (an ``int``,
    or a list of them)?"""
    while loc and isinstance(loc[-1], int):
        loc = loc[:-1]
    model = model_at(loc[:-1]) if loc else None
    field = model.model_fields.get(str(loc[-1])) if model is not None else None
    return field is not None and _has_int(field.annotation)


def _has_int(annotation: Any) -> bool:
    """Does ``annotation`` take an ``int`` (through Annotated, Optional, list, tuple)?"""
    if annotation is int:
        return True
    args = typing.get_args(annotation)
    if typing.get_origin(annotation) is typing.Annotated:
        args = args[:1]
    return any(_has_int(arg) for arg in args)


def _choice(err: ErrorDetails) -> str:
    """The refusal of a value that is none of a field's choices, with the closest choice to a
    text that is near one: ``expected 'flat' or 'edge', got 'edgewise'; did you mean 'edge'?``."""
    expected = str(err.get("ctx", {}).get("expected", ""))
    given_ = err.get("input")
    message = f"expected {expected}, got {shown(given_)}"
    if isinstance(given_, str):
        close = difflib.get_close_matches(given_, re.findall(r"'([^']*)'", expected), n=1)
        if close:
            message += f"; did you mean {close[0]!r}?"
    return message


def _pattern(ctx: dict[str, Any]) -> str:
    """A name pattern (``^[A-Za-z0-9_.-]{1,40}$``) in words."""
    pattern = str(ctx.get("pattern", ""))
    if pattern == PART_NAME:
        return (
            "expected a part name: an ASCII letter or '_' first (a digit first reads as a level in 'expect'), "
            "then ASCII letters, digits, '_' or '-', 40 at most"
        )
    if pattern == BODY_ID:
        return (
            "expected an id: an ASCII letter or '_' first (a digit first reads as a level in 'expect'), then ASCII letters, digits, "
            "'_', '.' or '-' (no spaces), not ending in '.' (the start of ids in 'expect'), 40 at most"
        )
    found = re.fullmatch(r"\^\[A-Za-z0-9([^\]]*)\]\{(\d+),(\d+)\}\$", pattern)
    if found is None:
        return f"expected text matching {ctx.get('pattern')!r}"
    signs = [repr(c) for c in found.group(1)]
    others = ", ".join(signs[:-1]) + f" or {signs[-1]}" if len(signs) > 1 else "".join(signs)
    return (
        f"expected a name of {found.group(2)} to {found.group(3)} ASCII letters, digits"
        + (f", {others}" if others else "")
        + " (no spaces)"
    )


def _not_ascii(text: str) -> str:
    """Where ``text`` has a character outside ASCII (which every name pattern of the language
    refuses): its code point, ``"; 'é' is U+00E9, not ASCII"``; else nothing."""
    odd = next((c for c in text if ord(c) > 127), None)
    return "" if odd is None else f"; {odd!r} is U+{ord(odd):04X}, not ASCII"


#: pydantic's error types whose words are said as the language says them: type -> message from ctx.
_PLAIN: dict[str, Callable[[dict[str, Any]], str]] = {
    "int_from_float": lambda ctx: "expected a whole number",
    "int_type": lambda ctx: "expected a whole number",
    "int_parsing": lambda ctx: "expected a whole number",
    "float_type": lambda ctx: "expected a number",
    "float_parsing": lambda ctx: "expected a number",
    "bool_type": lambda ctx: "expected true or false",
    "bool_parsing": lambda ctx: "expected true or false",
    "list_type": lambda ctx: "expected a list",
    "tuple_type": lambda ctx: "expected a list",
    "string_type": lambda ctx: "expected text",
    "string_pattern_mismatch": _pattern,
    "string_too_short": lambda ctx: (
        "expected some text" if ctx.get("min_length") == 1 else f"expected text of {ctx.get('min_length')} characters or more"
    ),
    "string_too_long": lambda ctx: f"expected text of {ctx.get('max_length')} characters at most",
    "greater_than_equal": lambda ctx: f"expected {ctx.get('ge')} or more",
    "greater_than": lambda ctx: f"expected more than {ctx.get('gt')}",
    "less_than_equal": lambda ctx: f"expected {ctx.get('le')} or less",
    "less_than": lambda ctx: f"expected less than {ctx.get('lt')}",
}


def shown(value: Any, limit: int = 60) -> str:
    """``value`` as the file writes it (``true``, ``null``, ``.nan``), cut to about ``limit`` characters."""
    return spelled(value, limit)


#: Discriminated unions of the schema: where they stand, and each tag's model. pydantic puts the
#: tag in an error's location (``expect.collapse.statistic.mean``); the file has no node for it.
_TAGGED: dict[FieldPath, dict[str, type[BaseModel]]] = {
    ("expect", "collapse"): {"level": CollapseLevel, "statistic": CollapseStatistic},
    ("structure", "parts"): {"list": Part, "map": Part},
}


def _untagged(loc: FieldPath) -> FieldPath:
    """A pydantic location without the tags of :data:`_TAGGED` unions: the field as written
    (the parts of a structure, kept in its ``parts`` field, are written as the structure itself)."""
    if loc[:2] == ("structure", "parts") and len(loc) > 2 and loc[2] in ("list", "map"):
        loc = ("structure",) + loc[3:]
    for where, tags in _TAGGED.items():
        n = len(where)
        if loc[:n] == where and len(loc) > n and loc[n] in tags:
            return loc[:n] + loc[n + 1 :]
    return loc


_TYPE_NAMES = frozenset({"int", "float", "str", "bool", "none", "tuple", "list", "dict", "set", "bytes"})


def _without_members(loc: FieldPath, source: SourceMap) -> FieldPath:
    """``loc`` without the names pydantic gives the members of a plain union
    (``literal['+x','-x']``, ``function-after[...]``, ``float``, a model's class name): segments
    with no YAML node that are no field name. A key the file wrote (a material called
    ``Steel-1``) has a node and stays."""
    out: FieldPath = ()
    for seg in loc:
        if _is_member(seg) and (*out, seg) not in source.values:
            continue
        out += (seg,)
    return out


def _is_member(seg: str | int) -> bool:
    """Could ``seg`` be the name pydantic gives a union's member (see :func:`_without_members`)?"""
    return isinstance(seg, str) and (seg in _TYPE_NAMES or seg[:1].isupper() or any(c in seg for c in "[]()-',"))


def fields_at(loc: FieldPath) -> list[str]:
    """Field names of the model that ``loc`` (a pydantic location, tags included) leads to."""
    model = model_at(loc)
    if model is None:
        return []
    # Structure(parts=...) is the Python models' way to give parts; a file writes the list or map itself
    return sorted(f for f in model.model_fields if not (model is Structure and f == "parts"))


def model_at(loc: FieldPath) -> type[BaseModel] | None:
    """The model that ``loc`` (a pydantic location, tags included) leads to, or None when it
    leads to no model (a number, a list of numbers). A part's name or index under ``structure``
    leads to :class:`Part`; a name no model has is passed over."""
    model: Any = Scenario
    for i, seg in enumerate(loc):
        tags = _TAGGED.get(tuple(loc[:i]), {})
        if isinstance(seg, str) and seg in tags:
            model = tags[seg]
            continue
        if model is Structure and (isinstance(seg, int) or seg not in Structure.model_fields):
            model = Part  # a part as written: structure[0] or structure.left
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or seg not in model.model_fields:
            continue
        annotation: Any = model.model_fields[seg].annotation
        member = loc[i + 1] if i + 1 < len(loc) else None  # a plain union's member, named as pydantic names it
        model = _model_in(annotation, loc, member if isinstance(member, str) else None)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def _model_in(annotation: Any, loc: FieldPath, member: str | None = None) -> Any:
    """The pydantic model inside ``annotation`` (through Optional, list, dict, Annotated): in a
    union, the one named ``member`` if there is one, else the first."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _model_in(typing.get_args(annotation)[0], loc, member)
    if origin in (typing.Union, types.UnionType, list, dict, tuple):
        found = [_model_in(arg, loc, member) for arg in typing.get_args(annotation)]
        models = [f for f in found if isinstance(f, type) and issubclass(f, BaseModel)]
        return next((m for m in models if m.__name__ == member), models[0] if models else None)
    return annotation
