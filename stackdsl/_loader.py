"""YAML -> :class:`Scenario`, with errors at ``file:line:col``.

The file is composed with PyYAML's safe loader into nodes (no object construction),
turned into plain data while a side table records each field's position, then
validated with pydantic; every error is mapped back to the nearest YAML node.
Duplicate keys and merge keys are rejected (PyYAML would silently keep the last).
Node count and file size are limited so that a hostile file (alias bombs) fails fast.

Source: stackdsl's own (errors at file:line:col), after Tavern.
"""

from __future__ import annotations

import difflib
import types
import typing
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError
from pydantic_core import ErrorDetails
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from ._errors import FieldPath, ScenarioError, SourceMap
from ._schema import BUILTIN_BRICKS, BUILTIN_MATERIALS, MAX_BRICKS, Scenario

MAX_FILE_BYTES = 1 << 20
MAX_NODES = 200_000


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file.

    Raises:
        ScenarioError: the file cannot be read, is not valid YAML, or is not a valid
            scenario; the error names file, line, column and field.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"cannot read the file: {exc.strerror or exc}", file=str(path)) from None
    if len(raw) > MAX_FILE_BYTES:
        raise ScenarioError(f"the file is larger than {MAX_FILE_BYTES} bytes", file=str(path))
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"the file is not UTF-8 text ({exc.reason} at byte {exc.start})", file=str(path)) from None
    return parse_scenario(text, file=str(path))


def parse_scenario(text: str, file: str = "<scenario>") -> Scenario:
    """Validate scenario YAML given as text; ``file`` names it in errors.

    Raises:
        ScenarioError: as :func:`load_scenario`.

    >>> parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 3}}", "t.yaml").structure.tower.levels
    3
    >>> parse_scenario("stackdsl: 1\\nstructure: {tower: {levles: 3}}", "t.yaml")
    Traceback (most recent call last):
    ...
    stackdsl._errors.ScenarioError: t.yaml:2:21: structure.tower.levles: unknown key 'levles'; did you mean 'levels'?
        structure: {tower: {levles: 3}}
                            ^
    """
    source = SourceMap(file, tuple(text.splitlines()))
    data = _read_yaml(text, source)
    try:
        scenario = Scenario.model_validate(data)
    except ValidationError as exc:
        raise _first_error(exc, source) from None
    problems = reference_errors(scenario)
    if problems:
        path, message = problems[0]
        raise source.error(path, message, more=len(problems) - 1)
    if scenario.name is None:
        scenario = scenario.model_copy(update={"name": Path(file).stem})
    scenario._source = source
    return scenario


def _read_yaml(text: str, source: SourceMap) -> Any:
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise ScenarioError("the file is empty; a scenario starts with 'stackdsl: 1'", file=source.file)
        return _plain(node, (), loader, source, [MAX_NODES])
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line if mark else None
        raise ScenarioError(
            f"not valid YAML: {exc.problem or exc.context}",
            file=source.file,
            line=None if line is None else line + 1,
            column=None if mark is None else mark.column + 1,
            source_line=source.lines[line] if line is not None and line < len(source.lines) else "",
        ) from None
    except yaml.YAMLError as exc:
        raise ScenarioError(f"not valid YAML: {exc}", file=source.file) from None
    finally:
        loader.dispose()


def _plain(node: Node, path: FieldPath, loader: yaml.SafeLoader, source: SourceMap, budget: list[int]) -> Any:
    """Plain Python data for ``node``, recording positions in ``source``."""
    budget[0] -= 1
    if budget[0] < 0:
        raise source.error(path, f"the file expands to more than {MAX_NODES} values (aliases?)")
    source.values[path] = (node.start_mark.line, node.start_mark.column)
    if isinstance(node, MappingNode):
        out: dict[str, Any] = {}
        for key_node, value_node in node.value:
            where = (key_node.start_mark.line, key_node.start_mark.column)
            merge = key_node.tag == "tag:yaml.org,2002:merge"
            key = "<<" if merge else loader.construct_object(key_node) if isinstance(key_node, ScalarNode) else None
            if key == "<<":
                source.values[path + ("<<",)] = where
                raise source.error(path + ("<<",), "merge keys ('<<') are not supported; write the fields out")
            if not isinstance(key, str):
                source.values[path + (str(key),)] = where
                raise source.error(path + (str(key),), f"keys must be names, got {key!r} (quote it if it is meant as a name)")
            if key in out:
                source.values[path + (key,)] = where
                raise source.error(path + (key,), f"duplicate key {key!r}")
            source.keys[path + (key,)] = where
            out[key] = _plain(value_node, path + (key,), loader, source, budget)
        return out
    if isinstance(node, SequenceNode):
        return [_plain(item, path + (i,), loader, source, budget) for i, item in enumerate(node.value)]
    return loader.construct_object(node, deep=True)


def _first_error(exc: ValidationError, source: SourceMap) -> ScenarioError:
    """The first of pydantic's errors as a ScenarioError: unknown keys first, then by position."""
    errors = exc.errors(include_url=False)
    typo_parents = {tuple(e["loc"][:-1]) for e in errors if e["type"] == "extra_forbidden"}
    errors = [e for e in errors if not (e["type"] == "missing" and tuple(e["loc"][:-1]) in typo_parents)]

    def order(err: ErrorDetails) -> tuple[bool, int, int]:
        # An unknown key usually is a typo of a missing one: report it first.
        where = source.error(err["loc"], "")
        return err["type"] != "extra_forbidden", where.line or 0, where.column or 0

    errors.sort(key=order)
    err = errors[0]
    loc = tuple(err["loc"])
    if err["type"] == "extra_forbidden":
        key = str(loc[-1])
        message = f"unknown key {key!r}"
        close = difflib.get_close_matches(key, _fields_at(loc[:-1]), n=1)
        message += f"; did you mean {close[0]!r}?" if close else f"; allowed: {', '.join(_fields_at(loc[:-1]))}"
        return source.error(loc, message, at_key=True, more=len(errors) - 1)
    if err["type"] == "missing":
        message = "required field is missing"
        if loc == ("stackdsl",):
            message += "; a scenario file starts with 'stackdsl: 1' (the format version)"
        return source.error(loc, message, more=len(errors) - 1)
    if not loc:
        return source.error(loc, "a scenario file is a mapping of fields, starting with 'stackdsl: 1'")
    message = err["msg"].removeprefix("Value error, ")
    if "input" in err and err["type"] not in ("value_error",) and not isinstance(err["input"], (dict, list)):
        message += f", got {err['input']!r}"
    return source.error(loc, message, more=len(errors) - 1)


def _fields_at(loc: FieldPath) -> list[str]:
    """Field names of the model that ``loc`` (a pydantic location) leads to."""
    model: Any = Scenario
    for seg in loc:
        if not (isinstance(model, type) and issubclass(model, BaseModel)) or seg not in model.model_fields:
            continue
        annotation: Any = model.model_fields[seg].annotation
        model = _model_in(annotation, loc)
    return sorted(model.model_fields) if isinstance(model, type) and issubclass(model, BaseModel) else []


def _model_in(annotation: Any, loc: FieldPath) -> Any:
    """The pydantic model inside ``annotation`` (through Optional, list, dict, Annotated)."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _model_in(typing.get_args(annotation)[0], loc)
    if origin in (typing.Union, types.UnionType, list, dict, tuple):
        for arg in typing.get_args(annotation):
            found = _model_in(arg, loc)
            if isinstance(found, type) and issubclass(found, BaseModel):
                return found
        return None
    return annotation


def reference_errors(s: Scenario) -> list[tuple[tuple, str]]:
    """Names that point nowhere: (field path, message) for each, in file order."""
    bricks = {**BUILTIN_BRICKS, **s.brick_types}
    materials = {**BUILTIN_MATERIALS, **s.materials}
    problems: list[tuple[tuple, str]] = []

    def brick(path: tuple, name: str) -> None:
        if name not in bricks:
            problems.append((path, f"unknown brick type {name!r}; known: {', '.join(sorted(bricks))}"))

    for name, bt in s.brick_types.items():
        if bt.material not in materials:
            problems.append(
                (("brick_types", name, "material"), f"unknown material {bt.material!r}; known: {', '.join(sorted(materials))}")
            )
    if s.ground.material not in materials:
        problems.append(
            (("ground", "material"), f"unknown material {s.ground.material!r}; known: {', '.join(sorted(materials))}")
        )
    if s.structure.tower:
        brick(("structure", "tower", "brick"), s.structure.tower.brick)
    if s.structure.card_house:
        brick(("structure", "card_house", "brick"), s.structure.card_house.brick)
    for i, b in enumerate(s.structure.bricks or []):
        brick(("structure", "bricks", i, "brick"), b.brick)
    ids = [b.id for b in s.structure.bricks or [] if b.id] + [imp.id for imp in s.impacts if imp.id]
    for i, b in enumerate(s.structure.bricks or []):
        if b.id and ids.count(b.id) > 1:
            problems.append((("structure", "bricks", i, "id"), f"brick id {b.id!r} is used more than once"))
    for i, imp in enumerate(s.impacts):
        brick(("impacts", i, "projectile"), imp.projectile)
    n_bricks = s.structure.tower.levels * s.structure.tower.bricks_per_layer if s.structure.tower else 0
    if n_bricks > MAX_BRICKS:
        problems.append((("structure", "tower", "levels"), f"the tower has {n_bricks} bricks; at most {MAX_BRICKS} are allowed"))
    return problems
