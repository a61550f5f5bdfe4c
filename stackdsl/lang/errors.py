"""Scenario errors that point at the YAML: ``file:line:col: field: what was expected``.

Source: stackdsl's own, modelled on Tavern (errors show the YAML line).
"""

from __future__ import annotations

import contextlib
import re
import sys
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, TypeAlias

FieldPath: TypeAlias = tuple[str | int, ...]  # a field path: keys (str) and list indices (int)

#: How errors name a scenario that came from no file: YAML text given to
#: :func:`stackdsl.parse_scenario` without a file name, or one built from the Python models.
NO_FILE = "<scenario>"


def format_path(path: FieldPath) -> str:
    """``("structure", "bricks", 3, "at")`` -> ``"structure.bricks[3].at"``."""
    out = ""
    for seg in path:
        out += f"[{seg}]" if isinstance(seg, int) else (f".{seg}" if out else str(seg))
    return out or "(top level)"


_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\ud800-\udfff]")


def one_line(text: str) -> str:
    """``text`` (a path) with its control characters, line and paragraph separators and lone
    surrogates (bytes of a name not in the file system's encoding) written as Python escapes
    (``"a\\nb.yaml"``), so that a message naming it stays one line and shows what is there."""
    return _CONTROL.sub(lambda m: repr(m.group())[1:-1], text)


class ScenarioError(Exception):
    """A scenario file that cannot be run; nothing was simulated.

    Attributes:
        file: the file name.
        line, column: 1-based position, or None when unknown.
        field: the dotted field path, or "" for the file as a whole.
        message: what is wrong and what was expected.
        source_line: the text of the offending line, or "".
        others: further problems of the same file, shown after this one (at most
            :data:`MAX_SHOWN` in all).
        more: how many further problems the same file has that are not shown.
        alike: the fields of further problems with this one's message on this one's line (a
            list's items all wrong the same way), named after it instead of shown again.
    """

    def __init__(
        self,
        message: str,
        *,
        file: str = NO_FILE,
        line: int | None = None,
        column: int | None = None,
        field: str = "",
        source_line: str = "",
        more: int = 0,
        others: tuple[ScenarioError, ...] = (),
    ) -> None:
        super().__init__(message)
        self.message, self.file, self.line, self.column = message, file, line, column
        self.field, self.source_line, self.more = field, source_line, more
        self.others = others
        self.alike: list[str] = []

    def __str__(self) -> str:
        file = one_line(self.file)
        where = file if self.line is None else f"{file}:{self.line}:{self.column}"
        message = cut_words(self.message)
        head = f"{where}: {self.field}: {message}" if self.field else f"{where}: {message}"
        lines = [head, *excerpt(self.source_line, self.column)]
        if self.alike:
            lines.append(f"    (the same at {', '.join(self.alike)})")
        for other in self.others:
            lines.append(str(other))
        if self.more:
            lines.append(f"    ({self.more} more problem{'s' if self.more > 1 else ''} in this file)")
        return "\n".join(lines)

    def with_others(self, others: list[ScenarioError]) -> ScenarioError:
        """This error with ``others`` (further problems of the file, in order) shown after it,
        at most :data:`MAX_SHOWN` in all; the rest counted in :attr:`more`. One with the message
        of a shown one on its line is named in that one's :attr:`alike` instead.

        >>> e = ScenarioError("too small", file="t.yaml", line=2, column=3, field="size[0]")
        >>> same = [ScenarioError("too small", file="t.yaml", line=2, column=c, field=f"size[{i}]") for i, c in ((1, 9), (2, 15))]
        >>> print(e.with_others(same))
        t.yaml:2:3: size[0]: too small
            (the same at size[1], size[2])
        """
        shown: list[ScenarioError] = [self]
        for other in others:
            first = next((s for s in shown if (s.line, s.message) == (other.line, other.message) and s.line is not None), None)
            if first is not None:
                first.alike.append(other.field or f"column {other.column}")
            else:
                shown.append(other)
        self.others = tuple(shown[1:MAX_SHOWN])
        self.more = max(len(shown) - 1 - len(self.others), 0)
        return self


class ScenarioWarning(UserWarning):
    """Something in a scenario that runs as written but is most likely not what was meant; ``str()``
    is the whole message, ``file:line:col: warning: field: ...`` (:meth:`SourceMap.warning`).
    The command line shows it as a line of its own on stderr."""


class ScenarioErrors(Exception):
    """Several files failed to load or compile; ``errors`` holds one ScenarioError each, and
    ``summary`` a last line for them all (empty: none)."""

    def __init__(self, errors: list[ScenarioError], summary: str = "") -> None:
        super().__init__("\n".join([*(str(e) for e in errors), *([summary] if summary else [])]))
        self.errors, self.summary = errors, summary


@contextlib.contextmanager
def warnings_as_lines() -> Iterator[None]:
    """Show the language's warnings (:class:`ScenarioWarning`: a unit slip, a pull into a
    neighbour) as their own line on stderr, ``file:line:col: warning: ...``, not as Python's
    report of where in stackdsl they were raised; other warnings as Python shows them. The
    command line's, and a sweep's workers' (whose samples are compiled there: a pull timed before
    one sample's build ends was shown as ``.../compiler.py:151: ScenarioWarning: ...``)."""
    shown = warnings.showwarning

    def show(message: Any, category: type[Warning], filename: str, lineno: int, file: Any = None, line: Any = None) -> None:
        if issubclass(category, ScenarioWarning):
            print(message, file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = shown


#: At most this many problems of one file are shown at once (the rest are counted).
MAX_SHOWN = 10
SHOWN_LINE_CHARS = 120  # an error shows at most this much of its source line


#: Characters a word of an error's message may have before it is cut (:func:`cut_words`).
LONGEST_WORD = 1000


def cut_words(text: str, longest: int = LONGEST_WORD) -> str:
    """``text`` with every run of over ``longest`` characters that are not spaces (a value the
    file wrote, quoted back; a path is shorter) cut to a tenth of that, saying how long it was:
    a spacing of '96 x...' with 300,000 x's was a line of 300 KB on standard error.

    >>> cut_words("got '96 " + "x" * 300 + "' as a length", longest=100)
    "got '96 xxxxxxxxxx… (301 characters) as a length"
    """
    return re.sub(rf"\S{{{longest + 1},}}", lambda m: f"{m.group()[: longest // 10]}… ({len(m.group())} characters)", text)


def excerpt(line: str, column: int | None) -> list[str]:
    """The lines an error shows under its head: ``line`` (the file's text, indented) and a caret
    under 1-based ``column``; none when the line is not known.

    >>> print("\\n".join(excerpt("  collapse: 12", 3)))
          collapse: 12
          ^
    """
    if not line:
        return []
    shown, caret = _excerpt(line, max((column or 1) - 1, 0))
    return [f"    {shown}", "    " + " " * caret + "^"]


@dataclass(frozen=True)
class Location:
    """Where something was written in a scenario file: its name as given, the 1-based line and
    column, and that line's text (to show it as an error does: :func:`excerpt`)."""

    file: str
    line: int
    column: int
    source_line: str = ""

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"


def _excerpt(line: str, column: int) -> tuple[str, int]:
    """``line`` as shown under an error, and the caret's offset for 0-based ``column``.

    Characters a terminal would act on or not show (controls, U+FFFE) become U+FFFD, one
    for one so that the caret stays under its character; a long line is cut to a window of
    :data:`SHOWN_LINE_CHARS` around the column, with "…" marking the cuts.
    """
    shown = "".join(c if c.isprintable() or c == "\t" else "\ufffd" for c in line).rstrip()
    if len(shown) <= SHOWN_LINE_CHARS:
        return shown, column
    start = min(max(column - SHOWN_LINE_CHARS // 2, 0), len(shown) - SHOWN_LINE_CHARS)
    window = shown[start : start + SHOWN_LINE_CHARS]
    head = "…" if start > 0 else ""
    tail = "…" if start + SHOWN_LINE_CHARS < len(shown) else ""
    return head + window + tail, column - start + len(head)


@dataclass(frozen=True)
class SourceMap:
    """Where each field of a scenario came from.

    Attributes:
        file: file name as given.
        lines: the file's lines.
        values: field path -> (line, column), 0-based, of the value node.
        keys: field path -> (line, column), 0-based, of the mapping key naming it.
        moved: (field path, path to blame instead, note) for fields whose value came from
            elsewhere in the file: an error at or under the field is placed at the other path,
            its message after the note (a sweep cell's grid value: ``"the grid value '10 mm'"``).
    """

    file: str
    lines: tuple[str, ...] = ()
    values: dict[FieldPath, tuple[int, int]] = field(default_factory=dict)
    keys: dict[FieldPath, tuple[int, int]] = field(default_factory=dict)
    moved: tuple[tuple[FieldPath, FieldPath, str], ...] = ()

    def warning(self, path: FieldPath, message: str) -> ScenarioWarning:
        """A :class:`ScenarioWarning` at ``path``'s node: ``file:line:col: warning: field: message``."""
        e = self.error(path, message)
        where = f"{e.file}:{e.line}:{e.column}" if e.line is not None else e.file
        return ScenarioWarning(f"{where}: warning: {e.field}: {message}")

    def error(self, path: FieldPath, message: str, *, at_key: bool = False, more: int = 0) -> ScenarioError:
        """A :class:`ScenarioError` for ``path``, placed at the nearest YAML node.

        Segments with no node (pydantic puts union tags in its paths) are skipped; a path under
        one of :attr:`moved` is blamed on the node it names, after its note.
        """
        for into, blamed, note in self.moved:
            if path[: len(into)] == into:
                path, message, at_key = blamed, f"{note}: {message}", False
                break
        line, col = self._position(path, at_key)
        source = self.lines[line] if line is not None and line < len(self.lines) else ""
        return ScenarioError(
            message,
            file=self.file,
            line=None if line is None else line + 1,
            column=None if col is None else col + 1,
            field=format_path(path),
            source_line=source,
            more=more,
        )

    def _position(self, path: FieldPath, at_key: bool) -> tuple[int | None, int | None]:
        """0-based (line, column) of the nearest YAML node of ``path`` (its key's with ``at_key``)."""
        known: FieldPath = ()
        for seg in path:
            if known + (seg,) in self.values:
                known += (seg,)
        table = self.keys if at_key and known in self.keys else self.values
        return table.get(known, (None, None))

    def locations(self, under: FieldPath) -> dict[str, Location]:
        """Where each field under ``under`` was written, by its path below it (``"collapse"``,
        ``"cells[0].p_stands"``): at its key, that is at the start of its entry.

        >>> source = SourceMap("t.yaml", ("expect:", "  collapse: 9"), keys={("expect", "collapse"): (1, 2)})
        >>> {name: str(at) for name, at in source.locations(("expect",)).items()}
        {'collapse': 't.yaml:2:3'}
        """
        out = {}
        for path, (line, col) in self.keys.items():
            if len(path) > len(under) and path[: len(under)] == under:
                text = self.lines[line] if line < len(self.lines) else ""
                out[format_path(path[len(under) :])] = Location(self.file, line + 1, col + 1, text)
        return out
