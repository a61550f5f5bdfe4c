"""Perturbations: a compiled Program changed in ways that should not change its verdict.

A verdict that a 10 micrometre nudge of the placements, a timestep 1% longer or 10% fewer
solver iterations can flip is *fragile*: it sits on a tie the engine decides by noise, and a
golden snapshot of it fails on the next machine. ``stackdsl check --perturb N`` reruns each
scenario under :func:`perturbations` and reports how many of its verdicts held
(:mod:`stackdsl.batch.perturb`).

Each perturbation is small against what decides a verdict (the collapse threshold, 4 mm for
KAPLA; a brick's tipping margin) and as large as the noise between two honest runs:

* ``jitter``: every placement moved by a uniform draw of at most :data:`JITTER` (10
  micrometres) in x and in y, from a seed of its own (the scene's own placement error and
  seed are kept);
* ``timestep``: the timestep 1% longer or shorter (:data:`TIMESTEP_CHANGE`), every action
  kept at its time in seconds, to the nearest step of the new timestep;
* ``iterations``: the solver iterations 10% more or fewer (:data:`ITERATIONS_CHANGE`);
* ``backend``: the scene on the other engine (compiled anew from the scenario, in the same
  mode and model), where it is installed and the scene is within what it simulates.

Source: stackdsl's own.

>>> [p.label for p in perturbations(7, "mujoco")]
['jitter 10 µm (draw 1)', 'timestep +1%', 'solver iterations +10%', 'on mujoco', 'jitter 10 µm (draw 2)', \
'timestep -1%', 'solver iterations -10%']
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .program import Launch, Place, Program, Push, Remove, Shake

#: Metres, the largest placement nudge of a ``jitter`` perturbation along x and along y.
JITTER = 1e-5
#: The relative change of the timestep of a ``timestep`` perturbation.
TIMESTEP_CHANGE = 0.01
#: The relative change of the solver iterations of an ``iterations`` perturbation.
ITERATIONS_CHANGE = 0.1

Kind = Literal["jitter", "timestep", "iterations", "backend"]


@dataclass(frozen=True)
class Perturbation:
    """One small change of a run.

    Attributes:
        kind: ``jitter``, ``timestep``, ``iterations`` or ``backend``.
        value: the jitter's draw (1, 2, ...), the sign of a timestep or iterations change
            (+1 or -1), or, for ``backend``, 0 (the engine is named by ``backend``).
        backend: the other engine's name, for ``backend``; else ``""``.
    """

    kind: Kind
    value: int = 0
    backend: str = ""

    @property
    def label(self) -> str:
        """In a few words: ``'timestep +1%'``, ``'jitter 10 µm (draw 2)'``, ``'on mujoco'``."""
        sign = "+" if self.value > 0 else "-"
        if self.kind == "jitter":
            return f"jitter {JITTER * 1e6:g} µm (draw {self.value})"
        if self.kind == "timestep":
            return f"timestep {sign}{TIMESTEP_CHANGE * 100:g}%"
        if self.kind == "iterations":
            return f"solver iterations {sign}{ITERATIONS_CHANGE * 100:g}%"
        return f"on {self.backend}"


def perturbations(count: int, other_backend: str | None = None) -> list[Perturbation]:
    """``count`` perturbations, each kind in turn (a jitter, the timestep longer, more solver
    iterations, the other engine; then a second jitter draw, the timestep shorter, fewer
    iterations; then further jitter draws), so that any four cover every kind.

    Args:
        count: how many (>= 0).
        other_backend: the engine the scene is also run on, or None to leave that kind out.

    Raises:
        ValueError: ``count`` is negative.
    """
    if count < 0:
        raise ValueError(f"the number of perturbations must be at least 0, not {count}")
    cycle: list[Perturbation] = [Perturbation("jitter", 1), Perturbation("timestep", 1), Perturbation("iterations", 1)]
    if other_backend:
        cycle.append(Perturbation("backend", 0, other_backend))
    cycle += [Perturbation("jitter", 2), Perturbation("timestep", -1), Perturbation("iterations", -1)]
    draw = 3
    while len(cycle) < count:
        cycle.append(Perturbation("jitter", draw))
        draw += 1
    return cycle[:count]


def perturb(program: Program, perturbation: Perturbation) -> Program:
    """``program`` changed by ``perturbation`` (a ``backend`` one is compiled anew from the
    scenario instead, by the caller: this raises for it).

    Raises:
        ValueError: a ``backend`` perturbation.

    >>> from stackdsl import compile_scenario, parse_scenario
    >>> program = compile_scenario(parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\n"))
    >>> longer = perturb(program, Perturbation("timestep", 1))
    >>> round(longer.engine.timestep / program.engine.timestep, 6), longer.actions[-1].time == program.actions[-1].time
    (1.01, False)
    >>> moved = perturb(program, Perturbation("jitter", 1))
    >>> max(abs(a - b) for p, q in zip(program.placements, moved.placements) for a, b in zip(p.position, q.position)) <= JITTER
    True
    """
    if perturbation.kind == "jitter":
        return _jittered(program, perturbation.value)
    if perturbation.kind == "timestep":
        return _retimed(program, program.engine.timestep * (1 + perturbation.value * TIMESTEP_CHANGE))
    if perturbation.kind == "iterations":
        iterations = max(1, round(program.engine.solver_iterations * (1 + perturbation.value * ITERATIONS_CHANGE)))
        return program.model_copy(update={"engine": program.engine.model_copy(update={"solver_iterations": iterations})})
    raise ValueError(f"a {perturbation.kind} perturbation is compiled from the scenario, not made from a program")


def _jittered(program: Program, draw: int) -> Program:
    """Every placement moved by a uniform draw of at most :data:`JITTER` along x and y."""
    rng = np.random.default_rng(np.random.SeedSequence([draw, 0x5EED]))
    actions = []
    for action in program.actions:
        if isinstance(action, Place):
            dx, dy = rng.uniform(-JITTER, JITTER, size=2)
            x, y, z = action.position
            action = action.model_copy(update={"position": (x + float(dx), y + float(dy), z)})
        actions.append(action)
    return program.model_copy(update={"actions": tuple(actions)})


def _retimed(program: Program, dt: float) -> Program:
    """``program`` at timestep ``dt`` (s): every action at the step of the new timestep nearest
    its time, and a shake's frequency fitted to its whole periods in its new steps."""
    actions = []
    for action in program.actions:
        step = round(action.time / dt)
        update: dict[str, object] = {"step": step, "time": step * dt}
        if isinstance(action, (Remove, Push, Shake)):
            end = max(step + 1, round(action.end_time / dt))
            update |= {"end_step": end, "end_time": end * dt}
            if isinstance(action, Shake):
                frequency = action.periods / ((end - step) * dt)
                update |= {"frequency": frequency, "written_frequency": action.written_frequency or action.frequency}
        if isinstance(action, Launch):
            update["arrival"] = action.arrival - action.time + step * dt
        actions.append(action.model_copy(update=update))
    if not math.isfinite(dt) or dt <= 0:
        raise ValueError(f"a timestep must be a positive number of seconds, not {dt}")
    return program.model_copy(update={"engine": program.engine.model_copy(update={"timestep": dt}), "actions": tuple(actions)})
