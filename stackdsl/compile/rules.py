"""The extension mode's rules a scene needs, chosen by the compiler with a reason each
(``stackdsl compile`` prints them; docs/design.md, "What the compiler switches on").

>>> from stackdsl import compile_scenario, parse_scenario
>>> program = compile_scenario(parse_scenario("stackdsl: 1\\nstructure: {card_house: {levels: 1}}\\n"))
>>> [(r.name, r.on) for r in program.rules]
[('basic', True), ('leaning', True), ('impacts', False), ('rigid', True)]

Source: stackdsl's own (model only what a scene needs).
"""

from __future__ import annotations

from collections.abc import Sequence

from ..lang.expectations import Expect
from .layouts import LaidBrick, lie_flat, on_a_face
from .program import PULL_STEP, Kinematic, Launch, Push, Remove, Rule, Shake


def choose_rules(
    bricks: list[LaidBrick],
    launches: list[Launch],
    expect: Expect,
    motions: Sequence[Kinematic] = (),
    split_pulls: bool = True,
) -> tuple[Rule, ...]:
    """The extension mode's rules this scene needs: leaning only if a brick does not lie flat
    or something is thrown, pulled or pushed (it may come to rest leaning), impacts only if
    something is thrown, fallen bricks made cheaper to step unless levels or bricks are expected to
    stay, move or topple, or may fall, which is judged after the collapse; and, listed only for
    a scene that has them, ``guided`` when a hand pulls or pushes, ``shake`` when the ground shakes
    (docs/design.md: what the compiler switches on); on an engine whose pulls are split
    (``split_pulls``: :attr:`stackdsl.engines.backend.Backend.split_pulls`), ``guided`` says that the
    steps are split while a pull lasts (:data:`stackdsl.compile.program.PULL_STEP`)."""
    tilted = [b.id for b, flat in zip(bricks, lie_flat(bricks)) if not flat]
    judged_after = next((name for name in ("stays", "may_fall", "moved", "toppled") if getattr(expect, name) is not None), None)
    hands = [m for m in motions if isinstance(m, (Remove, Push))]
    shakes = [m for m in motions if isinstance(m, Shake)]
    return (
        Rule(name="basic", on=True, reason="every scene"),
        Rule(name="leaning", on=bool(tilted or launches or hands), reason=_lean_reason(bricks, tilted, launches, hands)),
        Rule(
            name="impacts",
            on=bool(launches or hands),
            reason=f"{len(launches)} projectile{'s' * (len(launches) != 1)}"
            if launches
            else "a pulled or pushed brick may knock over the frozen bricks it falls on (the energy to tip or lift them)"
            if hands
            else "nothing is thrown",
        ),
        Rule(
            name="rigid",
            on=judged_after is None,
            reason=f"expect.{judged_after} is judged after a collapse"
            if judged_after
            else "nothing is judged on bricks after a collapse: they settle as cheaper bodies",
        ),
        *((_guided_rule(hands, split_pulls),) if hands else ()),
        *((_shake_rule(shakes),) if shakes else ()),
    )


def _lean_reason(bricks: list[LaidBrick], tilted: list[str], launches: list[Launch], hands: Sequence[Remove | Push]) -> str:
    """Why the ``leaning`` rule is on or off: the ``tilted`` bricks (on an edge or an end, or
    tilted; the first four named), a throw, a pull or a push, or none of them."""
    faced = set(b.id for b, face in zip(bricks, on_a_face(bricks)) if face)
    listed = ", ".join(tilted[:4]) + (f" and {len(tilted) - 4} more" if len(tilted) > 4 else "")
    return (
        f"bricks placed {'on an edge or an end' if all(t in faced for t in tilted) else 'tilted'}: {listed}"
        if tilted
        else "a thrown brick may come to rest leaning"
        if launches
        else "a pulled or pushed brick may come to rest leaning"
        if hands
        else "every brick lies flat and nothing is thrown"
    )


def _guided_rule(hands: Sequence[Remove | Push], split_pulls: bool) -> Rule:
    """The ``guided`` rule of a scene whose hands pull or push (``hands``), saying when the steps
    are split while a pull lasts (``split_pulls``)."""
    moved = ", ".join(f"{m.kind} {m.id} at {m.time:g} s" for m in hands)
    return Rule(
        name="guided",
        on=True,
        reason=f"{moved}: wakes what it carries and the frozen bricks it touches; never frozen while moved"
        + (
            f"; steps split to at most {PULL_STEP * 1000:.3g} ms ({1 / PULL_STEP:.0f} Hz) while a pull lasts, until a brick is past the collapse threshold"
            if split_pulls and any(isinstance(m, Remove) for m in hands)
            else ""
        ),
    )


def _shake_rule(shakes: list[Shake]) -> Rule:
    """The ``shake`` rule of a scene whose ground shakes (``shakes``), with the peak acceleration."""
    peak = max((m.peak_acceleration for m in shakes), default=0.0)
    return Rule(
        name="shake",
        on=True,
        reason=f"the ground shakes (peak {peak:.3g} m/s^2): the frozen stack stays frozen only if it stands under gravity "
        "tilted by the peak acceleration; else it wakes, and nothing freezes while the ground moves",
    )
