"""The extension mode's rules a scene needs, chosen by the compiler with a reason each
(``stackdsl compile`` prints them; docs/design.md, "What the compiler switches on").

>>> from stackdsl import compile_scenario, parse_scenario
>>> program = compile_scenario(parse_scenario("stackdsl: 1\\nstructure: {card_house: {levels: 1}}\\n"))
>>> [(r.name, r.on) for r in program.rules]
[('basic', True), ('leaning', True), ('impacts', False), ('rigid', True)]

Source: stackdsl's own (model only what a scene needs).
"""

from __future__ import annotations

from ..lang.expectations import Expect
from .layouts import LaidBrick, lie_flat
from .program import Launch, Rule


def choose_rules(bricks: list[LaidBrick], launches: list[Launch], expect: Expect) -> tuple[Rule, ...]:
    """The extension mode's rules this scene needs: leaning only if a brick does not lie flat
    or something is thrown (it may come to rest leaning), impacts only if something is thrown,
    fallen bricks made cheaper to step unless levels are expected to stay or may fall, which is
    judged after the collapse (docs/design.md: what the compiler switches on)."""
    tilted = [b.id for b, flat in zip(bricks, lie_flat(bricks)) if not flat]
    judged_after = next((name for name in ("stays", "may_fall") if getattr(expect, name) is not None), None)
    listed = ", ".join(tilted[:4]) + (f" and {len(tilted) - 4} more" if len(tilted) > 4 else "")
    lean = (
        f"bricks placed tilted: {listed}"
        if tilted
        else "a thrown brick may come to rest leaning"
        if launches
        else "every brick lies flat and nothing is thrown"
    )
    return (
        Rule(name="basic", on=True, reason="every scene"),
        Rule(name="leaning", on=bool(tilted or launches), reason=lean),
        Rule(
            name="impacts",
            on=bool(launches),
            reason=f"{len(launches)} projectile{'s' * (len(launches) != 1)}" if launches else "nothing is thrown",
        ),
        Rule(
            name="rigid",
            on=judged_after is None,
            reason=f"expect.{judged_after} is judged after a collapse"
            if judged_after
            else "nothing is judged on bricks after a collapse: they settle as cheaper bodies",
        ),
    )
