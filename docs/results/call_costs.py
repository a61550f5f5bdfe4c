"""What the calls a brick needs cost on their own: the floor under the Python around the steps.

    python docs/results/call_costs.py

Prints, each the median of many calls in this process (microseconds unless marked):

- pybullet: creating a brick with ``createMultiBody`` one at a time and in one batched call;
  what 60 static bricks far away add to each step; the ground plane with pybullet's TinyRenderer
  plugin loaded and without it; ``resetSimulation`` of an empty world;
- shapely: making a quadrilateral, intersecting two, their union's hull (the operations an
  admission makes some 35 of for each brick);
- stackdsl: one exact face overlap (:func:`stability._geometry.face_overlap`); the 30-level 4
  stack's run split into the engine's steps and everything else, and the parts of everything
  else (each function of :data:`PARTS` wrapped in ``time.perf_counter``: the fastest of five
  runs); the 30-domino row timed before its push and after it, with the extension and raw.

Output: docs/results/speed-against-error.md, "The floor under the Python around the steps".
"""

from __future__ import annotations

import collections
import importlib
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pybullet
import shapely
from pybullet_utils.bullet_client import BulletClient

import stackdsl
from stability import Box, Pose
from stability._geometry import face_overlap
from stackdsl.engines.pybullet.client import RENDERER, quiet_c_output

HALF = [0.06, 0.012, 0.004]

PARTS = (
    "stability._admission:Admission.basic",
    "stability._areas:ContactAreas.supports",
    "stability._stack:Stack.freeze",
    "stability._stack:Stack._prove",
    "stability._areas:ContactAreas.polygons",
    "stackdsl.runtime.loop:StepLoop.place",
    "stackdsl.engines.pybullet.world:PyBulletWorld.create",
    "stackdsl.runtime.bricks:Structure.under",
    "stability._extension:StabilityExtension.update",
    "stackdsl.runtime.subscribers:SoftLanding.before_step",
    "stackdsl.runtime.subscribers:SoftLanding.after_step",
    "stackdsl.runtime.subscribers:Substeps.before_step",
    "stackdsl.runtime.collapse:CollapseMonitor.after_step",
    "stackdsl.runtime.subscribers:Stability.graph",
)
"""The functions whose time :func:`tower_parts` reports (module:Class.method), inclusive."""


def median_us(call: Callable[[], object], n: int = 200) -> float:
    """Microseconds of one call, the median of ``n``."""
    times = []
    for _ in range(n):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e6


def pybullet_costs() -> None:
    with quiet_c_output():
        client = BulletClient(connection_mode=pybullet.DIRECT)
    shape = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=HALF)
    one = median_us(lambda: client.createMultiBody(0.0106, shape, basePosition=[0, 0, 10]))
    client.resetSimulation()
    shape = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=HALF)
    batch = median_us(lambda: client.createMultiBody(0.0106, shape, batchPositions=[[i, 0, 10] for i in range(60)]), 20) / 60
    print(f"pybullet createMultiBody: {one:.0f} us a brick one at a time, {batch:.1f} us a brick in a batch of 60")

    def step_cost(parked: int) -> float:
        client.resetSimulation()
        client.setGravity(0, 0, -9.81)
        client.createMultiBody(0.0, client.createCollisionShape(pybullet.GEOM_PLANE))
        box = client.createCollisionShape(pybullet.GEOM_BOX, halfExtents=HALF)
        client.createMultiBody(0.0106, box, basePosition=[0, 0, 0.004])
        if parked:
            client.createMultiBody(0.0, box, batchPositions=[[100 + 0.3 * i, 100, 1] for i in range(parked)])
        return median_us(client.stepSimulation, 1000)

    alone, with_60 = step_cost(0), step_cost(60)
    print(f"pybullet step: {alone:.1f} us with one brick moving, {with_60:.1f} us with 60 static bricks far away as well")

    def plane() -> float:
        client.resetSimulation()
        return median_us(lambda: client.createMultiBody(0.0, client.createCollisionShape(pybullet.GEOM_PLANE)), 1)

    with_renderer = statistics.median(plane() for _ in range(30))
    client.unloadPlugin(client.loadPlugin(RENDERER))
    without = statistics.median(plane() for _ in range(30))
    print(f"pybullet ground plane: {with_renderer:.0f} us with TinyRenderer loaded, {without:.0f} us without")
    empty = statistics.median(median_us(client.resetSimulation, 1) for _ in range(30))
    print(f"pybullet resetSimulation of an empty world: {empty / 1000:.2f} ms")
    client.disconnect()


def shapely_costs() -> None:
    a = [(0.0, 0.0), (0.12, 0.0), (0.12, 0.024), (0.0, 0.024)]
    b = [(0.05, -0.05), (0.074, -0.05), (0.074, 0.07), (0.05, 0.07)]
    pa, pb = shapely.polygons(a), shapely.polygons(b)
    make = median_us(lambda: shapely.polygons(a), 2000)
    cut = median_us(lambda: pa.intersection(pb), 2000)
    hull = median_us(lambda: shapely.union_all([pa, pb]).convex_hull, 2000)
    print(f"shapely: a polygon {make:.1f} us, an intersection {cut:.1f} us, a union's hull {hull:.1f} us")
    brick = Box(np.array(HALF), 0.0106)
    lower, upper = Pose.from_euler([0, 0.048, 0.004]), Pose.from_euler([0.048, 0, 0.0119], yaw=90.01)
    face = median_us(lambda: face_overlap(brick, upper, brick, lower, 0.001), 2000)
    print(f"stackdsl face_overlap (two bricks face to face): {face:.1f} us")


def tower_split() -> None:
    program = stackdsl.compile_scenario(stackdsl.load_scenario("scenarios/four_stack.yaml"))
    stackdsl.run_program(program)
    runs = [stackdsl.run_program(program) for _ in range(5)]
    fastest = min(runs, key=lambda o: o.wall_time)
    bricks = len(program.placements)
    rest = fastest.wall_time - fastest.engine_time
    print(
        f"30-level 4 stack: {fastest.wall_time * 1000:.1f} ms, {fastest.steps} steps, {bricks} bricks; "
        f"engine steps {fastest.engine_time / fastest.steps * 1e6:.0f} us a step; everything else "
        f"{rest / fastest.steps * 1e6:.0f} us a step, {rest / bricks * 1e6:.0f} us a brick"
    )


def tower_parts() -> None:
    totals: collections.Counter[str] = collections.Counter()
    calls: collections.Counter[str] = collections.Counter()

    def timed(name: str, function: Any) -> Any:
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                totals[name] += time.perf_counter() - start
                calls[name] += 1

        return wrapper

    for part in PARTS:
        module, qualified = part.split(":")
        owner_name, method = qualified.split(".")
        owner = getattr(importlib.import_module(module), owner_name)
        setattr(owner, method, timed(qualified, getattr(owner, method)))
    program = stackdsl.compile_scenario(stackdsl.load_scenario("scenarios/four_stack.yaml"))
    stackdsl.run_program(program)
    best: tuple[float, dict[str, float], dict[str, int]] | None = None
    for _ in range(5):
        totals.clear()
        calls.clear()
        outcome = stackdsl.run_program(program)
        if best is None or outcome.wall_time < best[0]:
            best = (outcome.wall_time, dict(totals), dict(calls))
    assert best is not None
    wall, spent, counted = best
    print(f"30-level 4 stack with these parts timed: {wall * 1000:.1f} ms")
    for name, seconds in sorted(spent.items(), key=lambda item: -item[1]):
        print(f"  {name}: {seconds * 1000:.2f} ms in {counted[name]} calls, {seconds / counted[name] * 1e6:.1f} us a call")


class _Clock(stackdsl.Subscriber):
    """After each step: the step, the wall clock and the engine's time so far."""

    def __init__(self) -> None:
        self.ticks: list[tuple[int, float, float]] = []

    def after_step(self, loop: Any) -> None:
        self.ticks.append((loop.step, time.perf_counter(), loop.engine_time))


def domino_phases() -> None:
    text = open("scenarios/dominoes_30.yaml").read()
    for mode in ("extension", "raw"):
        program = stackdsl.compile_scenario(stackdsl.parse_scenario(text, "dominoes_30.yaml"), mode)
        push = next(a.step for a in program.actions if type(a).__name__ == "Push")
        stackdsl.run_program(program)
        clock = _Clock()
        start = time.perf_counter()
        stackdsl.run_program(program, subscribers=(clock,))
        before = [(t, e) for s, t, e in clock.ticks if s <= push]
        t_push, e_push = before[-1] if before else (start, 0.0)
        _, t_end, e_end = clock.ticks[-1]
        print(
            f"30 dominoes, {mode}: up to the push (step {push}) {(t_push - start) * 1000:.0f} ms "
            f"({e_push * 1000:.0f} ms of engine steps), after it {(t_end - t_push) * 1000:.0f} ms "
            f"({(e_end - e_push) * 1000:.0f} ms of engine steps)"
        )


if __name__ == "__main__":
    pybullet_costs()
    shapely_costs()
    tower_split()
    tower_parts()
    domino_phases()
