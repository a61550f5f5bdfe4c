"""pytest's marks in a scenario file: ``skip`` and ``xfail``, each with a reason and an optional
condition on the run (the engine's backend and mode, the stability model), as pytest's
``skipif`` and ``xfail(condition, reason=..., strict=...)`` give them to a test::

    skip: {reason: "MuJoCo's contacts let the vee slide", when: "backend == mujoco"}
    xfail: {reason: "raw pybullet drops it at level 9", when: "mode == raw", strict: true}

``when`` is a condition of the grammar of ``require:`` (:mod:`stackdsl.lang.expressions`: ``and``,
``or``, ``not``, parentheses) that compares words with ``==`` and ``!=``: ``backend`` with
``pybullet`` or ``mujoco``, ``mode`` with ``raw``, ``tuned`` or ``extension``, ``model`` with
``report`` or ``equilibrium``; without it the mark holds on every run. A run's backend, mode and
model are the ones it runs with: the file's, or what ``stackdsl check --backend/--mode/--model``
or a ``compare`` column puts in their place. ``strict`` is pytest's: an xfail run whose
expectations all hold (XPASS) fails the check; not given, it is false (under pytest, its
``strict_xfail`` setting).

Source: stackdsl's own, after pytest's skip and xfail marks (docs.pytest.org, "How to use skip
and xfail to deal with tests that cannot succeed").
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, Field, StrictBool, model_validator

from .bounds import StrictModel
from .expressions import MAX_CONDITION, Node, parse

#: What a mark's condition reads: each field of the run and the words it may be.
RUN_WORDS: dict[str, tuple[str, ...]] = {
    "backend": ("pybullet", "mujoco"),
    "mode": ("raw", "tuned", "extension"),
    "model": ("report", "equilibrium"),
}
#: A reason's length at most (it is shown on one line).
MAX_REASON = 500
_READS = "; ".join(f"{field} ({', '.join(words)})" for field, words in RUN_WORDS.items())
_EXAMPLE = "'backend == mujoco and mode != extension'"
_OF_WORD = {word: field for field, words in RUN_WORDS.items() for word in words}
#: Each word a number of its own, so that the grammar's == and != compare words.
_CODES = {word: float(i) for i, word in enumerate([*RUN_WORDS, *_OF_WORD], 1)}


def check_condition(text: str) -> str:
    """``text`` when it is a condition a mark takes: the grammar of :mod:`stackdsl.lang.expressions`,
    each comparison a field of :data:`RUN_WORDS` ``==`` or ``!=`` one of its words.

    Raises:
        ValueError: anything else, saying what the condition reads and an example.

    >>> check_condition("backend == mujoco or (mode == raw and not model == equilibrium)")
    'backend == mujoco or (mode == raw and not model == equilibrium)'
    >>> check_condition("backend == raw")
    Traceback (most recent call last):
    ...
    ValueError: 'raw' is a mode, not a backend: compare backend with pybullet or mujoco
    """
    _check(parse(text).tree)
    return text


def _check(node: Node) -> None:
    """Check a parsed mark's condition: ``and``, ``or`` and ``not`` of comparisons of words.

    Raises:
        ValueError: at the first part that is not such a comparison.
    """
    kind = node[0]
    if kind in ("and", "or"):
        for part in node[1]:
            _check(part)
        return
    if kind == "not":
        _check(node[1])
        return
    if kind != "cmp":  # a bare number or name where a comparison goes: the grammar refuses it first
        raise ValueError(f"expected a comparison such as {_EXAMPLE}")
    _check_comparison(node[1], node[2])


def _check_comparison(ops: list[str], operands: list[Node]) -> None:
    """Check one comparison of a mark's condition (its operators ``ops`` and ``operands``): one
    ``==`` or ``!=`` between a field (backend, mode, model) and one of that field's words.

    Raises:
        ValueError: naming the operator, the operand or the word that does not fit.
    """
    if len(ops) != 1 or ops[0] not in ("==", "!="):
        shown = next((op for op in ops if op not in ("==", "!=")), ops[0])
        raise ValueError(f"compares with {shown!r}: a mark's condition compares words with == or != ({_EXAMPLE})")
    if any(operand[0] != "name" for operand in operands):
        raise ValueError(f"a mark's condition compares words, not numbers: it reads {_READS}")
    a, b = (operand[1] for operand in operands)
    unknown = next((n for n in (a, b) if n not in RUN_WORDS and n not in _OF_WORD), None)
    if unknown is not None:
        raise ValueError(f"{unknown!r} is not a word a mark's condition reads: it reads {_READS}")
    field, word = (a, b) if a in RUN_WORDS else (b, a)
    if field not in RUN_WORDS:
        raise ValueError(f"compares {a} with {b}: compare backend, mode or model with one of its words ({_EXAMPLE})")
    if word in RUN_WORDS:
        raise ValueError(f"compares {a} with {b}: compare each with one of its own words: {_READS}")
    if word not in RUN_WORDS[field]:
        owner = _OF_WORD[word]
        raise ValueError(f"{word!r} is a {owner}, not a {field}: compare {field} with {' or '.join(RUN_WORDS[field])}")


def condition_holds(text: str | None, backend: str, mode: str, model: str) -> bool:
    """Whether a mark's condition ``text`` (:func:`check_condition`) holds on a run with this
    ``backend``, ``mode`` and stability ``model``; True when there is none (the mark is
    unconditional).

    >>> condition_holds("backend == mujoco and mode != raw", "mujoco", "extension", "report")
    True
    >>> condition_holds("not (model == report)", "pybullet", "raw", "report")
    False
    """
    if text is None:
        return True
    values = {**_CODES, **{field: _CODES.get(value, -1.0) for field, value in zip(RUN_WORDS, (backend, mode, model))}}
    return parse(text).holds(values)


def _one_line(text: str) -> str:
    if not text.strip():
        raise ValueError("give the reason in words: it is shown beside the scenario")
    if any(c in text for c in "\n\r\t\x0b\x0c"):
        raise ValueError("a reason is one line of text (it is shown on the scenario's row)")
    return text


#: One line with a word in it (the schema's words for :func:`_one_line`), with no ``$`` (Python's
#: matches before a last newline, ECMA-262's does not).
_ONE_LINE = r"^(?![\s\S]*[\n\r\t\v\f])[\s\S]*\S"
Reason = Annotated[
    str, Field(min_length=1, max_length=MAX_REASON, json_schema_extra={"pattern": _ONE_LINE}), AfterValidator(_one_line)
]
When = Annotated[str, Field(min_length=1, max_length=MAX_CONDITION), AfterValidator(check_condition)]


class Skip(StrictModel):
    """``skip``: the scenario is not run (on the runs ``when`` holds on), and says why: a SKIP row
    with ``reason`` in ``stackdsl check``, pytest's skip (``s``) under pytest. A skipped run is
    not compiled: what the compiler alone refuses is not said. Source: stackdsl's own, after
    pytest's ``skip``/``skipif``."""

    reason: Reason
    when: When | None = None

    @model_validator(mode="before")
    @classmethod
    def _a_mapping(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            raise ValueError(
                "give a reason, and a condition if the mark is for some runs only: {reason: 'why', when: 'backend == mujoco'}"
            )
        return data

    def applies(self, backend: str, mode: str, model: str) -> bool:
        """Whether the mark holds on a run with this backend, mode and stability model."""
        return condition_holds(self.when, backend, mode, model)


class XFail(Skip):
    """``xfail``: the scenario runs and is expected to fail (on the runs ``when`` holds on). A run
    whose expectations do not all hold is XFAIL, which passes the check; one whose expectations
    all hold is XPASS, which passes unless ``strict`` (pytest's meaning: then it fails the check,
    so that a fix is noticed and the mark removed). A run that stopped (a timeout) or hit an
    internal error is no expected failure: it fails as any run does. Source: stackdsl's own,
    after pytest's ``xfail``."""

    strict: StrictBool | None = None


def _given(value: Any) -> Any:
    if value is None:
        raise ValueError(
            "no value: give {reason: 'why'} (and when: 'backend == mujoco' for some runs only), or leave the key out"
        )
    return value


def _no_null(schema: dict[str, Any]) -> None:
    """A mark written with no value is refused (:func:`_given`): the schema says so too."""
    schema["anyOf"] = [s for s in schema.get("anyOf", []) if s != {"type": "null"}]
    schema.pop("default", None)


#: The scenario's ``skip`` and ``xfail`` fields: a mark, or none when the key is left out.
SkipMark = Annotated[Skip | None, BeforeValidator(_given), Field(json_schema_extra=_no_null)]
XFailMark = Annotated[XFail | None, BeforeValidator(_given), Field(json_schema_extra=_no_null)]

#: The marks' docs for the JSON Schema (:mod:`stackdsl.lang.schema_docs` form: schema object ->
#: key -> (description, example)).
MARK_DOCS: dict[str, dict[str, tuple[str, Any]]] = {
    "": {
        "skip": (
            "Do not run this scenario, and say why: {reason, when}; when (optional) is a condition on the run: "
            "backend (pybullet, mujoco), mode (raw, tuned, extension), model (report, equilibrium), with ==, !=, "
            "and, or, not.",
            {"reason": "MuJoCo's contacts let the vee slide", "when": "backend == mujoco"},
        ),
        "xfail": (
            "This scenario is expected to fail: {reason, when, strict}; its failure passes the check (XFAIL), and "
            "with strict: true its passing fails it (XPASS).",
            {"reason": "raw pybullet drops it at level 9", "when": "mode == raw", "strict": True},
        ),
    },
    "Skip": {
        "reason": ("Why the scenario is skipped: one line, shown on its row.", "MuJoCo's contacts let the vee slide"),
        "when": (
            "The runs the mark is for (default: every run): backend, mode and model compared with their words "
            "by == and !=, joined by and, or, not.",
            "backend == mujoco",
        ),
    },
    "XFail": {
        "reason": ("Why the scenario is expected to fail: one line, shown on its row.", "raw pybullet drops it at level 9"),
        "when": (
            "The runs the mark is for (default: every run): backend, mode and model compared with their words "
            "by == and !=, joined by and, or, not.",
            "mode == raw",
        ),
        "strict": (
            "Whether passing fails the check (pytest's strict xfail; default false, under pytest its strict_xfail setting).",
            True,
        ),
    },
}
