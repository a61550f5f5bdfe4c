"""Hard-case measurements: the numbers behind docs/results/hard-cases.md.

``stackdsl bench hard`` prints three tables, each the extension beside pybullet alone:

* every scenario under ``scenarios/hard`` in extension and raw mode: the outcome, the
  drift of the bricks that stood, physics steps per placed brick;
* a brick thrown at a fixed 8 mm wall (:func:`wall_throw`): where it ends;
* the leaning limits swept (:func:`leaning_limits`): the largest angle at which an
  inverted V and a brick leaning on a wall stand, beside their closed forms.

Source: stackdsl's own; the closed forms are in ``scenarios/vee_stands.yaml``
and ``scenarios/lean_wall_stands.yaml``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..batch.check import compare
from ..compile.compiler import compile_scenario
from ..lang.errors import ScenarioError
from ..lang.loader import parse_scenario
from ..runtime.run import run_program
from ..verdicts.check_result import CheckResult

V_LIMIT = math.degrees(math.atan(0.5))
"""Degrees from vertical: the KAPLA inverted V's limit at friction coefficient 0.5 (vee_stands.yaml)."""
WALL_LIMIT = 55.3
"""Degrees from vertical: a KAPLA brick on a wall, both at 0.5 (lean_wall_stands.yaml)."""


def wall_throw(speed: float, mode: str, backend: str = "pybullet") -> str:
    """Scenario text: a KAPLA brick thrown along +x at ``speed`` m/s at a fixed wall, 8 mm
    thick, 200 mm wide and high, whose face is at x = -4 mm, on ``backend``.

    >>> "speed: 5 m/s" in wall_throw(5, "raw")
    True
    """
    return (
        "stackdsl: 1\nbrick_types: {wall: {size: [8 mm, 200 mm, 200 mm]}}\n"
        f"engine: {{mode: {mode}, backend: {backend}}}\n"
        "structure:\n  bricks:\n    - {id: wall, brick: wall, at: [0, 0, 100 mm], fixed: true}\n"
        "    - {at: [-300 mm, 0, 4 mm]}\n"
        f"impacts: [{{id: hammer, target: {{point: [-4 mm, 0, 60 mm]}}, direction: [1, 0, 0], speed: {speed:g} m/s, at: 1 s}}]\n"
    )


def thrown_at_wall(
    speeds: Sequence[float] = (5, 20, 50),
    modes: Sequence[str] = ("raw", "tuned", "extension"),
    backend: str = "pybullet",
    limits: bool = True,
) -> dict[tuple[float, str], float | None]:
    """(speed in m/s, mode) -> the thrown brick's final x in metres (beyond the wall if > 0);
    None where the compiler refuses the throw as beyond the engine (``limits`` False: run it)."""
    ends: dict[tuple[float, str], float | None] = {}
    for speed in speeds:
        for mode in modes:
            try:
                program = compile_scenario(parse_scenario(wall_throw(speed, mode, backend)), limits=limits)
            except ScenarioError:
                ends[speed, mode] = None
                continue
            outcome = run_program(program)
            hammer = next(n for n in outcome.final_graph.nodes if n.id == "hammer")
            ends[speed, mode] = hammer.position_mm[0] / 1000
    return ends


def vee(angle: float, mode: str) -> str:
    """Scenario text: one inverted V of KAPLA bricks, each ``angle`` degrees from vertical."""
    return f"stackdsl: 1\nstructure: {{card_house: {{levels: 1, angle: {angle:g}}}}}\nengine: {{mode: {mode}}}\n"


def lean_on_wall(angle: float, mode: str) -> str:
    """Scenario text: a KAPLA brick ``angle`` degrees from vertical, its lowest corner on the
    ground and its top corner 0.2 mm from a fixed pine wall (as lean_wall_stands.yaml;
    its long side is ``90 - angle`` degrees from horizontal, pitch ``angle - 90``)."""
    a = math.radians(angle)
    x = -(60 * math.sin(a) + 4 * math.cos(a)) - 0.2
    z = 60 * math.cos(a) + 4 * math.sin(a)
    return (
        "stackdsl: 1\nbrick_types: {wall: {size: [20 mm, 200 mm, 200 mm], material: pine}}\n"
        f"engine: {{mode: {mode}}}\n"
        "structure:\n  bricks:\n    - {id: wall, brick: wall, at: [10 mm, 0, 100 mm], fixed: true}\n"
        f"    - {{id: leaner, at: [{x:.3f} mm, 0, {z:.3f} mm], pitch: {angle - 90:g}}}\n"
    )


def leaning_limits(
    modes: Sequence[str] = ("raw", "extension"), step: float = 0.5, span: float = 4.0
) -> dict[tuple[str, str], tuple[float | None, float | None]]:
    """Sweep each leaning structure from ``span`` degrees below its closed-form limit to
    ``span`` above, in ``step`` degrees.

    Returns:
        (structure, mode) -> (largest angle that stood, smallest angle that fell), degrees;
        None where none did.
    """
    found = {}
    for name, scene, limit in (("inverted V", vee, V_LIMIT), ("brick on a wall", lean_on_wall, WALL_LIMIT)):
        angles = np.round(np.arange(round(limit) - span, round(limit) + span + step / 2, step), 3)
        for mode in modes:
            stood = {float(a): run_program(compile_scenario(parse_scenario(scene(a, mode)))).collapse is None for a in angles}
            found[name, mode] = (
                max((a for a, s in stood.items() if s), default=None),
                min((a for a, s in stood.items() if not s), default=None),
            )
    return found


def format_hard(folder: str | Path = "scenarios/hard", jobs: int | None = None) -> str:
    """Every scenario under ``folder`` in extension and raw mode, as a markdown table."""
    table = compare([folder], ("extension", "raw"), jobs=jobs)
    lines = ["| scenario | expected | extension | raw pybullet |", "|---|---|---|---|"]
    for file, row in table.items():
        lines.append(f"| {Path(file).stem} | {row['extension'].expected} | {_cell(row['extension'])} | {_cell(row['raw'])} |")
    return "\n".join(lines)


def _cell(r: CheckResult) -> str:
    if r.refused:  # the compiler's reason, up to its detail: "5 m/s is faster than pybullet simulates ..."
        return f"refused: {r.refused.split(':')[0]}"
    return f"{'PASS' if r.passed else 'FAIL'} {r.measured}; drift {r.drift * 1000:.2f} mm; {r.steps_per_brick:.1f} steps a brick"


def format_wall(ends: dict[tuple[float, str], float | None]) -> str:
    """:func:`thrown_at_wall` as a markdown table."""
    modes = list(dict.fromkeys(m for _, m in ends))
    lines = ["| speed | " + " | ".join(modes) + " |", "|---:|" + "---:|" * len(modes)]
    for speed in dict.fromkeys(s for s, _ in ends):
        lines.append(f"| {speed:g} m/s | " + " | ".join(_end(ends[speed, m]) for m in modes) + " |")
    return "\n".join(lines)


def _end(x: float | None) -> str:
    if x is None:
        return "refused (beyond the engine)"
    return f"x = {x:+.3f} m" + (" (passed through)" if x > 0 else "")


def format_limits(found: dict[tuple[str, str], tuple[float | None, float | None]]) -> str:
    """:func:`leaning_limits` as a markdown table."""
    lines = ["| structure | closed form | mode | largest angle standing | smallest angle falling |", "|---|---:|---|---:|---:|"]
    for (name, mode), (stood, fell) in found.items():
        limit = V_LIMIT if name == "inverted V" else WALL_LIMIT
        lines.append(f"| {name} | {limit:.1f} deg | {mode} | {_deg(stood)} | {_deg(fell)} |")
    return "\n".join(lines)


def _deg(angle: float | None) -> str:
    return "none" if angle is None else f"{angle:g} deg"
