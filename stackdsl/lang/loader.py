"""YAML -> :class:`Scenario`, with errors at ``file:line:col``.

The file's text is read by :mod:`stackdsl.lang.scenario_file` (a regular file of at most 1 MiB,
never a FIFO, device or socket; UTF-8; only the characters YAML allows), then composed with
PyYAML's safe loader into nodes (no object construction), turned into plain data while a side
table records each field's position, and validated with pydantic; every error is mapped back
to the nearest YAML node. Where PyYAML was built with libyaml, libyaml's parser (in C) gives the
events and PyYAML's Python composer, with the checks below, builds the nodes; a text libyaml
refuses, or one with a character where the two read apart (:data:`_PYYAML_ONLY`), is read by
PyYAML's Python parser, whose reading or error is the one given: what is refused, where and in
what words, is PyYAML's either way (tests/test_loader.py compares the two on every YAML file of
the repository and thousands of edits of them), but for an empty value in a flow mapping with a
comment after its colon (:meth:`_FastLoader._after_colon`).

Hostile input fails fast and cleanly: duplicate keys, merge keys, recursive aliases and
tags other than the plain ones (str, int, float, bool, null, seq, map) are refused;
nesting is bounded by :data:`MAX_DEPTH` and the values a file expands to (aliases) by
:data:`MAX_NODES`; a scalar PyYAML cannot convert (``!!int abc``) is an error at that node.
Dates (``2024-01-01``) and ``=`` stay strings: the language has no use for YAML 1.1's
timestamp and value types.

Source: stackdsl's own (errors at file:line:col), after Tavern.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import yaml
from yaml.events import AliasEvent, MappingStartEvent, SequenceStartEvent
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from .bounds import NOT_IN_A_VALUE
from .errors import NO_FILE, FieldPath, ScenarioError, SourceMap
from .sampling import Template
from .scenario_file import character_name, check_characters, file_problem, read_text
from .schema import Scenario
from .spelling import spelled
from .unit_slips import UnitSlipWarning, unit_slips
from .validate import raised_in_library, validate
from .validation_errors import shown
from .yaml_out import EXPONENT_ONLY, dump

MAX_NODES = 200_000  # values a file may expand to, counting each alias's copy
MAX_DEPTH = 64  # lists and mappings nested in one another; scenarios need fewer than 10
# Characters in an integer literal: enough for any integer a double holds, even written in
# binary (0b + 1024 digits); longer ones are refused before PyYAML converts them (Python
# refuses decimal strings of over 4300 digits, and 1:2:3... sexagesimal costs quadratic time).
MAX_INTEGER_CHARS = 1100

_YAML = "tag:yaml.org,2002:"
_SCALAR_TAGS = {f"{_YAML}{t}": t for t in ("str", "int", "float", "bool", "null")}
_READ_AS = {"int": " (an integer)", "float": " (a number)", "bool": " (true or false)"}


def load_scenario(path: str | Path, seed: int | None = None, *, shown: str | None = None) -> Scenario:
    """Read and validate a scenario file; ``seed``, when given, replaces the file's ``seed``
    (``stackdsl check|run|sweep --seed N``); ``shown``, when given, names the file in errors
    instead of ``path`` (the pytest plugin opens a file by its absolute path and names it as the
    user can type it from where pytest runs).

    Only a regular file (or a symbolic link to one) of at most
    :data:`stackdsl.lang.scenario_file.MAX_FILE_BYTES` is read; anything else is refused before
    it is opened.

    Raises:
        ScenarioError: the file is missing, not a regular file, too large, not UTF-8, not
            valid YAML, or not a valid scenario; the error names file, line, column and field.
    """
    path = Path(path)
    name = str(path) if shown is None else shown
    problem = file_problem(path)
    if problem:
        raise ScenarioError(problem, file=name)
    return parse_scenario(read_text(path, name), file=name, seed=seed)


def read_data(path: str | Path, seed: int | None = None) -> tuple[dict[str, Any], SourceMap]:
    """A scenario file's plain data (distributions in place) and where each field came from, read
    as :func:`load_scenario` reads it (``seed`` replacing the file's); for a command that makes
    templates of its own from the file (``stackdsl search``). Call :func:`load_scenario` first:
    this checks nothing of the scenario.

    Raises:
        ScenarioError: as :func:`load_scenario`, or the file is not a mapping.
    """
    path = Path(path)
    if problem := file_problem(path):
        raise ScenarioError(problem, file=str(path))
    text = read_text(path, str(path)).removeprefix("\ufeff")
    source = SourceMap(str(path), tuple(text.splitlines()))
    data = _read_yaml(text, source)
    if not isinstance(data, dict):
        raise ScenarioError("a scenario is a mapping of keys", file=str(path))
    if seed is not None:
        data["seed"] = seed
    return data, source


#: At most this many unit slips of a file are shown (the rest are counted).
SLIPS_SHOWN = 5


def _as_yaml(data: Mapping[str, Any], file: str = NO_FILE) -> str:
    """``data`` as YAML text, tuples as lists. Raises TypeError for what YAML cannot write, and
    ScenarioError for lists and mappings nested more than :data:`MAX_DEPTH` deep (a mapping that
    holds itself too), the loader's own limit, said before anything recurses that deep."""

    def plain(value: Any, depth: int) -> Any:
        if isinstance(value, (Mapping, list, tuple)) and depth > MAX_DEPTH:
            raise ScenarioError(f"lists and mappings are nested more than {MAX_DEPTH} levels deep", file=file)
        if isinstance(value, Mapping):
            return {k: plain(v, depth + 1) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [plain(v, depth + 1) for v in value]
        return value

    try:
        return dump(plain(data, 1))  # text the loader reads back as it was (a part named '1e3' quoted)
    except yaml.representer.RepresenterError as exc:
        raise TypeError(
            f"parse_scenario takes YAML text or plain data (dicts, lists, numbers, strings), not {exc.args[-1]!r}"
        ) from None


def parse_scenario(text: str | Mapping[str, Any], file: str = NO_FILE, seed: int | None = None) -> Scenario:
    """Validate scenario YAML given as text; ``file`` names it in errors and gives a scenario
    without a ``name`` its stem (with no file, the name stays None, as a scenario built in Python
    has it: the two compile to the same Program); ``seed``, when given, replaces the file's ``seed``.

    ``text`` may also be the file's plain data (dicts, lists, numbers, strings: what
    ``yaml.safe_load`` of it gives), the way to build a random scenario in Python, distributions
    and a sweep included: it is written as YAML and read as a file is, so an error shows the
    line of that YAML.

    Raises:
        ScenarioError: as :func:`load_scenario`.
        TypeError: bytes (decode them, or give the file to :func:`load_scenario`); plain data
            holding something YAML cannot write (an object, a model).

    >>> parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 3}}", "t.yaml").structure.tower.levels
    3
    >>> parse_scenario("stackdsl: 1\\nstructure: {tower: {levles: 3}}", "t.yaml")
    Traceback (most recent call last):
    ...
    stackdsl.lang.errors.ScenarioError: t.yaml:2:21: structure.tower.levles: unknown key 'levles'; did you mean 'levels'?
        structure: {tower: {levles: 3}}
                            ^
    """
    if isinstance(text, (bytes, bytearray, memoryview)):
        raise TypeError("parse_scenario takes the file's text (str), not bytes: decode them, or give the file to load_scenario")
    if not isinstance(text, str):
        text = _as_yaml(text, file)
    text = text.removeprefix("\ufeff")
    check_characters(text, file)
    source = SourceMap(file, tuple(text.splitlines()))
    data = _read_yaml(text, source)
    if seed is not None and isinstance(data, dict):
        data["seed"] = seed
    template = Template.of(data, source)
    scenario = template.scenario(0, 0, checked=True) if template is not None else validate(data, source)
    slips = unit_slips(data, source)  # a valid file's (a refused one has its error to read)
    for slip in slips[:SLIPS_SHOWN]:
        warnings.warn(UnitSlipWarning(slip), stacklevel=2)
    if len(slips) > SLIPS_SHOWN:
        warnings.warn(UnitSlipWarning(f"{file}: warning: {len(slips) - SLIPS_SHOWN} more bare numbers like these"), stacklevel=2)
    return scenario


class _Checks(yaml.composer.Composer, yaml.resolver.Resolver):
    """PyYAML's composer and resolver without YAML 1.1's timestamp, value and merge types, that
    refuse recursive aliases and nesting deeper than :data:`MAX_DEPTH` while composing, and read
    ``1e-4`` as a number, as YAML 1.2 does; the parser that gives the events is the loader's."""

    yaml_implicit_resolvers = {  # noqa: RUF012 (PyYAML's own class attribute, read only)
        first: [(tag, regexp) for tag, regexp in resolvers if tag in _SCALAR_TAGS]
        + ([(_YAML + "float", EXPONENT_ONLY)] if first in "+-0123456789" else [])
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }

    def _start(self, source: SourceMap) -> None:
        self.source = source
        self.depth = 0
        self.open_anchors: set[str] = set()
        # where each alias was written, by (its parent node, its index or key node): the node it
        # names is the anchor's own, whose marks are the anchor's
        self.aliases: dict[tuple[int, int], Any] = {}

    peek_event: Callable[[], Any]  # the parser's, libyaml's or PyYAML's

    def compose_node(self, parent: Node | None, index: Any) -> Node | None:
        event = self.peek_event()
        if isinstance(event, AliasEvent) and event.anchor in self.open_anchors:
            raise self.error(event.start_mark, f"the alias *{event.anchor} is inside the node it names (a recursive alias)")
        if isinstance(event, AliasEvent) and parent is not None and index is not None:
            self.aliases[(id(parent), index if isinstance(index, int) else id(index))] = event.start_mark
        if not isinstance(event, (SequenceStartEvent, MappingStartEvent)):
            return super().compose_node(parent, index)
        if self.depth >= MAX_DEPTH:
            raise self.error(event.start_mark, f"lists and mappings are nested more than {MAX_DEPTH} levels deep")
        anchor = event.anchor
        self.depth += 1
        if anchor is not None:
            self.open_anchors.add(anchor)
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1
            if anchor is not None:
                self.open_anchors.discard(anchor)

    def error(self, mark: Any, message: str) -> ScenarioError:
        """A :class:`ScenarioError` at ``mark`` (a PyYAML ``Mark``, or None)."""
        if mark is None:
            return ScenarioError(message, file=self.source.file)
        lines = self.source.lines
        return ScenarioError(
            message,
            file=self.source.file,
            line=mark.line + 1,
            column=mark.column + 1,
            source_line=lines[mark.line] if mark.line < len(lines) else "",
        )


class _Loader(_Checks, yaml.SafeLoader):
    """:class:`_Checks` on PyYAML's own Python reader, scanner and parser: the reference."""

    def __init__(self, text: str, source: SourceMap) -> None:
        yaml.SafeLoader.__init__(self, text)
        self._start(source)


try:
    from yaml._yaml import CParser as _CParser
except ImportError:  # PyYAML built without libyaml: its Python parser alone
    _FAST: type[_Checks] | None = None
else:

    class _FastLoader(_Checks, _CParser, yaml.constructor.SafeConstructor):
        """:class:`_Checks` on libyaml's parser, its nodes as PyYAML's parser makes them: a plain
        scalar's style None (libyaml's is ""), an empty value in a flow mapping (``{a: }``) marked
        just after its colon (libyaml: at the ``}``)."""

        def __init__(self, text: str, source: SourceMap) -> None:
            _CParser.__init__(self, text)
            yaml.composer.Composer.__init__(self)
            yaml.constructor.SafeConstructor.__init__(self)
            yaml.resolver.Resolver.__init__(self)
            self._start(source)

        def compose_scalar_node(self, anchor: Any) -> ScalarNode:
            node = super().compose_scalar_node(anchor)
            if node.style == "":  # libyaml's plain style; PyYAML's is None
                node.style = None
                if node.value == "" and node.start_mark.index == node.end_mark.index:  # no anchor or tag
                    node.start_mark = node.end_mark = self._after_colon(node.start_mark)
            return node

        def _after_colon(self, mark: Any) -> Any:
            """Where PyYAML marks an empty value that libyaml marks at ``mark``: just after its
            colon when only blanks and line ends lie between (``{a: }``), else ``mark`` (with a
            comment between, ``{a: # why`` and the ``}`` on the next line, at the ``}``, where
            PyYAML marks after the colon)."""
            lines, line = self.source.lines, mark.line
            text = lines[line][: mark.column] if line < len(lines) else ""
            while not text.strip(" \t") and line > 0:
                line -= 1
                text = lines[line]
            column = len(text.rstrip(" \t"))
            if (
                not text[:column].endswith(":")
                or (line, column) == (mark.line, mark.column)
                or (line != mark.line and "#" in text)
            ):
                return mark
            return yaml.error.Mark(mark.name, mark.index, line, column, None, 0)  # its index, read nowhere, libyaml's

    _FAST = _FastLoader


# where libyaml reads other than PyYAML: tabs and "?" in flow context (YAML 1.2 allows them, PyYAML
# refuses them), tags ("!@!str", "!x1," in a flow mapping) and columns after a U+FEFF inside the text
_PYYAML_ONLY = re.compile("[\t?!\ufeff]")


def _read_yaml(text: str, source: SourceMap) -> Any:
    if _FAST is not None and not _PYYAML_ONLY.search(text):
        try:
            return _compose(_FAST, text, source)
        except (yaml.YAMLError, _Refused):
            pass  # read again below: PyYAML's Python parser gives the error, or reads what libyaml would not
    return _compose(_Loader, text, source)


class _Refused(Exception):
    """libyaml failed on a text other than with a YAML error."""


def _compose(kind: type[_Checks], text: str, source: SourceMap) -> Any:
    """Plain data of ``text`` composed by ``kind`` (:class:`_Loader`, or :class:`_FastLoader`, whose
    YAML errors and failures (as :class:`_Refused`) are left to the caller to read again)."""
    fast = kind is not _Loader
    loader: Any = None
    try:
        loader = kind(text, source)  # type: ignore[call-arg]
        node = loader.get_single_node()
        if node is None:
            raise ScenarioError("the file is empty; a scenario starts with 'stackdsl: 1'", file=source.file)
        return _plain(node, (), loader, source, [MAX_NODES], 1)
    except yaml.MarkedYAMLError as exc:
        if fast:
            raise
        raise _marked_error(exc, source) from None
    except yaml.YAMLError as exc:
        if fast:
            raise
        raise ScenarioError(f"not valid YAML: {exc}", file=source.file) from None
    except ScenarioError:
        raise
    except Exception as exc:
        if loader is None or not raised_in_library(exc):
            raise  # a bug of ours: not to be dressed up as the user's error
        if fast:
            raise _Refused from exc
        # PyYAML failed without a YAML error (e.g. "\U0011ffff", beyond Unicode): where it was reading
        where = loader.get_mark()
        raise loader.error(where, f"not valid YAML: {type(exc).__name__}: {exc}") from None
    finally:
        if loader is not None:
            loader.dispose()


def _marked_error(exc: yaml.MarkedYAMLError, source: SourceMap) -> ScenarioError:
    """The error for PyYAML's ``exc`` at the line and column it marks, with where what it was
    reading began when that is another line (a quote or a bracket left open: at that line when
    it failed past the file's end), and a hint when a ``[`` inside ``{...}`` follows a name (a
    grid key with an index written in flow style)."""
    mark = exc.problem_mark or exc.context_mark
    line = mark.line if mark else None
    started = ""  # where what PyYAML was reading began, when not where it failed: an unclosed quote or bracket
    if exc.problem and exc.context and (begun := exc.context_mark) is not None and (mark is None or begun.line != mark.line):
        started = f", {exc.context} that starts at {begun.line + 1}:{begun.column + 1}"
        if line is None or line >= len(source.lines):  # failed past the file's end: shown where it began
            mark, line = begun, begun.line
            started = f", {exc.context} that starts here and is still open at the file's end"
    text_line = source.lines[line] if line is not None and line < len(source.lines) else ""
    hint = ""
    if mark is not None and "but got '['" in str(exc.problem) and text_line[mark.column - 1 : mark.column].isalnum():
        hint = (
            "; inside {...} YAML reads '[' as a list: quote a key with an index "
            '("actions[0].shake.amplitude": ...), write it with a dot (actions.0.shake.amplitude) or on a line of its own'
        )
    return ScenarioError(
        f"not valid YAML: {exc.problem or exc.context or exc}{started}{hint}",
        file=source.file,
        line=None if line is None else line + 1,
        column=None if mark is None else mark.column + 1,
        source_line=source.lines[line] if line is not None and line < len(source.lines) else "",
    )


def _plain(
    node: Node, path: FieldPath, loader: _Loader, source: SourceMap, budget: list[int], depth: int, alias: Any = None
) -> Any:
    """Plain Python data for ``node`` (at nesting ``depth``), recording positions in ``source``:
    inside a node an alias names (``alias``: where the alias is written), that alias's."""
    budget[0] -= 1
    if budget[0] < 0:
        raise source.error(path, f"the file expands to more than {MAX_NODES} values (aliases?)")
    mark = alias or node.start_mark
    source.values[path] = (mark.line, mark.column)
    if isinstance(node, ScalarNode):
        return _scalar(node, path, loader, source)
    kind, tag = ("mapping", "map") if isinstance(node, MappingNode) else ("list", "seq")
    if node.tag != _YAML + tag:
        raise source.error(path, _tag_problem(node.tag, kind))
    if depth > MAX_DEPTH:  # only through aliases: composing bounds the written nesting
        raise source.error(path, f"lists and mappings are nested more than {MAX_DEPTH} levels deep (through aliases)")
    if isinstance(node, SequenceNode):
        return [
            _plain(item, path + (i,), loader, source, budget, depth + 1, alias or loader.aliases.get((id(node), i)))
            for i, item in enumerate(node.value)
        ]
    return _mapping(node, path, loader, source, budget, depth, alias)


def _mapping(
    node: Node, path: FieldPath, loader: _Loader, source: SourceMap, budget: list[int], depth: int, alias: Any
) -> dict[str, Any]:
    """Plain data for a mapping ``node`` (as :func:`_plain`), recording where each key is written.

    Raises:
        ScenarioError: at a key that is not a name, a merge key or a duplicate key.
    """
    out: dict[str, Any] = {}
    for key_node, value_node in node.value:
        where = (alias.line, alias.column) if alias else (key_node.start_mark.line, key_node.start_mark.column)
        key = _key(key_node, path, where, loader, source)
        if key in out:
            source.values[path + (key,)] = where
            raise source.error(path + (key,), f"duplicate key {key!r}")
        source.keys[path + (key,)] = where
        named = alias or loader.aliases.get((id(node), id(key_node)))
        out[key] = _plain(value_node, path + (key,), loader, source, budget, depth + 1, named)
    return out


def _key(key_node: Node, path: FieldPath, where: tuple[int, int], loader: _Loader, source: SourceMap) -> str:
    """The name a mapping key (``key_node``, written at ``where`` in the mapping at ``path``) gives.

    Raises:
        ScenarioError: when it is a mapping, a list, a merge key (``<<``) or a scalar that is not text.
    """
    if not isinstance(key_node, ScalarNode):
        shown = "a mapping" if isinstance(key_node, MappingNode) else "a list"
        source.values[path + ("?",)] = where
        raise source.error(path + ("?",), f"keys must be names, got {shown}")
    source.values[path + (key_node.value,)] = where
    # a plain key YAML 1.1 reads as true or false ("on", "yes") is the name as written: keys are names
    plain_word = key_node.tag == _YAML + "bool" and key_node.style is None
    key = key_node.value if plain_word else _scalar(key_node, path + (key_node.value,), loader, source)
    if key == "<<":
        raise source.error(path + ("<<",), "merge keys ('<<') are not supported; write the fields out")
    if not isinstance(key, str):
        source.values[path + (str(key),)] = where
        raise source.error(path + (str(key),), f"keys must be names, got {spelled(key)} (quote it if it is meant as a name)")
    return key


def _scalar(node: ScalarNode, path: FieldPath, loader: _Loader, source: SourceMap) -> Any:
    """The value of a plain-typed scalar; any failure of PyYAML's converters is an error here."""
    name = _SCALAR_TAGS.get(node.tag)
    if name is None:
        raise source.error(path, _tag_problem(node.tag, "scalar value"))
    if name == "int" and len(node.value.replace("_", "")) > MAX_INTEGER_CHARS:
        digits = len(node.value.replace("_", ""))
        raise source.error(path, f"an integer written with {digits} digits is too large; a number must fit in a double")
    surprise = _yaml11_number(node.value) if name in ("int", "float") else None
    if surprise:
        raise source.error(path, surprise)
    try:
        value = loader.construct_object(node, deep=True)
    except Exception:  # only PyYAML's converters run here, on a node of a known tag
        raise source.error(path, f"cannot read {shown(node.value, 40)} as !!{name}{_READ_AS.get(name, '')}") from None
    bad = NOT_IN_A_VALUE.search(value) if isinstance(value, str) else None
    if bad:  # the file's own characters were checked: this one was written as an escape ("\e")
        raise source.error(path, f"{character_name(bad.group())}, written as an escape, is not allowed in a value")
    return value


def _yaml11_number(text: str) -> str | None:
    """Why a number written as ``text`` is refused: YAML 1.1 reads ``1:30`` as base 60 (90)
    and ``010`` as octal (8), which no one writing a scenario means; None when it is plain."""
    digits = text.replace("_", "")
    if ":" in digits:
        return f"{text} is a base-60 number in YAML 1.1 (1:30 is 90); write the number itself, or quote it"
    if re.fullmatch(r"[-+]?0[0-7]+", digits):
        return f"{text} is an octal number in YAML 1.1 ({text.lstrip('+-')} is {int(digits.lstrip('+-'), 8)}); write it without the leading 0"
    return None


def _tag_problem(tag: str, kind: str) -> str:
    """Why a node with YAML tag ``tag`` is refused (``kind``: scalar value, list, mapping)."""
    shown = "!!" + tag.removeprefix(_YAML) if tag.startswith(_YAML) else tag
    if tag in _SCALAR_TAGS or tag in (_YAML + "seq", _YAML + "map"):
        return f"the YAML tag {shown} does not fit a {kind}"
    return f"the YAML tag {shown} is not supported; a scenario holds only strings, numbers, true/false, null, lists and mappings"
