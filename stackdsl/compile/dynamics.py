"""What a backend without dynamics refuses: a scene that needs motion.

A backend whose :attr:`~stackdsl.engines.backend.Backend.dynamics` is False (the statics one)
places bricks and solves equilibrium; it cannot say what a thrown brick, a hand or a shake
table does, where a dropped or fallen brick ends, how a floating brick lands, or whether a brick
ever tilts or slips (the onset of motion, ``expect: still``). Such a scene is refused at the field
that makes it move or asks about motion, before anything runs.

Source: stackdsl's own.
"""

from __future__ import annotations

from ..engines.backend import Backend
from ..lang.errors import FieldPath
from ..lang.schema import Scenario

#: Expectations judged on where bricks end after a collapse, and why each needs motion.
_AFTER_A_FALL = ("moved", "toppled", "stays", "may_fall")


def check_motion(scenario: Scenario, backend: Backend) -> None:
    """Nothing for a backend with dynamics, or a scene without motion.

    Raises:
        ScenarioError: at the first field that needs motion (an impact, an action, a drop gap
            above the backend's :attr:`~stackdsl.engines.backend.Backend.max_drop`, floating
            bricks allowed, an expectation of where bricks end or of the onset of motion, ``still``),
            naming the backend and why.
    """
    if backend.dynamics:
        return
    where: FieldPath | None = None
    if scenario.impacts:
        where, what = ("impacts", 0), "a thrown brick needs motion"
    elif scenario.actions:
        where, what = ("actions", 0), "a hand or a shake table needs motion"
    elif scenario.timing.drop_gap > backend.max_drop:
        where = ("timing", "drop_gap")
        what = f"a brick dropped {scenario.timing.drop_gap * 1000:g} mm falls onto its support (at most {backend.max_drop * 1000:g} mm)"
    elif "floating" in scenario.allow:
        where, what = ("allow",), "a floating brick falls when placed"
    else:
        said = next((name for name in _AFTER_A_FALL if getattr(scenario.expect, name) is not None), None)
        if said is not None:
            where, what = ("expect", said), f"where bricks end ({said}) needs motion"
        elif scenario.expect.still is not None:
            where, what = ("expect", "still"), "the onset of motion (still: the largest tilt and slip) needs motion"
    if where is None:
        return
    message = f"{backend.refusal}: {what}; run it on an engine (engine: {{backend: ...}} or --backend)"
    raise scenario.source.error(where, message)
