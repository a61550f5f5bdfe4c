"""The result of checking one scenario: what ran, each expectation's verdict, what was
measured, and why a run failed or stopped, if it did.

Source: stackdsl's own.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .expect import Verdict, describe, near_tie, past_words


@dataclass(frozen=True)
class CheckResult:
    """One scenario checked.

    Attributes:
        file, scenario, mode, model, backend: what ran (model: the stability model; backend:
            the engine, pybullet or mujoco).
        verdicts: one per expectation (empty: the file expects nothing).
        collapse_level: measured, or None when the structure stood (the highest level placed
            when the first brick moved past the collapse threshold).
        first_moved, first_moved_level: the brick that moved first and its own level (a blow
            at level 8 of a 10-level tower: collapse level 10, first moved level 8), or ``""``
            and None when the structure stood.
        moved_levels: the levels with a brick beyond the collapse threshold at the end.
        levels_placed: how many levels were built.
        simulated_time, wall_time: seconds.
        drift: metres, the largest displacement of a brick that stood (``Outcome.drift``).
        steps_per_brick: physics steps taken per placed brick.
        explanation: why the failed expectations failed, one line each (empty when all
            held; see :func:`stackdsl.verdicts.expect.explain`).
        error: one line when the run itself failed (an internal error: an exception, out of
            memory, its worker died), else empty; traceback: the exception's traceback, if any.
        stopped: one line when a guard stopped the run before its end (its wall-clock
            limit), else empty.
        folder: with a report, the folder of the run's files (:mod:`stackdsl.draw.artefacts`);
            artefacts: kind -> file name in it (trajectory, picture, graph, clip);
            draw_error: the first file that could not be drawn, one line, else empty;
            draw_time: wall seconds the drawing took.
        certificate: the proof of the verdict in one line (:func:`stackdsl.runtime.outcome.describe_certificate`),
            else empty.
        bad_input: a sweep's sample the language refuses (a drawn value out of range), the
            message at file:line:col, else empty; sweep: a sweep's measured summary, else empty
            (a sweep's verdicts are its statistical expectations, one a grid cell).
        refused: in a comparison, why the compiler refused the scene on this column's engine
            or mode (beyond what it simulates faithfully: :mod:`stackdsl.compile.limits`),
            one line, else empty; nothing ran.
        expects: in a refused cell, what the file expects (no verdict was reached), else empty.
        margin_mm: a stand's certificate margin, mm (:attr:`stackdsl.Certificate.margin_mm`), else None.
        margin: metres, the run's signed margin (:attr:`stackdsl.Outcome.margin`: positive it
            stands, negative it collapsed), else None.
        first_moved_ended: metres from its place that the brick the collapse is named after
            ended the run at, for a collapse; else None.
        threshold: the run's collapse threshold, metres (how far a brick that stays may move),
            else None.
        skipped: the reason of the file's ``skip`` mark when it holds on this run (nothing ran),
            else empty (:mod:`stackdsl.lang.schema_marks`).
        xfail: the reason of the file's ``xfail`` mark when it holds on this run, else empty;
            strict: that mark's ``strict`` (an XPASS then fails the check).
    """

    file: str
    scenario: str
    mode: str
    model: str
    verdicts: tuple[Verdict, ...]
    collapse_level: int | None
    levels_placed: int
    simulated_time: float
    wall_time: float
    drift: float = 0.0
    steps_per_brick: float = 0.0
    explanation: tuple[str, ...] = ()
    error: str = ""
    stopped: str = ""
    traceback: str = ""
    backend: str = "pybullet"
    folder: str = ""
    artefacts: tuple[tuple[str, str], ...] = ()
    draw_error: str = ""
    draw_time: float = 0.0
    bad_input: str = ""
    refused: str = ""
    sweep: str = ""
    certificate: str = ""
    first_moved: str = ""
    first_moved_level: int | None = None
    moved_levels: tuple[int, ...] = ()
    expects: str = ""
    margin_mm: float | None = None
    margin: float | None = None
    first_moved_ended: float | None = None
    threshold: float | None = None
    skipped: str = ""
    xfail: str = ""
    strict: bool = False

    @property
    def kind(self) -> str | None:
        """The kind of the verdict's proof (``"no equilibrium"``, ``"off its support"``, ...), as
        :attr:`certificate` says it; None without a certificate."""
        head = self.certificate.split(": ", 1)[0]
        return head.split(", ", 1)[1] if ", " in head else None

    @property
    def passed(self) -> bool:
        """True when the run ran, ended normally and every expectation held (an XPASS too; a
        skipped run did not run)."""
        return (
            not self.error
            and not self.stopped
            and not self.bad_input
            and not self.refused
            and not self.skipped
            and all(v.passed for v in self.verdicts)
        )

    @property
    def verdict(self) -> str:
        """The word of the run's row (:data:`VERDICTS`): ``SKIP`` when the file's ``skip`` holds on
        it; ``FAIL`` when it stopped early, hit an internal error, drew bad input or was refused
        (xfail or not); else, with an ``xfail`` mark, ``XPASS`` when every expectation held and
        ``XFAIL`` when not; without one, ``PASS``, ``INCONCLUSIVE`` when the only expectations
        not held are a sweep's undecided statistics, or ``FAIL``."""
        if self.skipped:
            return "SKIP"
        if self.error or self.stopped or self.bad_input or self.refused:
            return "FAIL"
        held = all(v.passed for v in self.verdicts)
        if self.xfail:
            return "XPASS" if held else "XFAIL"
        if held:
            return "PASS"
        return "INCONCLUSIVE" if all(v.passed or v.inconclusive for v in self.verdicts) else "FAIL"

    @property
    def held(self) -> bool:
        """Whether this result lets the check pass (exit 0): PASS, SKIP, XFAIL, and XPASS unless
        its mark is strict; not FAIL, INCONCLUSIVE (exit 1: undecided is not held) or a strict
        XPASS (pytest's meaning of strict)."""
        verdict = self.verdict
        return verdict in ("PASS", "SKIP", "XFAIL") or (verdict == "XPASS" and not self.strict)

    @property
    def expected(self) -> str:
        """The expectations, as in check's table: ``'collapse 9±1'``, ``'stands'``."""
        return ", ".join(dict.fromkeys(v.expected for v in self.verdicts)) or self.expects or "(nothing)"

    @property
    def measured(self) -> str:
        """What was measured, as in check's table: ``'collapse 13 from L13.2 (level 13), level 13
        moved'`` (:func:`stackdsl.verdicts.expect.describe`), then what the ``stays``, ``moved`` and
        ``toppled`` verdicts measured, each fact once (a ``moved: 6-12`` that held measured the
        levels the description names; a ``stays`` that failed, "levels 4-8 moved; levels 10-12
        never placed", adds the levels never placed, and "levels 3-8 moved" of levels the
        description names moved, nothing); how near a tie a collapse was (:func:`stackdsl.verdicts.expect.near_tie`);
        the error or what stopped the run when either happened."""
        if self.refused:
            return "refused"
        if self.skipped:
            return f"skipped: {self.skipped}"
        if self.error or self.stopped or self.bad_input:
            return self.error or self.stopped or "bad input in a sample"
        if self.sweep:
            return self.sweep
        first = (self.first_moved, self.first_moved_level) if self.first_moved_level is not None else None
        if self.certificate.startswith("undecided"):  # ended in motion: no verdict on the pose
            return "undecided: still moving at the end"
        past = past_words(self.collapse_level, self.moved_levels)
        facts = [describe(self.collapse_level, first), *([past] if past is not None else [])]
        if self.collapse_level is not None and (tie := near_tie(self.margin, self.first_moved_ended, self.threshold, self.kind)):
            facts.append(tie)  # a slide 0.005 mm past the threshold read as a fall
        said = set(self.moved_levels)
        for v in self.verdicts:
            if v.name not in ("stays", "moved", "toppled"):
                continue
            for fact in v.measured.split("; "):
                levels = _moved_levels(fact)
                if levels is not None and levels <= said:  # the description names these levels moved already
                    continue
                facts.append(fact)
        return ", ".join(dict.fromkeys(facts))


#: The words of check's rows, as pytest's outcomes: PASS and FAIL, SKIP (the file's skip mark),
#: XFAIL and XPASS (its xfail mark: failed as expected, or passed), and INCONCLUSIVE (a sweep's
#: statistic its samples did not decide).
VERDICTS = ("PASS", "FAIL", "INCONCLUSIVE", "SKIP", "XFAIL", "XPASS")


def _moved_levels(fact: str) -> set[int] | None:
    """The levels a fact such as ``"levels 3-5, 8 moved"`` or ``"level 3 moved"`` names, else None."""
    match = re.fullmatch(r"levels? ([0-9, -]+) moved", fact)
    if match is None:
        return None
    levels: set[int] = set()
    for part in match[1].split(","):
        first, _, last = part.strip().partition("-")
        if not first.isdigit() or (last and not last.isdigit()):
            return None
        levels |= set(range(int(first), int(last or first) + 1))
    return levels
