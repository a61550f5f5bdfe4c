"""``stackdsl bench limits``: each engine's own limits (:class:`stackdsl.engines.protocol.Limits`)
measured again, past them, with the compiler's check of them off.

* **Smallest side**: cubes of 1.5 to 3 mm, one on the ground in each mode (how far it moved
  at the end, or the level that collapsed), and a straight column of ten at the engine's
  defaults.
* **Fastest projectile**: a KAPLA brick thrown at a fixed 8 mm wall (:func:`stackdsl.bench.hard.wall_throw`)
  with substeps (extension mode) and without (raw mode): where it ends (beyond the wall if x > 0).
* **Fastest push**: a KAPLA brick lying on the ground pushed end on (a KAPLA pusher, 5 mm gap,
  25 mm of travel) towards a fixed 8 mm wall that stops it at x = 186 mm (:func:`pushed_at_wall`),
  in each mode: where it ends (a rebound if less, through or into the wall if more).
* **Largest mass ratio**: a heavy KAPLA brick crossed on a light one, twice (four bricks), in
  tuned mode: how far the bricks sank or moved (the collapse threshold is 4 mm).
* **Largest restitution**: in each mode, for each restitution (of every material, the ground's
  too), a 4 stack of 4 and of 10 levels built as usual (each brick put down at rest), and a
  KAPLA brick dropped onto the ground or onto a brick (:data:`DROPS`): the most energy it has
  after its first landing, as a share of what it fell with (a bounce that rises higher than
  the brick fell gains energy: more than 1; a faithful one keeps ``e^2`` of it).

Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..compile.compiler import compile_scenario
from ..engines.registry import settings_class
from ..lang.loader import parse_scenario
from ..runtime.loop import StepLoop, Subscriber
from ..runtime.outcome import Outcome
from ..runtime.run import run_program
from .hard import format_wall, thrown_at_wall

SIDES_MM = (1.5, 2.0, 2.5, 3.0)
SPEEDS = {"extension": (20.0, 30.0, 35.0, 40.0, 50.0, 100.0), "raw": (5.0, 8.0, 10.0, 20.0, 25.0, 30.0)}
PUSH_SPEEDS = (1.5, 1.75, 2.0, 2.5, 4.0, 10.0)
RATIOS = (100, 300, 500, 1000, 3000, 5000)
MODES = ("raw", "tuned", "extension")
RESTITUTIONS = (0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99)
TOWER_RESTITUTIONS = (0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.8, 0.99)
#: Drops of a KAPLA brick ``b``: name -> (the structure's bricks, the height of b's centre when
#: it lies flat where it lands, m). Heights are of its centre above where it lies; an edge
#: landing is rolled 20 degrees, a corner one rolled and pitched.
DROPS: dict[str, tuple[str, float]] = {
    "flat 10 mm": ("[{id: b, at: [0, 0, 14 mm]}]", 0.004),
    "flat 30 mm": ("[{id: b, at: [0, 0, 34 mm]}]", 0.004),
    "flat 100 mm": ("[{id: b, at: [0, 0, 104 mm]}]", 0.004),
    "flat 300 mm": ("[{id: b, at: [0, 0, 304 mm]}]", 0.004),
    "tilted 5 deg, 100 mm": ("[{id: b, at: [0, 0, 104 mm], pitch: 5}]", 0.004),
    "edge 30 mm": ("[{id: b, at: [0, 0, 34 mm], roll: 20}]", 0.004),
    "edge 100 mm": ("[{id: b, at: [0, 0, 104 mm], roll: 20}]", 0.004),
    "edge 300 mm": ("[{id: b, at: [0, 0, 304 mm], roll: 20}]", 0.004),
    "corner 100 mm": ("[{id: b, at: [0, 0, 104 mm], roll: 15, pitch: 10}]", 0.004),
    "corner 300 mm": ("[{id: b, at: [0, 0, 304 mm], roll: 15, pitch: 10}]", 0.004),
    "steep corner 300 mm": ("[{id: b, at: [0, 0, 304 mm], roll: 25, pitch: 30}]", 0.004),
    "on its side, 100 mm": ("[{id: b, at: [0, 0, 112 mm], roll: 90}]", 0.004),
    "onto a brick, 30 mm": ("[{id: a, at: [0, 0, 4 mm]}, {id: b, at: [0, 0, 42 mm], yaw: 90}]", 0.012),
    "onto a brick, 100 mm": ("[{id: a, at: [0, 0, 4 mm]}, {id: b, at: [0, 0, 112 mm], yaw: 90}]", 0.012),
}


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


def _bouncy(restitution: float, backend: str, mode: str, structure: str, extra: str = "") -> str:
    return (
        f"stackdsl: 1\nmaterials: {{rubber: {{density: 460 kg/m^3, friction: 0.5, restitution: {restitution:g}}}}}\n"
        "brick_types: {kapla: {size: [120 mm, 24 mm, 8 mm], material: rubber}}\nground: {material: rubber}\n"
        f"structure: {structure}\n{extra}engine: {{backend: {backend}, mode: {mode}}}\n"
    )


def bouncy_tower(restitution: float, backend: str, mode: str, levels: int) -> str:
    """Scenario text: a 4 stack of ``levels`` levels, every material of ``restitution``.

    >>> "restitution: 0.3" in bouncy_tower(0.3, "mujoco", "tuned", 4)
    True
    """
    return _bouncy(restitution, backend, mode, f"{{tower: {{levels: {levels}}}}}", "expect: {stands: true}\n")


def dropped(restitution: float, backend: str, mode: str, bricks: str) -> str:
    """Scenario text: the bricks of a drop (:data:`DROPS`), every material of ``restitution``, 2 s to settle."""
    return _bouncy(restitution, backend, mode, f"{{bricks: {bricks}}}", "allow: [floating]\ntiming: {settle: 2 s}\n")


class _Energy(Subscriber):
    """Each step once all ``bricks`` are in: their energy (J: potential above z = 0, kinetic,
    rotational) and the height of brick ``b``; ``weight``: b's (N)."""

    def __init__(self, bricks: int) -> None:
        self.bricks = bricks
        self.energy: list[float] = []
        self.height: list[float] = []
        self.weight = 0.0

    def after_step(self, loop: StepLoop) -> None:
        placed = loop.structure.placed
        if len(placed) < self.bricks:
            return
        gravity, total = loop.program.engine.gravity, 0.0
        for record in placed:
            pose = loop.world.pose(record.body)
            linear, angular = loop.world.velocity(record.body)
            a, b, c = record.spec.half_extents
            inertia = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) / 3  # a uniform box's, per kg
            spin = pose.rotation @ inertia @ pose.rotation.T
            total += record.spec.mass * (
                gravity * float(pose.position[2]) + float(linear @ linear + angular @ spin @ angular) / 2
            )
        self.energy.append(total)
        dropped = loop.structure.records["b"]
        self.height.append(float(loop.world.pose(dropped.body).position[2]))
        self.weight = dropped.spec.mass * gravity


def bounce(restitution: float, backend: str, mode: str, drop: str) -> float:
    """The most energy the dropped brick of ``drop`` (:data:`DROPS`) has after it first lands
    (the others' included), as a share of what it fell with: its energy above lying flat where
    it lands."""
    bricks, rest = DROPS[drop]
    program = compile_scenario(parse_scenario(dropped(restitution, backend, mode, bricks), "drop.yaml"), limits=False)
    watch = _Energy(bricks.count("id:"))
    run_program(program, subscribers=(watch,))
    energy, height = np.array(watch.energy), np.array(watch.height)
    floor = energy[0] - watch.weight * (height[0] - rest)  # every brick at rest, b flat where it lands
    landed = int(np.argmin(height[: round(0.35 / program.engine.timestep)]))  # each drop lands within 0.25 s
    return float((energy[landed + 1 :] - floor).max() / (energy[0] - floor))


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


def pushed_at_wall(speed: float, backend: str, mode: str) -> str:
    """Scenario text: a KAPLA brick at the origin pushed along +x at ``speed`` m/s for 25 mm (5 mm
    gap), towards a fixed 8 mm wall whose face is at x = 246 mm: it stops with its centre at 186 mm.

    >>> "speed: 2 m/s" in pushed_at_wall(2, "pybullet", "raw")
    True
    """
    return (
        f"stackdsl: 1\nbrick_types: {{wall: {{size: [8 mm, 200 mm, 100 mm]}}}}\nengine: {{backend: {backend}, mode: {mode}}}\n"
        "structure:\n  bricks:\n    - {id: wall, brick: wall, at: [250 mm, 0, 50 mm], fixed: true}\n"
        "    - {id: a, at: [0, 0, 4 mm]}\n"
        f"actions: [{{push: {{target: {{brick: a}}, direction: [1, 0, 0], speed: {speed:g} m/s, distance: 25 mm, gap: 5 mm, at: 1 s}}}}]\n"
    )


def format_pushes(backend: str, speeds: Sequence[float] = PUSH_SPEEDS) -> str:
    """The fastest-push table of ``backend``, markdown: where the pushed brick's centre ends
    (x; 186 mm at the wall) and its height when it sank (a KAPLA brick lies at z = 4 mm)."""
    lines = ["| push | " + " | ".join(MODES) + " |", "|---:|" + "---:|" * len(MODES)]
    for speed in speeds:
        cells = []
        for mode in MODES:
            outcome = _run(pushed_at_wall(speed, backend, mode))
            x, _, z = next(n.position_mm for n in outcome.final_graph.nodes if n.id == "a")
            cells.append(f"x = {x:.1f} mm" + ("" if z > 3.5 else f", z = {z:.1f} mm"))
        lines.append(f"| {speed:g} m/s | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def format_ratios(backend: str, ratios: Sequence[float] = RATIOS) -> str:
    """The mass-ratio table of ``backend``, markdown (tuned mode)."""
    lines = ["| density ratio | tuned |", "|---:|---:|"]
    lines += [f"| {r:g} | {_cell(_run(crossed(r, backend)))} |" for r in ratios]
    return "\n".join(lines)


def format_restitution(
    backend: str, restitutions: Sequence[float] = RESTITUTIONS, towers: Sequence[float] = TOWER_RESTITUTIONS
) -> str:
    """The restitution table of ``backend``, markdown: per mode the 4 stacks of 4 and 10 levels
    (at ``towers``) and the most energy a dropped brick keeps (the drop that kept the most)."""
    lines = [
        "| restitution | " + " | ".join(f"{m}: 4 and 10 levels | {m}: most energy kept" for m in MODES) + " |",
        "|---:|" + "---:|---:|" * len(MODES),
    ]
    for e in restitutions:
        cells = []
        for mode in MODES:
            stacks = ", ".join(_stack(_run(bouncy_tower(e, backend, mode, levels))) for levels in (4, 10)) if e in towers else ""
            kept = {drop: bounce(e, backend, mode, drop) for drop in DROPS}
            worst = max(kept, key=kept.__getitem__)
            cells += [stacks, f"{kept[worst]:.3g} ({worst})"]
        lines.append(f"| {e:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _stack(outcome: Outcome) -> str:
    return "stands" if outcome.collapse is None else f"collapse {outcome.collapse.level}"


def format_report(backends: Sequence[str]) -> str:
    """Every engine's limits in force and their measurements, markdown."""
    parts = []
    for backend in backends:
        kind = settings_class(backend)
        lim = kind.LIMITS
        parts.append(
            f"## {kind.NAME}\n\nIn force: sides from {lim.min_side * 1000:g} mm; projectiles up to {lim.max_speed:g} m/s "
            + "".join(f"({v:g} m/s in {mode} mode) " for mode, (v, _) in lim.max_speed_by_mode.items())
            + f"with substeps, {lim.max_speed_no_substeps:g} m/s without (and less than the thinnest brick a step); "
            "pushes as throws, with substeps in extension mode only"
            + "".join(f", at most {v:g} m/s in {mode} mode" for mode, (v, _) in lim.max_guided_speed_by_mode.items())
            + "; pulls as pushes"
            + "".join(f", at most {v:g} m/s in {mode} mode" for mode, (v, _) in lim.max_pull_speed_by_mode.items())
            + f"; mass ratios up to {lim.max_mass_ratio:g}; restitution up to "
            + ", ".join(f"{lim.restitution(m):g} in {m} mode" for m in MODES)
            + ".\n\n"
            f"Smallest side (how far a cube moved, or the level that collapsed):\n\n{format_sides(backend)}\n\n"
            f"A KAPLA brick thrown at a fixed 8 mm wall, with substeps (extension) and without (raw):\n\n"
            f"{format_speeds(backend)}\n\n"
            "A KAPLA brick pushed at a fixed 8 mm wall that stops it at x = 186 mm, in each mode:\n\n"
            f"{format_pushes(backend)}\n\n"
            f"A heavy KAPLA brick crossed on a light one, twice:\n\n{format_ratios(backend)}\n\n"
            "Every material of one restitution: a 4 stack built as usual, and the most energy a dropped KAPLA brick keeps "
            f"after it lands, as a share of what it fell with (of {len(DROPS)} drops, the one that kept the most):\n\n"
            f"{format_restitution(backend)}"
        )
    return "\n\n".join(parts)
