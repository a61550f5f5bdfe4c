"""``-k EXPR`` of ``stackdsl check`` and ``compare``: pytest's keyword expressions over scenarios.

An expression is words joined by ``and``, ``or`` and ``not``, with parentheses; a word matches a
scenario when its file's path or its name contains the word, ignoring case, as pytest's ``-k``
matches a test by the names of the test and its parents (pytest matches each of those names
alone; here the path is one text, so a word may hold a ``/``: ``-k "hard/ and not slant"``). The
grammar is pytest's (``_pytest/mark/expression.py``), without the ``name(key=value)`` form
that only ``-m`` uses::

    expression := [expr] end
    expr       := and_expr ("or" and_expr)*
    and_expr   := not_expr ("and" not_expr)*
    not_expr   := "not" not_expr | "(" expr ")" | word
    word       := (letter, digit, "_", ":", "+", "-", ".", "[", "]", "\\", "/")+

An empty expression matches every scenario. stackdsl has its own parser so that its core does
not need pytest (a test extra).

>>> parse_keywords("tower and not (slant or hard/)").matches("scenarios/Four_Tower.yaml", "four tower")
True
>>> parse_keywords("tower and not (slant or hard/)").matches("scenarios/hard/tower.yaml", "tower")
False

Source: pytest's ``-k`` grammar and matching (docs.pytest.org, "Specifying which tests to run");
the code is stackdsl's own.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

_WORD = re.compile(r"(?:[\w:+\-.\[\]\\/])+")
_KEYWORDS = ("and", "or", "not")
#: Nesting of parentheses and ``not`` at most (a longer one is no selection a person writes).
MAX_DEPTH = 100

Match = Callable[[str], bool]


class KeywordError(ValueError):
    """A ``-k`` expression that cannot be read: the message names the column (1-based) and what
    was expected there."""


@dataclass(frozen=True)
class Keywords:
    """A parsed ``-k`` expression: its text and a function of a text to match against (the
    scenario's path or name, folded) that says whether it is selected."""

    text: str
    _test: Callable[[Match], bool]

    def matches(self, *names: str) -> bool:
        """Whether a scenario whose path and name are ``names`` is selected: each word of the
        expression holds when one of ``names`` contains it, ignoring case."""
        folded = [n.casefold() for n in names]
        return self._test(lambda word: any(word in n for n in folded))


def parse_keywords(text: str) -> Keywords:
    """Parse a ``-k`` expression (the module's grammar).

    Raises:
        KeywordError: it does not follow the grammar: ``at column 7: expected a word, 'not' or
            '(' after 'and'; got the end of the expression``.
    """
    tokens = _tokens(text)
    parser = _Parser(text, tokens)
    if not tokens:
        return Keywords(text, lambda match: True)
    test = parser.expr(0)
    if parser.at < len(tokens):
        _, word, column = tokens[parser.at]
        raise KeywordError(f"at column {column}: expected 'and', 'or' or the end; got {word!r}")
    return Keywords(text, test)


def _tokens(text: str) -> list[tuple[str, str, int]]:
    """(kind, text, column) of each token: ``(``, ``)``, a keyword, or a word (folded)."""
    out = []
    at = 0
    while at < len(text):
        if text[at].isspace():
            at += 1
            continue
        if text[at] in "()":
            out.append((text[at], text[at], at + 1))
            at += 1
            continue
        found = _WORD.match(text, at)
        if found is None:
            raise KeywordError(
                f"at column {at + 1}: {text[at]!r} is in no word: a word is letters, digits and _ : + - . [ ] \\ /"
            )
        word = found.group()
        out.append(("keyword" if word in _KEYWORDS else "word", word if word in _KEYWORDS else word.casefold(), at + 1))
        at = found.end()
    return out


class _Parser:
    def __init__(self, text: str, tokens: list[tuple[str, str, int]]) -> None:
        self.text, self.tokens, self.at = text, tokens, 0

    def _peek(self) -> str | None:
        return self.tokens[self.at][1] if self.at < len(self.tokens) else None

    def _expected(self, what: str) -> KeywordError:
        after = f" after {self.tokens[self.at - 1][1]!r}" if self.at else ""
        if self.at < len(self.tokens):
            _, word, column = self.tokens[self.at]
            return KeywordError(f"at column {column}: expected {what}{after}; got {word!r}")
        return KeywordError(f"at column {len(self.text) + 1}: expected {what}{after}; got the end of the expression")

    def expr(self, depth: int) -> Callable[[Match], bool]:
        parts = [self.and_expr(depth)]
        while self._peek() == "or":
            self.at += 1
            parts.append(self.and_expr(depth))
        return parts[0] if len(parts) == 1 else lambda match: any(p(match) for p in parts)

    def and_expr(self, depth: int) -> Callable[[Match], bool]:
        parts = [self.not_expr(depth)]
        while self._peek() == "and":
            self.at += 1
            parts.append(self.not_expr(depth))
        return parts[0] if len(parts) == 1 else lambda match: all(p(match) for p in parts)

    def not_expr(self, depth: int) -> Callable[[Match], bool]:
        if depth > MAX_DEPTH:
            raise self._expected(f"at most {MAX_DEPTH} nested 'not's and parentheses; a word")
        if self.at >= len(self.tokens):
            raise self._expected("a word, 'not' or '('")
        kind, word, _ = self.tokens[self.at]
        if word == "not":
            self.at += 1
            inner = self.not_expr(depth + 1)
            return lambda match: not inner(match)
        if kind == "(":
            self.at += 1
            inner = self.expr(depth + 1)
            if self._peek() != ")":
                raise self._expected("')'")
            self.at += 1
            return inner
        if kind != "word":
            raise self._expected("a word, 'not' or '('")
        self.at += 1
        return lambda match: match(word)
