"""Conditions of a scenario's ``require:``: a small grammar, parsed here, never evaluated as Python.

A condition compares numbers: names (a field of the scene, ``timing.placement_error``; a list
item as ``actions.0.shake.amplitude`` or ``actions[0].shake.amplitude``, which read the same; or a
quantity derived from where its bricks are, ``overhang``), numbers with an optional unit
(``10 mm``, ``0.5 s``, ``2 deg``), ``+ - * /``, ``abs(x)``, ``min(a, b, ...)`` and ``max(a, b, ...)``, joined by ``and``,
``or`` and ``not``, with parentheses::

    condition  := disjunct ("or" disjunct)*
    disjunct   := negation ("and" negation)*
    negation   := "not" negation | comparison
    comparison := sum (("<" | "<=" | ">" | ">=" | "==" | "!=") sum)+    # chained: a < b < c
                | "(" condition ")"
    sum        := product (("+" | "-") product)*
    product    := unary (("*" | "/") unary)*
    unary      := "-" unary | NUMBER [UNIT] | NAME | FUNCTION "(" sum ("," sum)* ")" | "(" sum ")"

Quantities are SI (metres, seconds, m/s, kg/m^3, m/s^2) and degrees for angles, as everywhere in a
Program; a number's unit converts it (pint converts the unit only, as for any quantity of a file).
Each side of a comparison has a kind (:func:`check_kinds`): a product or quotient the kind its
factors make.
A division by zero makes the condition false, and so does a comparison with a name the values
lack (NaN); a division by a number that reads no name and is zero (``1 / 0``, ``x / (2 - 2)``) is
refused when the condition is parsed.

>>> c = parse("overhang >= 10 mm and abs(com_offset) < 0.06")
>>> c.names, c.holds({"overhang": 0.012, "com_offset": -0.02})
(('overhang', 'com_offset'), True)

Source: stackdsl's own (after Scenic's ``require``: Fremont et al., "Scenic: a language for
scenario specification and scene generation", PLDI 2019).
"""

from __future__ import annotations

import itertools
import math
import operator
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from .spelling import spelled
from .units import UNSIGNED, angle, angular_speed, density, length, si_unit, speed, time

MAX_CONDITION = 500
"""Characters a condition may have."""
_MAX_DEPTH = 50  # nested parentheses, functions and 'not'

_TOKEN = re.compile(
    r"\s*(?:"
    rf"(?P<number>{UNSIGNED})"
    r"(?:[ \t]*(?P<unit>[A-Za-zµ°][A-Za-zµ°0-9]*(?:[/^][A-Za-zµ°0-9]+)*))?"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z0-9_]+|\[[ \t]*[0-9]+[ \t]*\])*)"
    r"|(?P<op><=|>=|==|!=|<|>|\+|-|\*|/|\(|\)|,)"
    r")"
)
_KEYWORDS = {"and", "or", "not"}
FUNCTIONS: dict[str, Callable[..., float]] = {"abs": abs, "min": min, "max": max}
_COMPARE: dict[str, Callable[[float, float], bool]] = {
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
    "==": operator.eq,
    "!=": operator.ne,
}
_ARITHMETIC: dict[str, Callable[[float, float], float]] = {"+": operator.add, "-": operator.sub, "*": operator.mul}
_CONVERTERS = (length, time, speed, angular_speed, density, angle)


def quantity(number: str, unit: str) -> float:
    """``number`` with ``unit`` in SI (degrees for angles). Raises ValueError for an unknown unit."""
    return measured(number, unit)[0]


def measured(number: str, unit: str) -> tuple[float, str]:
    """``number`` with ``unit`` in SI (degrees for angles), and its kind of quantity: one of
    :data:`KINDS`, or for another product of metres, seconds and kilograms its SI unit
    (``"m^2/s"``). Raises ValueError for a number beyond a double, an unknown unit, or a unit of
    no kind a condition compares (:data:`SUPPORTED`).

    >>> measured("1", "ms"), measured("2", "Hz")[1], measured("9.8", "m/s^2"), measured("3", "cm^2/s")
    ((0.001, 'time'), 'per time', (9.8, 'acceleration'), (0.00030000000000000003, 'm^2/s'))
    """
    text = f"{number} {unit}"
    if not math.isfinite(float(number)):
        raise ValueError(_INFINITE.format(number))
    for convert, kind in zip(_CONVERTERS, _KINDS, strict=True):
        try:
            return float(convert(text)), kind
        except ValueError:
            continue
    found = si_unit(unit)
    if found is None:
        raise ValueError(f"unknown unit {unit!r} in '{text}': {SUPPORTED}")
    factor, dimensions = found
    value = float(number) * factor
    if not math.isfinite(value):
        raise ValueError(f"'{text}' is not a finite number in SI units: it is beyond the largest a double holds")
    return value, _kind_name((*dimensions, 0)) if any(dimensions) else ""


_INFINITE = "{} is not a finite number: it is beyond the largest a double holds (about 1.8e308)"
KINDS = ("length", "time", "speed", "per time", "density", "angle", "mass", "acceleration", "area", "volume", "count")
"""The kinds of quantity a condition's dimensions are checked by: what a number's unit says, and
what the compiler knows of a name (a derived quantity, a field of the scene). A bare number has
none: it is read in the unit a name of its kind means (SI), and goes with anything. A product or
a quotient has the kind its factors make (a length over a time squared: an acceleration), or a
unit of its own (``m^2/s``); a count times a length is a length."""
_KINDS = ("length", "time", "speed", "per time", "density", "angle")  # of _CONVERTERS, in order
SUPPORTED = (
    "a condition's numbers are lengths, times, masses and angles (deg, rad), and products and quotients of "
    "metres, seconds and kilograms (m/s, Hz, m/s^2, m^2, kg/m^3)"
)

Dimensions = tuple[int, ...]
"""Exponents of metre, second, kilogram and degree."""
_DIMENSIONS: dict[str, Dimensions] = {
    "count": (0, 0, 0, 0),
    "length": (1, 0, 0, 0),
    "area": (2, 0, 0, 0),
    "volume": (3, 0, 0, 0),
    "time": (0, 1, 0, 0),
    "per time": (0, -1, 0, 0),
    "speed": (1, -1, 0, 0),
    "acceleration": (1, -2, 0, 0),
    "mass": (0, 0, 1, 0),
    "density": (-3, 0, 1, 0),
    "angle": (0, 0, 0, 1),
}
_UNIT_NAMES = ("m", "s", "kg", "deg")
Kind = Dimensions | str
"""A node's kind in :func:`check_kinds`: its dimensions; "" for a bare number (goes with anything,
takes the other factor's kind), "?" for what is not known (goes with anything)."""


def _kind_name(dimensions: Dimensions) -> str:
    """A kind's name (:data:`KINDS`), or its unit in SI (``"m^2/s"``)."""
    named = next((k for k, d in _DIMENSIONS.items() if d == dimensions), None)
    if named is not None:
        return named
    up = [f"{u}^{e}" if e != 1 else u for u, e in zip(_UNIT_NAMES, dimensions, strict=True) if e > 0]
    down = [f"{u}^{-e}" if e != -1 else u for u, e in zip(_UNIT_NAMES, dimensions, strict=True) if e < 0]
    return (" ".join(up) or "1") + (f"/{' '.join(down)}" if len(down) == 1 else f"/({' '.join(down)})" if down else "")


def _dimensions(kind: str) -> Kind:
    """The dimensions of a kind as :func:`measured` or the compiler names it ("" stays "")."""
    if not kind:
        return ""
    if kind in _DIMENSIONS:
        return _DIMENSIONS[kind]
    found = si_unit(kind.replace(" ", "*"))
    return (*found[1], 0) if found is not None else "?"


def check_kinds(condition: Condition, kinds: Mapping[str, str]) -> None:
    """Refuse a condition that compares, adds or subtracts quantities of two kinds (``overhang < 3
    s``, ``levels > 2 mm``), or takes the min or max of such: ``kinds`` gives the kind of each name
    the compiler knows (:data:`KINDS`); an unknown name and a bare number go with anything, and a
    product or quotient has the kind its factors make (their exponents of metre, second, kilogram
    and degree added or subtracted; a bare number keeps the other's). Source: stackdsl's own.

    Raises:
        ValueError: the first such mismatch, naming both sides and their kinds.

    >>> check_kinds(parse("overhang < 10 mm and levels >= 3"), {"overhang": "length", "levels": "count"})
    >>> check_kinds(parse("max_overhang < 1 ms"), {"max_overhang": "length"})
    Traceback (most recent call last):
    ...
    ValueError: compares max_overhang (a length) with 1 ms (a time): both sides must be quantities of one kind
    >>> check_kinds(parse("a * f * f < 1 m"), {"a": "length", "f": "per time"})
    Traceback (most recent call last):
    ...
    ValueError: compares a * f * f (an acceleration) with 1 m (a length): both sides must be quantities of one kind
    """
    _kind_of(condition.tree, kinds)


def _kind_of(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """(kind, how it is written) of a node (:data:`Kind`), by the rule for its kind of node
    (``and`` and ``or`` check their parts alone)."""
    return _KIND_RULES.get(node[0], _logic_kind)(node, kinds)


def _num_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """A number's kind: that of its unit."""
    return _dimensions(node[2]), node[3]


def _name_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """A name's kind: the one ``kinds`` gives it (unknown when it gives none)."""
    return _dimensions(kinds.get(node[1], "")), node[1]


def _neg_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """``-x``: the kind of ``x``."""
    inner, words = _kind_of(node[1], kinds)
    return inner, f"-{words}"


def _arith_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """``a + b`` and ``a - b``: of one kind, checked; ``a * b`` and ``a / b``: their dimensions
    added or subtracted (a bare number scales; unknown if either side is).

    Raises:
        ValueError: when a sum or a difference has sides of two kinds.
    """
    (a, wa), (b, wb) = _kind_of(node[2], kinds), _kind_of(node[3], kinds)
    words = f"{wa} {node[1]} {wb}"
    if node[1] == "+":
        _same(a, wa, b, wb, "adds", "to")
        return _either(a, b), words
    if node[1] == "-":
        _same(b, wb, a, wa, "subtracts", "from")  # a - b subtracts b from a
        return _either(a, b), words
    if b == "":  # a bare number scales what it multiplies or divides
        return a, words
    if a == "" and node[1] == "*":
        return b, words
    if (isinstance(a, str) and a) or isinstance(b, str):  # "?": not known, nor is the product
        return "?", words
    sign = 1 if node[1] == "*" else -1
    base = (0, 0, 0, 0) if a == "" else a
    return tuple(x + sign * y for x, y in zip(base, b, strict=True)), words


def _call_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """``min``, ``max``, ``abs``: arguments of one kind, checked; the call is of that kind.

    Raises:
        ValueError: when two arguments are of two kinds.
    """
    parts = [_kind_of(arg, kinds) for arg in node[2]]
    for (a, wa), (b, wb) in itertools.pairwise(parts):
        _same(a, wa, b, wb, f"takes the {node[1]} of", "and")
    found: Kind = ""
    for k, _ in parts:
        found = _either(found, k)
    return found, f"{node[1]}(...)"


def _cmp_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """A comparison (a chain of them): each pair of sides of one kind, checked.

    Raises:
        ValueError: when two sides compared are of two kinds.
    """
    parts = [_kind_of(operand, kinds) for operand in node[2]]
    for (a, wa), (b, wb) in itertools.pairwise(parts):
        _same(a, wa, b, wb, "compares", "with")
    return "", ""


def _not_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """``not x``: ``x`` checked."""
    _kind_of(node[1], kinds)
    return "", ""


def _logic_kind(node: Node, kinds: Mapping[str, str]) -> tuple[Kind, str]:
    """``and``, ``or``: each part checked."""
    for part in node[1]:
        _kind_of(part, kinds)
    return "", ""


_KIND_RULES: dict[str, Callable[[Node, Mapping[str, str]], tuple[Kind, str]]] = {
    "num": _num_kind,
    "name": _name_kind,
    "neg": _neg_kind,
    "arith": _arith_kind,
    "call": _call_kind,
    "cmp": _cmp_kind,
    "not": _not_kind,
}


def _either(a: Kind, b: Kind) -> Kind:
    """The kind of a sum of two things of one kind: the one that is known."""
    if not isinstance(a, str):
        return a
    if not isinstance(b, str):
        return b
    return "?" if "?" in (a, b) else ""


def _same(a: Kind, wa: str, b: Kind, wb: str, verb: str, joint: str) -> None:
    if not isinstance(a, str) and not isinstance(b, str) and a != b:
        raise ValueError(f"{verb} {wa} ({_article(a)}) {joint} {wb} ({_article(b)}): both sides must be quantities of one kind")


def _article(dimensions: Dimensions) -> str:
    kind = _kind_name(dimensions)
    if kind not in _DIMENSIONS:
        return f"a quantity in {kind}"
    return {"angle": "an angle", "acceleration": "an acceleration", "area": "an area", "per time": "a rate (per time)"}.get(
        kind, f"a {kind}"
    )


# a parsed condition is a tree of tuples: ("num", value, kind, as written), ("name", text), ("neg", x),
# ("arith", op, a, b), ("call", fn, args), ("cmp", [ops], [operands]), ("not", x), ("and"/"or", [xs])
Node = tuple[Any, ...]


@dataclass(frozen=True)
class Condition:
    """One parsed condition: its text, tree and the names it reads, in order of first use."""

    text: str
    tree: Node
    names: tuple[str, ...]

    def holds(self, values: Mapping[str, float]) -> bool:
        """Whether the condition holds with ``values`` for its names (SI numbers); a name not in
        ``values`` (a field this draw of the scene lacks, such as the shift of a level it does not
        build) reads as NaN, and every comparison with NaN is false."""
        try:
            return bool(_evaluate(self.tree, values))
        except ZeroDivisionError:
            return False

    def divides_by_zero(self, values: Mapping[str, float]) -> bool:
        """Whether evaluating the condition with ``values`` divides by zero (it is then false).

        >>> parse("1 / levels > 0").divides_by_zero({"levels": 0.0})
        True
        """
        try:
            _evaluate(self.tree, values)
        except ZeroDivisionError:
            return True
        return False

    def can_hold(self, ranges: Mapping[str, tuple[float, float]]) -> bool:
        """Whether the condition may hold for some values of its names within ``ranges`` (name ->
        closed interval, SI; a name not there may be anything), by interval arithmetic: False only
        when no values in the ranges can make it hold (the condition itself cannot), True when
        it may (a name used twice, ``x < 1 and x > 2``, is taken as two, so True errs that way).

        >>> parse("com_offset < -1 mm").can_hold({"com_offset": (0.0, math.inf)})
        False
        >>> parse("levels > 100 or overhang > 1 m").can_hold({"levels": (5.0, 5.0), "overhang": (0.0, math.inf)})
        True
        """
        return True in _truths(self.tree, ranges)


def _span(node: Node, ranges: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
    """The interval of values a number node can take with its names in ``ranges``."""
    kind = node[0]
    if kind == "num":
        return node[1], node[1]
    if kind == "name":
        return ranges.get(node[1], (-math.inf, math.inf))
    if kind == "neg":
        lo, hi = _span(node[1], ranges)
        return -hi, -lo
    if kind == "arith":
        return _arith_span(node[1], _span(node[2], ranges), _span(node[3], ranges))
    return _call_span(node[1], [_span(arg, ranges) for arg in node[2]])  # "call"


def _arith_span(op: str, a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """The interval of ``x op y`` for x in ``a`` and y in ``b`` (``op``: ``+ - * /``); anything
    when it divides by an interval holding 0, or multiplies 0 by infinity."""
    (a0, a1), (b0, b1) = a, b
    if op == "+":
        return a0 + b0, a1 + b1
    if op == "-":
        return a0 - b1, a1 - b0
    if op == "/":
        if b0 <= 0 <= b1:
            return -math.inf, math.inf
        b0, b1 = 1 / b1, 1 / b0
    products = [x * y for x in (a0, a1) for y in (b0, b1)]
    if any(math.isnan(p) for p in products):  # 0 x inf: anything
        return -math.inf, math.inf
    return min(products), max(products)


def _call_span(fn: str, spans: list[tuple[float, float]]) -> tuple[float, float]:
    """The interval of ``fn`` (``min``, ``max`` or ``abs``) of arguments in ``spans``."""
    if fn == "min":
        return min(lo for lo, _ in spans), min(hi for _, hi in spans)
    if fn == "max":
        return max(lo for lo, _ in spans), max(hi for _, hi in spans)
    lo, hi = spans[0]  # abs
    return (lo, hi) if lo >= 0 else (-hi, -lo) if hi <= 0 else (0.0, max(-lo, hi))


def _truths(node: Node, ranges: Mapping[str, tuple[float, float]]) -> set[bool]:
    """What a condition node may come out as (True, False or both) with its names in ``ranges``."""
    kind = node[0]
    if kind == "cmp":
        return _cmp_truths(node, ranges)
    if kind == "not":
        return {not t for t in _truths(node[1], ranges)}
    parts = [_truths(part, ranges) for part in node[1]]
    if kind == "and":
        return ({True} if all(True in p for p in parts) else set()) | ({False} if any(False in p for p in parts) else set())
    return ({True} if any(True in p for p in parts) else set()) | ({False} if all(False in p for p in parts) else set())


def _cmp_truths(node: Node, ranges: Mapping[str, tuple[float, float]]) -> set[bool]:
    """What a comparison (a chain of them) may come out as with its names in ``ranges``: true
    when every pair may be, false when some pair may be; false alone when a name is NaN."""
    spans = [_span(operand, ranges) for operand in node[2]]
    if any(math.isnan(v) for span in spans for v in span):
        return {False}  # a name a draw lacks: every comparison is false
    pairs = [_compared(op, a, b) for op, a, b in zip(node[1], spans, spans[1:])]
    out = set()
    if all(True in p for p in pairs):
        out.add(True)
    if any(False in p for p in pairs):
        out.add(False)
    return out


def _compared(op: str, a: tuple[float, float], b: tuple[float, float]) -> set[bool]:
    """What ``x op y`` may be for x in ``a`` and y in ``b``."""
    if op in (">", ">="):
        op, a, b = {">": "<", ">=": "<="}[op], b, a
    point = a[0] == a[1] == b[0] == b[1]
    meet = a[0] <= b[1] and b[0] <= a[1]
    if op == "<":
        can, cannot = a[0] < b[1], a[1] >= b[0]
    elif op == "<=":
        can, cannot = a[0] <= b[1], a[1] > b[0]
    elif op == "==":
        can, cannot = meet, not point
    else:  # "!="
        can, cannot = not point, meet
    return ({True} if can else set()) | ({False} if cannot else set())


def parse(text: str) -> Condition:
    """Parse a condition (the module's grammar).

    Raises:
        ValueError: a syntax error, with the character it is at (1-based), or an unknown unit.
    """
    if not isinstance(text, str):
        raise ValueError(f"a condition is text, such as 'overhang >= 10 mm', got {spelled(text)}")
    if len(text) > MAX_CONDITION:
        raise ValueError(f"a condition has at most {MAX_CONDITION} characters, not {len(text)}")
    parser = _Parser(text)
    tree = parser.condition(0)
    if parser.peek() is not None:
        raise parser.error(f"unexpected {parser.peek()!r}")
    return Condition(text, tree, tuple(dict.fromkeys(parser.names)))


class _Parser:
    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens: list[tuple[str, str, int]] = []  # kind, text, position
        self.names: list[str] = []
        self.units: dict[int, tuple[str, str]] = {}  # a number token -> its kind and how it is written
        position = 0
        while position < len(text):
            if text[position:].strip() == "":
                break
            match = _TOKEN.match(text, position)
            if match is None or match.end() == position:
                start = len(text) - len(text[position:].lstrip())
                raise ValueError(f"at character {start + 1}: cannot read {text[start : start + 10]!r}")
            start = match.start(match.lastgroup or 0) if match.lastgroup else position
            if match["number"] is not None:
                unit = match["unit"]
                if unit in _KEYWORDS:  # "3 and ...": the word is no unit
                    self.tokens.append(("num", match["number"], match.start("number")))
                    position = match.start("unit")
                    continue
                if not math.isfinite(float(match["number"])):
                    raise ValueError(f"at character {match.start('number') + 1}: {_INFINITE.format(match['number'])}")
                value, kind = measured(match["number"], unit) if unit else (float(match["number"]), "")
                self.tokens.append(("num", repr(value), match.start("number")))
                self.units[len(self.tokens) - 1] = (kind, f"{match['number']} {unit}" if unit else match["number"])
            elif match["name"] is not None:
                word = re.sub(r"\[[ \t]*([0-9]+)[ \t]*\]", r".\1", match["name"])  # actions[0].x reads as actions.0.x
                self.tokens.append(("kw" if word in _KEYWORDS else "name", word, start))
            else:
                self.tokens.append(("op", match["op"], start))
            position = match.end()
        self.at = 0

    def peek(self) -> str | None:
        return self.tokens[self.at][1] if self.at < len(self.tokens) else None

    def take(self) -> tuple[str, str, int]:
        if self.at >= len(self.tokens):
            raise ValueError(f"at character {len(self.text) + 1}: the condition ends too soon")
        token = self.tokens[self.at]
        self.at += 1
        return token

    def error(self, message: str) -> ValueError:
        where = self.tokens[self.at][2] + 1 if self.at < len(self.tokens) else len(self.text) + 1
        return ValueError(f"at character {where}: {message}")

    def expect(self, text: str) -> None:
        if self.peek() != text:
            raise self.error(f"expected {text!r}" + (f", got {self.peek()!r}" if self.peek() is not None else ""))
        self.take()

    def _deeper(self, depth: int) -> int:
        if depth >= _MAX_DEPTH:
            raise self.error(f"nested more than {_MAX_DEPTH} deep")
        return depth + 1

    # conditions (true or false)
    def condition(self, depth: int) -> Node:
        parts = [self.disjunct(depth)]
        while self.peek() == "or":
            self.take()
            parts.append(self.disjunct(depth))
        return parts[0] if len(parts) == 1 else ("or", parts)

    def disjunct(self, depth: int) -> Node:
        parts = [self.negation(depth)]
        while self.peek() == "and":
            self.take()
            parts.append(self.negation(depth))
        return parts[0] if len(parts) == 1 else ("and", parts)

    def negation(self, depth: int) -> Node:
        if self.peek() == "not":
            self.take()
            return ("not", self.negation(self._deeper(depth)))
        return self.comparison(depth)

    def comparison(self, depth: int) -> Node:
        if self.peek() == "(":  # a condition in parentheses, or a sum that a comparison follows
            saved = self.at
            self.take()
            try:
                inner = self.condition(self._deeper(depth))
                self.expect(")")
                if self.peek() not in _COMPARE:
                    return inner
            except ValueError:
                pass
            self.at = saved
        operands = [self.sum(depth)]
        ops = []
        while self.peek() in _COMPARE:
            ops.append(self.take()[1])
            operands.append(self.sum(depth))
        if not ops:
            raise self.error("expected a comparison (<, <=, >, >=, ==, !=)" + (f", got {self.peek()!r}" if self.peek() else ""))
        return ("cmp", ops, operands)

    # numbers
    def sum(self, depth: int) -> Node:
        node = self.product(depth)
        while self.peek() in ("+", "-"):
            op = self.take()[1]
            node = ("arith", op, node, self.product(depth))
        return node

    def product(self, depth: int) -> Node:
        node = self.unary(depth)
        while self.peek() in ("*", "/"):
            op = self.take()[1]
            start = self.at
            divisor = self.unary(depth)
            if op == "/" and _constant(divisor) == 0:
                self.at = start
                raise self.error("divides by zero (a condition that does is never true)")
            node = ("arith", op, node, divisor)
        return node

    def unary(self, depth: int) -> Node:
        kind, text, _ = self.take()
        if text == "-":
            return ("neg", self.unary(self._deeper(depth)))
        if kind == "num":
            unit_kind, written = self.units.get(self.at - 1, ("", text))
            return ("num", float(text), unit_kind, written)
        if kind == "name" and text in FUNCTIONS and self.peek() == "(":
            self.take()
            args = [self.sum(self._deeper(depth))]
            while self.peek() == ",":
                self.take()
                args.append(self.sum(self._deeper(depth)))
            self.expect(")")
            if text == "abs" and len(args) != 1:
                self.at -= 1
                raise self.error("abs takes one number")
            if text != "abs" and len(args) < 2:
                self.at -= 1
                raise self.error(f"{text} takes two or more numbers ({text}(a, b), ...): it compares them")
            return ("call", text, args)
        if kind == "name":
            self.names.append(text)
            return ("name", text)
        if text == "(":
            inner = self.sum(self._deeper(depth))
            self.expect(")")
            return inner
        self.at -= 1
        raise self.error(f"expected a number or a name, got {text!r}")


def _constant(node: Node) -> float | None:
    """The value of a number node that reads no name, or None when it reads one."""
    if node[0] == "name":
        return None
    if node[0] == "neg":
        inner = _constant(node[1])
        return None if inner is None else -inner
    if node[0] == "arith" or node[0] == "call":
        parts = [_constant(n) for n in (node[2:] if node[0] == "arith" else node[2])]
        if any(p is None for p in parts):
            return None
    return float(_evaluate(node, {}))


def _evaluate(node: Node, values: Mapping[str, float]) -> Any:
    kind = node[0]
    if kind == "num":
        return node[1]
    if kind == "name":
        return float(values.get(node[1], math.nan))
    if kind == "neg":
        return -_evaluate(node[1], values)
    if kind == "arith":
        a, b = _evaluate(node[2], values), _evaluate(node[3], values)
        return a / b if node[1] == "/" else _ARITHMETIC[node[1]](a, b)
    if kind == "call":
        return FUNCTIONS[node[1]](*(_evaluate(arg, values) for arg in node[2]))
    if kind == "cmp":
        numbers = [_evaluate(operand, values) for operand in node[2]]
        if any(math.isnan(n) for n in numbers):
            return False
        return all(_COMPARE[op](a, b) for op, a, b in zip(node[1], numbers, numbers[1:]))
    if kind == "not":
        return not _evaluate(node[1], values)
    if kind == "and":
        return all(_evaluate(part, values) for part in node[1])
    return any(_evaluate(part, values) for part in node[1])  # "or"
