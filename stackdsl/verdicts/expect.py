"""Outcome + expectations -> verdicts.

Source: stackdsl's own (docs/design.md, words: collapse level).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from numbers import Real

from pydantic import BaseModel, ConfigDict

from ..lang.bounds import MAX_SIDE
from ..lang.errors import Location, excerpt
from ..lang.expectations import CollapseLevel, Expect, Still, bricks_of, levels_of, selects, span
from ..runtime.outcome import Outcome


class Verdict(BaseModel):
    """One expectation checked: what was expected, what was measured, and whether it held.

    Attributes:
        name: the expectation's key (``collapse``, ``stays``...; ``finished`` for a run stopped early).
        at: where the expectation was written (file, line, column, the line's text), when it was
            read from a file.
        inconclusive: decided neither way (not passed, not failed either): a sweep's statistic
            whose 95% interval holds both (:mod:`stackdsl.verdicts.stats`), or a run that ended
            with bricks still moving and no collapse proved (its certificate ``undecided``).
    """

    model_config = ConfigDict(frozen=True)

    name: str
    passed: bool
    expected: str
    measured: str
    at: Location | None = None
    inconclusive: bool = False

    def lines(self) -> list[str]:
        """This verdict as a failure says it, pointing at its expectation as a parse error points
        at a field: ``file:line:col: expect.NAME: expected ..., measured ...``, then the line and a
        caret (:func:`stackdsl.lang.errors.excerpt`); without a place, the words alone."""
        said = f"expected {self.expected}, measured {self.measured}"
        if self.at is None:
            return [said]
        return [f"{self.at}: expect.{self.name}: {said}", *excerpt(self.at.source_line, self.at.column)]


def located_lines(verdicts: Iterable[Verdict]) -> list[str]:
    """The :meth:`Verdict.lines` of each failed verdict that knows where its expectation was written."""
    return [line for v in verdicts if not v.passed and v.at is not None for line in v.lines()]


def evaluate(expect: Expect, outcome: Outcome, threshold: float) -> list[Verdict]:
    """Check ``outcome`` against ``expect``; ``threshold`` (m) is how far a brick that
    stays in place may move (a compiled program's ``collapse_threshold``). ``may_fall``
    levels are not checked. An empty list means nothing was expected. A run stopped early
    (``outcome.stopped``, a timeout) adds a failed ``finished`` verdict: what it did not
    simulate was not checked.

    Raises:
        ValueError: ``threshold`` is not a finite number of metres above 0 and at most
            :data:`~stackdsl.lang.bounds.MAX_SIDE` (10 m, a scenario's own bound on it).
        TypeError: ``threshold`` is not a number (a string, a bool).
    """
    check_threshold(threshold)
    verdicts = []
    measured = describe_outcome(outcome, threshold)
    texts = expected_texts(expect)
    if isinstance(expect.collapse, CollapseLevel):  # a sweep's statistics are decided over its samples
        c = expect.collapse
        passed = outcome.collapse is not None and abs(outcome.collapse.level - c.level) <= c.tolerance
        verdicts.append(Verdict(name="collapse", passed=passed, expected=texts["collapse"], measured=measured))
    if expect.stands:
        verdicts.append(Verdict(name="stands", passed=outcome.collapse is None, expected="stands", measured=measured))
    if expect.stands_until is not None:
        until = expect.stands_until
        held = outcome.collapse is None or outcome.collapse.time >= until
        said = "stands" if outcome.collapse is None else f"{measured} at {outcome.collapse.time:.2f} s"
        verdicts.append(Verdict(name="stands_until", passed=held, expected=texts["stands_until"], measured=said))
    if expect.stays:
        verdicts.append(_stays_verdict(expect.stays, outcome, threshold))
    if expect.moved:
        verdicts.append(_moved_verdict(expect.moved, outcome, threshold))
    if expect.toppled is not None:
        least, most = expect.toppled.allows(len(outcome.displacement) + len(outcome.unplaced))
        verdicts.append(_toppled_verdict(outcome, least, most, texts["toppled"]))
    if expect.still is not None:
        verdicts.append(_still(expect.still, outcome, texts["still"]))
    if outcome.stopped:
        verdicts = [_stopped(v, expect, outcome) for v in verdicts]
        verdicts.append(Verdict(name="finished", passed=False, expected="the run finishes", measured=outcome.stopped))
    elif outcome.certificate is not None and outcome.certificate.verdict == "undecided":
        verdicts = [_undecided(v, outcome.certificate.detail) for v in verdicts]
    elif outcome.kinetic_energy > STILL_MOVING:
        verdicts = [_cut_off(v, expect, outcome) for v in verdicts]
    return [v.model_copy(update={"at": expect.at(v.name)}) if expect.at(v.name) else v for v in verdicts]


def _stays_verdict(selectors: Sequence[int | str], outcome: Outcome, threshold: float) -> Verdict:
    """The ``stays`` verdict: none of the levels and bricks ``selectors`` name moved more than
    ``threshold`` (m), and all of them were placed."""
    levels, bricks = levels_of(selectors), bricks_of(selectors)
    moved = _moved_levels(outcome, threshold)
    bad = sorted(set(levels) & moved)
    bad_bricks = [b for b in _selected(outcome, bricks) if outcome.displacement[b] > threshold]
    never = _never(outcome, levels, bricks)
    said = _said(levels, bricks, _named(outcome, bricks))
    wrong = ([_said(bad, _short(bad_bricks)) + " moved"] if bad or bad_bricks else []) + ([never] if never else [])
    if wrong:
        return Verdict(name="stays", passed=False, expected=f"{said} stay", measured="; ".join(wrong))
    # how near it came: a push that moved level 4 2.4 mm against a 4 mm threshold read "levels 1-4
    # stayed" as one that moved nothing, beside a setting that moved it 4.8 mm and failed
    at_level = _levels(outcome)
    named = [b for b, lv in at_level.items() if lv in levels and b in outcome.displacement] + _selected(outcome, bricks)
    most = max((outcome.displacement[b] for b in named), default=0.0)
    # in brackets, of the bricks named: "levels 1-2 stayed, moved 4.6 mm at most" read as though
    # the structure had moved that far besides
    near = f" (moved {millimetres(most, against=threshold)} at most)" if most >= SHOWN_STAYED else ""
    return Verdict(name="stays", passed=True, expected=f"{said} stay", measured=f"{said} stayed{near}")


#: Metres from which a ``stays`` that held says how far its bricks moved at most (1 mm).
SHOWN_STAYED = 0.001


def _moved_verdict(selectors: Sequence[int | str], outcome: Outcome, threshold: float) -> Verdict:
    """The ``moved`` verdict: every brick of the levels and bricks ``selectors`` name moved more
    than ``threshold`` (m), and all of them were placed."""
    levels, bricks = levels_of(selectors), bricks_of(selectors)
    named = _selected(outcome, bricks) + [b for b, lv in _levels(outcome).items() if lv in levels and b in outcome.displacement]
    still = [b for b in dict.fromkeys(named) if outcome.displacement[b] <= threshold]
    never = _never(outcome, levels, bricks)
    said = _said(levels, bricks, _named(outcome, bricks))
    wrong = ([f"{', '.join(_short(still))} stayed"] if still else []) + ([never] if never else [])
    return Verdict(name="moved", passed=not wrong, expected=f"{said} moved", measured="; ".join(wrong) or f"{said} moved")


def _toppled_verdict(outcome: Outcome, least: int, most: int, expected: str) -> Verdict:
    """The ``toppled`` verdict: between ``least`` and ``most`` bricks ended tilted past their
    tipping angle, of all the scene's bricks, placed or not."""
    count, total = len(outcome.toppled), len(outcome.displacement) + len(outcome.unplaced)
    never = f" ({len(outcome.unplaced)} never placed)" if outcome.unplaced else ""
    return Verdict(
        name="toppled", passed=least <= count <= most, expected=expected, measured=f"{count} of {total} toppled{never}"
    )


def _still(still: Still, outcome: Outcome, expected: str) -> Verdict:
    """The ``still`` verdict: the run's largest tilt and slip (:attr:`Outcome.peak_tilt`,
    :attr:`Outcome.peak_slip`) within their bounds; failed when the run did not measure them
    (an outcome built without the scenario's expectation, or an engine that simulates no motion)."""
    if outcome.peak_tilt is None or outcome.peak_slip is None:
        return Verdict(name="still", passed=False, expected=expected, measured="no motion measured (no engine steps)")
    measured = f"tilted at most {math.degrees(outcome.peak_tilt):.3g} deg, slipped at most {outcome.peak_slip * 1000:.3g} mm"
    return Verdict(
        name="still", passed=still.margin(outcome.peak_tilt, outcome.peak_slip) >= 0, expected=expected, measured=measured
    )


def _undecided(verdict: Verdict, why: str) -> Verdict:
    """A verdict of a run that ended with bricks still moving and no collapse proved: what the
    final state would say is not known yet (inconclusive), save what held whatever comes
    (``stands_until``: no collapse before its time)."""
    if verdict.name == "stands_until" and verdict.passed:
        return verdict
    return verdict.model_copy(update={"passed": False, "inconclusive": True, "measured": f"undecided: {why}"})


def _stopped(verdict: Verdict, expect: Expect, outcome: Outcome) -> Verdict:
    """A verdict of a run stopped early (a timeout): what the rest of the run would have said is
    not known (inconclusive, not failed: the run's ``finished`` verdict fails it), save what was
    decided for good before it stopped: a collapse (its level, and that the stack did not stand),
    ``stands_until`` once its time or a collapse came, a brick moved that must stay, more
    toppled than allowed, a bound of ``still`` passed. Source: stackdsl's own."""
    name, collapse = verdict.name, outcome.collapse
    if name in ("collapse", "stands"):
        final = collapse is not None
    elif name == "stands_until":
        final = collapse is not None or (expect.stands_until is not None and outcome.simulated_time >= expect.stands_until)
    elif name == "toppled" and expect.toppled is not None:
        _, most = expect.toppled.allows(len(outcome.displacement) + len(outcome.unplaced))
        final = len(outcome.toppled) > most
    else:  # stays, still: failed for good once failed; moved: a brick may move yet
        final = name in ("stays", "still") and not verdict.passed
    if final:
        return verdict
    why = f"not decided: the run stopped at t = {outcome.simulated_time:.2f} s (so far: {verdict.measured})"
    return verdict.model_copy(update={"passed": False, "inconclusive": True, "measured": why})


def _cut_off(verdict: Verdict, expect: Expect, outcome: Outcome) -> Verdict:
    """A failed final-state verdict of a run that ended with its bricks still moving (kinetic
    energy above :data:`STILL_MOVING`), a collapse decided or not, that the motion may still turn:
    fewer toppled than the least asked (a domino chain the run's end cut off), or a brick asked
    to move that has not yet. Undecided, as a run ended in motion with no collapse proved is;
    a brick that moved where it must stay, or more toppled than allowed, has failed whatever
    comes. Source: stackdsl's own."""
    if verdict.passed:
        return verdict
    ended = f"the run ended at t={outcome.simulated_time:.2f} s with its bricks still moving"
    if verdict.name == "toppled" and expect.toppled is not None:
        least, _ = expect.toppled.allows(len(outcome.displacement) + len(outcome.unplaced))
        if len(outcome.toppled) < least:
            return _undecided(verdict, f"{verdict.measured} when {ended}")
    if verdict.name == "moved" and expect.moved and not _never(outcome, levels_of(expect.moved), bricks_of(expect.moved)):
        return _undecided(verdict, f"{verdict.measured} when {ended}")
    return verdict


def check_threshold(threshold: float) -> None:
    """Refuse a collapse threshold no scenario could have: it must be a number of metres,
    finite, above 0 and at most :data:`~stackdsl.lang.bounds.MAX_SIDE` (the bound a scenario's
    ``collapse_threshold`` has; a brick's half side, the default, is within it too). Below 0
    every brick has moved and none has; above, the number was most likely millimetres.

    Raises:
        TypeError: ``threshold`` is not a number (a string, a bool).
        ValueError: ``threshold`` is not finite, not above 0 or above 10 m.
    """
    if isinstance(threshold, bool) or not isinstance(threshold, Real):
        raise TypeError(f"threshold must be a number of metres, not {threshold!r}")
    if not 0.0 < threshold < math.inf:
        raise ValueError(f"threshold must be a finite number of metres above 0 (KAPLA's default: 0.004), not {threshold!r}")
    if threshold > MAX_SIDE:
        raise ValueError(
            f"threshold is in metres: {threshold!r} m is more than any brick is long ({MAX_SIDE:g} m);"
            f" for {threshold:g} mm, give {threshold / 1000:g}"
        )


def expected_texts(expect: Expect) -> dict[str, str]:
    """What ``expect`` asks, in the words of its verdicts' ``expected``, by expectation name,
    before anything ran (a run's ``stays`` and ``moved`` can say "bricks" where a selector named
    a part of several): ``{"collapse": "collapse 9±1", "stays": "levels 1-3 stay"}``. A sweep's
    statistics are left out (their verdicts are the sweep's). Source: stackdsl's own.

    >>> from stackdsl.lang.expectations import Expect
    >>> expected_texts(Expect.model_validate({"collapse": "9 +- 1", "stays": "1-3"}))
    {'collapse': 'collapse 9±1', 'stays': 'levels 1-3 stay'}
    """
    texts = {}
    if isinstance(expect.collapse, CollapseLevel):
        c = expect.collapse
        texts["collapse"] = f"collapse {c.level}" + (f"±{c.tolerance}" if c.tolerance else "")
    if expect.stands:
        texts["stands"] = "stands"
    if expect.stands_until is not None:
        texts["stands_until"] = f"stands until {expect.stands_until:g} s"
    if expect.stays:
        texts["stays"] = f"{_said(levels_of(expect.stays), bricks_of(expect.stays))} stay"
    if expect.moved:
        texts["moved"] = f"{_said(levels_of(expect.moved), bricks_of(expect.moved))} moved"
    if expect.toppled is not None:
        texts["toppled"] = f"{expect.toppled.text()} toppled"
    if expect.still is not None:
        texts["still"] = f"keeps still: {expect.still.text()}"
    return texts


def _moved_levels(outcome: Outcome, threshold: float) -> set[int]:
    levels = _levels(outcome)
    return {lv for b, d in outcome.displacement.items() if d > threshold and (lv := levels.get(b)) is not None}


def moved_levels(outcome: Outcome, threshold: float) -> tuple[int, ...]:
    """The levels of the structure bricks more than ``threshold`` (m) from their placed pose at
    the end of the run, ascending: where a collapse (or a blow) left the structure. Source:
    stackdsl's own (docs/design.md, words: collapse level)."""
    return tuple(sorted(_moved_levels(outcome, threshold)))


def describe_outcome(outcome: Outcome, threshold: float) -> str:
    """What a run measured, in words (:func:`describe`): the collapse level, the brick that
    moved first and its level, and the levels moved at the end (``threshold`` in m), or, of a
    collapse, that no brick was past the threshold at the end (:data:`NONE_PAST`: a brick that
    came to rest past it and crept back, or a fall statics proved that the engine's contacts
    held); a run that ended with bricks still moving and no collapse proved is "undecided", not
    "stands"."""
    c = outcome.collapse
    level = c.level if c is not None else None
    said = describe(level, (c.brick, c.brick_level) if c is not None else None)
    if (past := past_words(level, moved_levels(outcome, threshold))) is not None:
        said += f", {past}"
    if c is None and outcome.certificate is not None and outcome.certificate.verdict == "undecided":
        return said.replace("stands", "undecided: still moving at the end", 1)
    kind = outcome.certificate.kind if outcome.certificate is not None else None
    if c is not None and (tie := near_tie(outcome.margin, outcome.displacement.get(c.brick), threshold, kind)):
        said += f", {tie}"
    return said


NEAR_TIE = 0.001
"""Metres past its limit under which a collapse is said to be a near tie (:func:`near_tie`)."""


def near_tie(margin: float | None, ended: float | None, threshold: float | None, kind: str | None = None) -> str:
    """``"0.0 mm past its limit, a near tie"`` for a collapse decided less than :data:`NEAR_TIE`
    past its limit (``margin``: the deciding proof's signed margin, m, :attr:`Outcome.margin`)
    whose first brick also ended less than that past ``threshold`` (``ended``: m from its place);
    else "" (and when any is unknown). A new user read "collapse 8 from L02.2, level 2 moved" of
    a wall that stood with one brick slid 4.0 mm against a 4 mm threshold as a fall: run's,
    check's and compare's words say it alike. A collapse statics decided at the end (``kind``
    "no equilibrium", whose margin is no distance) with its first brick within the threshold
    says that instead: "0.0 mm past its limit" read as a measure of a card house whose brick had
    moved 0.95 mm."""
    if margin is None or ended is None or threshold is None:
        return ""
    past = max(-margin, ended - threshold)
    if past >= NEAR_TIE:
        return ""
    if kind == "no equilibrium" and ended < threshold:
        return "no equilibrium at the end, a near tie"
    return f"{max(past, 0.0) * 1000:.1f} mm past its limit, a near tie"


NONE_PAST = "no brick past the threshold at the end"
"""Said of a collapse when no structure brick is past the collapse threshold at the end of the
run: the collapse was decided on a brick that was (at rest past it, or falling by a proof), or
on statics (a part placed off its support), and the levels moved at the end are none."""


def past_words(collapse_level: int | None, moved: Sequence[int]) -> str | None:
    """What a run's end says of the levels ``moved`` past the threshold, after :func:`describe`
    of its collapse level: "levels 8-10 moved", :data:`NONE_PAST` of a collapse with none, or
    None (a stand with none). The words of run's and check's descriptions alike."""
    if moved:
        return levels_moved(moved)
    return NONE_PAST if collapse_level is not None else None


def _levels(outcome: Outcome) -> dict[str, int | None]:
    return {n.id: n.level for n in outcome.final_graph.nodes}


def _selected(outcome: Outcome, selectors: tuple[str, ...]) -> list[str]:
    """The structure bricks (of the outcome's displacements) that ``selectors`` name, in order."""
    return [b for b in outcome.displacement if any(selects(s, b) for s in selectors)]


def _named(outcome: Outcome, selectors: tuple[str, ...]) -> int:
    """How many structure bricks ``selectors`` name, placed or not (a part whose second brick a
    collapse left unplaced is still 'bricks deck')."""
    return len(_selected(outcome, selectors)) + sum(any(selects(s, b) for s in selectors) for b in outcome.unplaced)


def _never(outcome: Outcome, levels: Sequence[int], selectors: tuple[str, ...]) -> str:
    """The named levels and bricks that were never placed (building stops at a collapse), in
    words ("level 3, brick pyr.L02.1 never placed"), or "": nothing of them can stay or move."""
    levels_never = [lv for lv in levels if lv > outcome.levels_placed]
    bricks_never = [b for b in outcome.unplaced if any(selects(s, b) for s in selectors)]
    return f"{_said(levels_never, _short(bricks_never))} never placed" if levels_never or bricks_never else ""


def _said(levels: Iterable[int], bricks: Iterable[str], selected: int = 1) -> str:
    """``"levels 1-3, bricks L05.2, left.L01.1"``; one selector that names more than one brick
    (``selected``: how many the selectors name), a part's or a level's prefix, is "the bricks of"
    it: ``"the bricks of deck"``."""
    levels, bricks = list(levels), list(bricks)
    if len(bricks) == 1 and selected > 1:
        named = [f"the bricks of {bricks[0]}"]
    else:
        named = [f"brick{'s' * (len(bricks) != 1)} {', '.join(bricks)}"] if bricks else []
    return ", ".join(([f"level{'s' * (len(levels) != 1)} {span(levels)}"] if levels else []) + named)


def _short(ids: list[str]) -> list[str]:
    """At most :data:`MOVED_SHOWN` ids, and how many more."""
    return ids[:MOVED_SHOWN] + ([f"{len(ids) - MOVED_SHOWN} more"] if len(ids) > MOVED_SHOWN else [])


#: At most this many moved bricks are named for a failed ``stays``; the rest are counted.
MOVED_SHOWN = 3

#: Joules of the structure's bricks at the end above which a failed final-state expectation says
#: they were still moving (a KAPLA brick at 43 mm/s): a domino chain cut off by the run's end
#: read as a chain that stopped.
STILL_MOVING = 1e-5


def explain(expect: Expect, outcome: Outcome, threshold: float) -> list[str]:
    """Why the expectations that failed did so, one line each, from the outcome's collapse
    record and its displacements: which brick moved, how far (mm), when (s) and at what
    level. Empty when every expectation held (see :func:`evaluate`; ``threshold`` in m).

    - collapse, stands or stands_until failed and the structure collapsed: the brick that moved first,
      its displacement when detected, the time and how many levels were placed;
    - a collapse was expected but the structure stood: the largest displacement at the
      end and its brick;
    - stays failed: the bricks of the levels that must stay that moved beyond
      ``threshold`` by the end, the farthest first (at most :data:`MOVED_SHOWN`);
    - under any failure, the actions the collapse left undone (:func:`not_run_line`);
    - a run that ended with bricks still moving and no collapse proved (its certificate
      ``undecided``): that, with the largest displacement then, and nothing else.

    Source: stackdsl's own.
    """
    failed = {v.name for v in evaluate(expect, outcome, threshold) if not v.passed}
    levels = _levels(outcome)
    if failed and outcome.certificate is not None and outcome.certificate.verdict == "undecided":
        return _undecided_lines(outcome, levels)
    lines = []
    if failed & {"collapse", "stands", "stands_until"}:
        lines.append(_collapse_line(outcome, threshold, levels))
    if "moved" in failed and expect.moved:
        lines += _stayed_lines(expect.moved, outcome, threshold, levels)
    if "toppled" in failed:
        lines.append(_toppled_line(outcome))
    if "finished" in failed:
        lines.append(f"stopped: {outcome.stopped}; the rest of the run was not simulated")
    # what more settling may still turn (a brick that moved where it must stay, or more toppled
    # than allowed, has failed whatever comes: no hint to settle longer under those)
    may_turn = {"moved"} | ({"collapse", "stands"} if outcome.collapse is None else set())
    if expect.toppled is not None:
        least, _ = expect.toppled.allows(len(outcome.displacement) + len(outcome.unplaced))
        if len(outcome.toppled) < least:
            may_turn.add("toppled")
    if failed & may_turn and outcome.kinetic_energy > STILL_MOVING:
        lines.append(
            f"still moving: the run ended at t={outcome.simulated_time:.2f} s with its bricks' kinetic energy at "
            f"{outcome.kinetic_energy * 1000:.3g} mJ; a longer timing.settle lets them come to rest before they are judged"
        )
    if "stays" in failed and expect.stays:
        lines += _moved_lines(expect.stays, outcome, threshold, levels)
    if failed and outcome.not_run:
        lines.append(not_run_line(outcome))
    return lines


def _undecided_lines(outcome: Outcome, levels: dict[str, int | None]) -> list[str]:
    """Why a run that ended in motion with no collapse proved decided nothing (what the pose
    says is no verdict): its largest displacement then, and the actions left undone."""
    lines = []
    if outcome.displacement:
        brick, largest = max(outcome.displacement.items(), key=lambda item: item[1])
        lines.append(
            f"undecided: the run ended at t={outcome.simulated_time:.2f} s before its bricks came to rest "
            f"(the largest displacement then {millimetres(largest)}, {_brick(brick, levels.get(brick))}); "
            "a longer timing.settle lets them come to rest before they are judged"
        )
    return lines + ([not_run_line(outcome)] if outcome.not_run else [])


def _toppled_line(outcome: Outcome) -> str:
    """Why ``toppled`` failed: the bricks that ended tilted past their tipping angle."""
    return (
        f"toppled: {len(outcome.toppled)} brick{'s' * (len(outcome.toppled) != 1)} ended tilted past "
        f"{'its' if len(outcome.toppled) == 1 else 'their'} tipping angle: "
        f"{', '.join(_short(list(outcome.toppled))) or 'none'}"
    )


def _collapse_line(outcome: Outcome, threshold: float, levels: dict[str, int | None]) -> str:
    """Why ``collapse``, ``stands`` or ``stands_until`` failed: the collapse (its first moved brick,
    or its mechanism when no brick passed the threshold), or what stood and moved most."""
    c = outcome.collapse
    proof = outcome.certificate
    if c is not None and proof is not None and proof.kind == "no equilibrium":  # no brick passed the threshold
        return (
            f"collapsed: no rigid-block equilibrium holds the bricks where they are at the end (t={c.time:.2f} s), "
            f"with {c.level} level{'s' * (c.level != 1)} placed: {proof.detail}; in the mechanism: "
            f"{', '.join(_short(list(proof.bricks)))}"
        )
    if c is not None:
        return (
            f"collapsed: {_brick(c.brick, c.brick_level)} moved past {millimetres(threshold)} at t={c.time:.2f} s, "
            f"with {c.level} level{'s' * (c.level != 1)} placed ({millimetres(c.displacement, threshold)} by t={c.decided:.2f} s, "
            f"when the collapse was decided)"
        )
    if outcome.displacement:
        brick, largest = max(outcome.displacement.items(), key=lambda item: item[1])
        return (
            f"stood: the largest displacement at the end (t={outcome.simulated_time:.2f} s) was {millimetres(largest, threshold)}, "
            f"{_brick(brick, levels.get(brick))}; a collapse is a move beyond {millimetres(threshold)}"
        )
    return "stood: no structure brick was placed"


def _stayed_lines(selection: Iterable[int | str], outcome: Outcome, threshold: float, levels: dict[str, int | None]) -> list[str]:
    """Why ``moved`` failed: the bricks it names (``selection``: levels and brick selectors) that
    ended within ``threshold`` of where they were placed, the nearest first."""
    named = set(_selected(outcome, bricks_of(selection))) | {
        b for b, lv in levels.items() if lv in levels_of(selection) and b in outcome.displacement
    }
    still = sorted((outcome.displacement[b], b) for b in named if outcome.displacement[b] <= threshold)
    return [
        f"stayed: {_brick(b, levels.get(b))} ended {millimetres(d, threshold)} from where it was placed "
        f"(a move is beyond {millimetres(threshold)})"
        for d, b in still[:MOVED_SHOWN]
    ]


def _moved_lines(selection: Iterable[int | str], outcome: Outcome, threshold: float, levels: dict[str, int | None]) -> list[str]:
    """Why ``stays`` failed: the bricks it names (``selection``) that moved beyond ``threshold``
    by the end, the farthest first, at most :data:`MOVED_SHOWN` and how many more."""
    keep = set(levels_of(selection))
    named = set(_selected(outcome, bricks_of(selection)))
    moved = sorted(
        ((d, b) for b, d in outcome.displacement.items() if d > threshold and (levels.get(b) in keep or b in named)),
        reverse=True,
    )
    lines = [
        f"moved: {_brick(b, levels.get(b))} moved {millimetres(d, threshold)} by the end, t={outcome.simulated_time:.2f} s "
        f"(allowed {millimetres(threshold)}, the collapse threshold)"
        for d, b in moved[:MOVED_SHOWN]
    ]
    if len(moved) > MOVED_SHOWN:
        lines.append(f"moved: and {len(moved) - MOVED_SHOWN} more bricks of levels that must stay")
    return lines


def not_run_line(outcome: Outcome) -> str:
    """The actions a collapse left undone, in one line: those timed after a placement the
    collapse cancelled (``run`` says it always; ``check`` under a failure). Source: stackdsl's own.
    """
    n = len(outcome.not_run)
    return (
        f"not run: {n} action{'s' * (n != 1)} timed after a brick the collapse left unplaced "
        f"(building stops at a collapse): " + ", ".join(outcome.not_run)
    )


def _brick(brick: str, level: int | None) -> str:
    return brick if level is None else f"brick {brick} (level {level})"


def millimetres(metres: float, against: float | None = None) -> str:
    """``0.0081`` -> ``'8.1 mm'``, ``1.2e-05`` -> ``'0.012 mm'``; within 0.05 mm of ``against``
    (metres: the threshold it is judged by), to the micrometre, so that the two never read alike
    (a brick 4.03 mm from its place failed a 4 mm ``stays`` and read "moved 4.0 mm").

    >>> millimetres(0.00403), millimetres(0.00403, against=0.004), millimetres(0.0081, against=0.004)
    ('4.0 mm', '4.030 mm', '8.1 mm')
    """
    mm = metres * 1000
    if against is not None and mm >= 1 and abs(mm - against * 1000) < 0.05:
        return f"{mm:.3f} mm"
    return f"{mm:.1f} mm" if mm >= 1 else f"{mm:.2g} mm"


def describe(collapse_level: int | None, first: tuple[str, int] | None = None, moved: Sequence[int] = ()) -> str:
    """``'collapse 9'`` or ``'stands'``; with ``first`` (the brick that moved first and its
    level) and ``moved`` (the levels moved at the end), both named after it. The collapse
    level is the highest level placed when the first brick moved past the threshold (the
    report's "collapses at level N" of a tower being built); ``first`` says where it began,
    which after a blow can be lower.

    >>> describe(9), describe(None)
    ('collapse 9', 'stands')
    >>> describe(10, ("L08.1", 8), [8, 9, 10])
    'collapse 10 from L08.1 (level 8), levels 8-10 moved'
    """
    text = "stands" if collapse_level is None else f"collapse {collapse_level}"
    if first is not None:
        text += f" from {first[0]} (level {first[1]})"
    if moved:
        text += f", {levels_moved(moved)}"
    return text


def levels_moved(moved: Sequence[int]) -> str:
    """``'levels 8-10 moved'``: the words of :func:`describe` and of a ``moved`` verdict that held
    for the same levels (:func:`evaluate`), which a table says once."""
    return f"level{'s' * (len(moved) != 1)} {span(moved)} moved"
