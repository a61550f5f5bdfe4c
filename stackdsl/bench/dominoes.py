"""``stackdsl bench dominoes``: a row of dominoes pushed over, in each engine setting, at the same
toppled count.

The scene is ``scenarios/dominoes_30.yaml``'s for any count: KAPLA bricks on end 40 mm apart,
placed one every 0.1 s, and a finger that pushes the first near its top 0.5 s after the last
is placed. Simulated alone, every standing domino costs the engine every step from its
placement on; with the extension each is frozen once it stands and woken when the chain
reaches it (the impact rule with the energy to tip it, :func:`stability._impact.tipping_energy`),
and the run jumps over the time in which nothing moves. Each setting runs once untimed (the
process's one-off costs), then ``repeats`` times; the median wall time is kept, with how many
dominoes toppled, so that settings are compared where they agree.

Source: stackdsl's own.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass

from ..compile.compiler import compile_scenario
from ..lang.loader import parse_scenario
from ..runtime.outcome import Outcome
from ..runtime.run import run_program
from .bench import SETTINGS, Setting

#: Settings only the domino bench runs: MuJoCo's own defaults with its own sleeping (tolerance
#: 1e-4), beside the tuned peer.
EXTRA: dict[str, Setting] = {
    "MuJoCo raw sleeping": Setting("raw", engine=(("backend", "mujoco"), ("sleep_tolerance", 1e-4)), lazy_bodies=True),
}

#: Every setting the domino bench knows: :data:`SETTINGS` and :data:`EXTRA`.
KNOWN: dict[str, Setting] = {**SETTINGS, **EXTRA}

#: The settings compared by default: the engine alone, the peer through stackdsl's loop (tuned
#: MuJoCo with its own sleeping, and MuJoCo's defaults with its own sleeping), and the extension
#: on both engines.
DEFAULT = ("raw 240 Hz", "MuJoCo tuned sleeping", "MuJoCo raw sleeping", "extension report", "MuJoCo extension")


def domino_row(count: int, setting: str) -> str:
    """The scenario text of ``count`` dominoes under ``setting`` (a name of :data:`KNOWN`)."""
    chosen = KNOWN[setting]
    extra = "".join(f", {k}: {v}" for k, v in chosen.engine)
    bricks = "\n".join(f"    - {{id: d{i + 1:03d}, at: [{i * 40} mm, 0, 60 mm], pitch: 90, level: 1}}" for i in range(count))
    push = 0.1 * count + 0.5
    return f"""stackdsl: 1
name: {count} dominoes
brick_types: {{finger: {{size: [20 mm, 10 mm, 10 mm]}}}}
structure:
  bricks:
{bricks}
timing: {{interval: 0.1 s, settle: {max(2.0, 0.06 * count):g} s}}
engine: {{mode: {chosen.mode}{extra}}}
stability: {{model: {chosen.model}}}
actions:
  - push: {{target: {{brick: d001, offset: [0, 0, 45 mm]}}, direction: [1, 0, 0], speed: 0.2 m/s, distance: 15 mm, at: {push:g} s, pusher: finger}}
"""


#: Metres from its placed pose beyond which a domino has left the row: a fallen KAPLA domino's
#: centre moves about 0.06 m; one farther was thrown out by the engine (MuJoCo resets a run whose
#: accelerations blow up: every body goes back to its model pose, far from the row, lying flat).
LEFT_THE_ROW = 0.5


@dataclass(frozen=True)
class DominoCost:
    """One setting: the median wall time (s), the dominoes toppled in the row of ``count`` (not
    counting those that left it), steps taken, and how many left the row (:data:`LEFT_THE_ROW`):
    a run with any is not a domino row that fell, whatever its toppled count."""

    setting: str
    count: int
    wall: float
    toppled: int
    steps: int
    left: int = 0


def domino_cost(count: int, setting: str, repeats: int = 1) -> DominoCost:
    """Run ``count`` dominoes under ``setting``, once untimed and ``repeats`` times timed.

    Raises:
        KeyError: an unknown setting; ImportError: MuJoCo's settings without MuJoCo.
    """
    program = compile_scenario(parse_scenario(domino_row(count, setting), f"dominoes-{count}.yaml"))
    run_program(program)  # one-off costs: imports, first calls
    walls, outcome = [], None
    for _ in range(max(1, repeats)):
        start = time.perf_counter()
        outcome = run_program(program)
        walls.append(time.perf_counter() - start)
    assert outcome is not None
    toppled, left = row_count(outcome)
    return DominoCost(setting, count, statistics.median(walls), toppled, outcome.steps, left)


def row_count(outcome: Outcome) -> tuple[int, int]:
    """The dominoes of ``outcome`` that toppled in the row, and how many left it
    (:data:`LEFT_THE_ROW`), or, when the run stopped early (``outcome.stopped``: the engine blew
    up, or the budget ran out), every domino:
    such a run is no row that fell, whatever its toppled count."""
    if outcome.stopped is not None:
        return 0, len(outcome.displacement)
    left = {b for b, d in outcome.displacement.items() if d > LEFT_THE_ROW}
    return len(set(outcome.toppled) - left), len(left)


def format_dominoes(costs: list[DominoCost]) -> str:
    """A Markdown table of :func:`domino_cost` results, each wall time also as a ratio to the first
    row's; a setting whose run threw dominoes out of the row is marked, its ratio left out."""
    first = costs[0].wall if costs else 1.0
    lines = [
        "| setting | dominoes | toppled | left the row | steps | wall (s) | to the first |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for c in costs:
        ratio = f"{c.wall / first:.2f}" if not c.left else "blew up"
        lines.append(f"| {c.setting} | {c.count} | {c.toppled} | {c.left} | {c.steps} | {c.wall:.2f} | {ratio} |")
    return "\n".join(lines)
