"""``stackdsl bench limits``: each engine's own limits (:class:`stackdsl.engines.protocol.Limits`)
measured again, past them, with the compiler's check of them off.

* **Smallest side**: cubes of 1.5 to 3 mm, one on the ground in each mode (how far it moved
  at the end, or the level that collapsed), and a straight column of ten at the engine's
  defaults.
* **Fastest projectile**: a KAPLA brick thrown at a fixed 8 mm wall (:func:`stackdsl.bench.hard.wall_throw`)
  with substeps (extension mode) and without (raw mode): where it ends (beyond the wall if x > 0).
* **Largest mass ratio**: a heavy KAPLA brick crossed on a light one, twice (four bricks), in
  tuned mode: how far the bricks sank or moved (the collapse threshold is 4 mm).

Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..compile.compiler import compile_scenario
from ..engines.settings import SETTINGS
from ..lang.loader import parse_scenario
from ..runtime.outcome import Outcome
from ..runtime.run import run_program
from .hard import format_wall, thrown_at_wall

SIDES_MM = (1.5, 2.0, 2.5, 3.0)
SPEEDS = {"extension": (20.0, 30.0, 35.0, 40.0, 50.0, 100.0), "raw": (5.0, 8.0, 10.0, 20.0, 25.0, 30.0)}
RATIOS = (100, 300, 500, 1000, 3000, 5000)
MODES = ("raw", "tuned", "extension")


def cubes(side_mm: float, backend: str, mode: str | None, levels: int) -> str:
    """Scenario text: a straight column of ``levels`` cubes of ``side_mm`` (mode None: the default).

    >>> "levels: 10" in cubes(3, "pybullet", None, 10)
    True
    """
    engine = f"{{backend: {backend}" + (f", mode: {mode}}}" if mode else "}")
    return (
        f"stackdsl: 1\nbrick_types: {{cube: {{size: [{side_mm:g} mm, {side_mm:g} mm, {side_mm:g} mm]}}}}\n"
        f"structure: {{tower: {{levels: {levels}, bricks_per_layer: 1, turn: 0, brick: cube}}}}\nengine: {engine}\n"
    )


def crossed(ratio: float, backend: str, mode: str = "tuned") -> str:
    """Scenario text: four KAPLA bricks crossed, light and heavy (``ratio`` times denser) in turn."""
    light = 10.0
    return (
        f"stackdsl: 1\nmaterials: {{light: {{density: {light:g}}}, heavy: {{density: {light * ratio:g}}}}}\n"
        "brick_types: {a: {size: [120 mm, 24 mm, 8 mm], material: light}, b: {size: [120 mm, 24 mm, 8 mm], material: heavy}}\n"
        "structure:\n  bricks:\n    - {brick: a, at: [0, 0, 4 mm]}\n    - {brick: b, at: [0, 0, 12 mm], yaw: 90}\n"
        "    - {brick: a, at: [0, 0, 20 mm]}\n    - {brick: b, at: [0, 0, 28 mm], yaw: 90}\n"
        f"engine: {{backend: {backend}, mode: {mode}}}\n"
    )


def _run(text: str) -> Outcome:
    return run_program(compile_scenario(parse_scenario(text, "limits.yaml"), limits=False))


def _cell(outcome: Outcome) -> str:
    if outcome.collapse is not None:
        return f"collapse {outcome.collapse.level}"
    return f"{outcome.drift * 1000:.2f} mm"


def format_sides(backend: str, sides: Sequence[float] = SIDES_MM) -> str:
    """The smallest-side table of ``backend``, markdown."""
    lines = [
        "| cube | " + " | ".join(f"one, {m}" for m in MODES) + " | ten at the defaults |",
        "|---:|" + "---:|" * (len(MODES) + 1),
    ]
    for side in sides:
        cells = [_cell(_run(cubes(side, backend, m, 1))) for m in MODES] + [_cell(_run(cubes(side, backend, None, 10)))]
        lines.append(f"| {side:g} mm | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def format_speeds(backend: str) -> str:
    """The fastest-projectile tables of ``backend``, markdown: with and without substeps."""
    parts = []
    for mode, speeds in SPEEDS.items():
        parts.append(format_wall(thrown_at_wall(speeds, (mode,), backend, limits=False)))
    return "\n\n".join(parts)


def format_ratios(backend: str, ratios: Sequence[float] = RATIOS) -> str:
    """The mass-ratio table of ``backend``, markdown (tuned mode)."""
    lines = ["| density ratio | tuned |", "|---:|---:|"]
    lines += [f"| {r:g} | {_cell(_run(crossed(r, backend)))} |" for r in ratios]
    return "\n".join(lines)


def format_report(backends: Sequence[str]) -> str:
    """Every engine's limits in force and their measurements, markdown."""
    parts = []
    for backend in backends:
        kind = SETTINGS[backend]
        lim = kind.LIMITS
        parts.append(
            f"## {kind.NAME}\n\nIn force: sides from {lim.min_side * 1000:g} mm; projectiles up to {lim.max_speed:g} m/s "
            + "".join(f"({v:g} m/s in {mode} mode) " for mode, (v, _) in lim.max_speed_by_mode.items())
            + f"with substeps, {lim.max_speed_no_substeps:g} m/s without (and less than the thinnest brick a step); "
            f"mass ratios up to {lim.max_mass_ratio:g}.\n\n"
            f"Smallest side (how far a cube moved, or the level that collapsed):\n\n{format_sides(backend)}\n\n"
            f"A KAPLA brick thrown at a fixed 8 mm wall, with substeps (extension) and without (raw):\n\n"
            f"{format_speeds(backend)}\n\n"
            f"A heavy KAPLA brick crossed on a light one, twice:\n\n{format_ratios(backend)}"
        )
    return "\n\n".join(parts)
