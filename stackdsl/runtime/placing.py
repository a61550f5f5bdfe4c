"""Program -> Outcome without dynamics: bricks placed in their compiled order and decided by
rigid-block equilibrium, for a backend that simulates no motion.

A backend whose :attr:`~stackdsl.engines.backend.Backend.dynamics` is False has nothing for the
step loop to step: its compiler refuses every scene that moves (impacts, actions, drops that
matter), so a run is its placements, in order. :func:`run_placed` puts each brick at its pose
(lowered by its engine's seat, as :meth:`stackdsl.runtime.loop.StepLoop.place` does; nothing
sinks and nothing falls a drop gap) into :class:`stability.Placing`, which asks rigid-block
equilibrium of the bricks under the new one only (their load paths, the equilibrium program
where those fail). The first placement after which no forces balance the bricks is the
collapse, at its level, proved "no equilibrium", named after the lowest brick of the collapse
mechanism (then the first placed); nothing is placed after it. A run that places every brick
stands, with the load paths' or the program's certificate
(:func:`stackdsl.runtime.end_proofs.stand_words`). The :class:`~stackdsl.runtime.outcome.Outcome`
is the one the step loop builds: timeline (``place`` and ``collapse`` events), brick graphs,
certificate; nothing moved (displacements, drift and kinetic energy are 0) and no step was
taken.

Source: stackdsl's own (the collapse level of rigid-block equilibrium: docs/results/statics.md).
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Iterator

import numpy as np

from stability import Box, Placed, PlacedBox, Placing, Pose, RigidBlock, equilibrium_margin, friction_share
from stability import Certificate as Equilibrium

from ..compile.program import End, Place, Program
from .end_proofs import stand_words
from .outcome import Certificate, Collapse, Event, Graph, Outcome

__all__ = ["GROUND", "run_placed"]

#: The ground's key in :class:`stability.Placing` (fixtures and bricks follow from 1).
GROUND = 0


def run_placed(program: Program, *, timeout: float | None = None, started: float | None = None) -> Outcome:
    """Place ``program``'s bricks in order and decide by rigid-block equilibrium (module
    docstring). ``timeout``: seconds of wall time from ``started`` (``time.perf_counter()``
    seconds; None: now) after which no more bricks are placed (:attr:`Outcome.stopped`).

    Raises:
        ValueError: an action that needs motion (a throw, a pull, a push, a shake), which the
            compiler refuses for a backend without dynamics first.
    """
    start = _time.perf_counter() if started is None else started
    deadline = None if timeout is None else start + timeout
    engine = program.engine
    labels = {GROUND: "ground"}
    steps: list[list[Place]] = []
    boxes: list[list[PlacedBox]] = []
    now = 0.0
    for step in _steps(program):
        if isinstance(step, End):
            now = step.time
            break
        steps.append(step)
        boxes.append([])
        for action in step:
            nominal = Pose.from_euler(action.position, action.yaw, action.pitch, action.roll)
            target = Pose(nominal.position - [0.0, 0.0, engine.SEAT], nominal.orientation)
            box = Box(np.array(action.brick.half_extents), action.brick.mass)
            boxes[-1].append(PlacedBox(len(labels) + len(program.fixtures), box, target, action.brick.friction))
            labels[boxes[-1][-1].key] = action.id
    placing = _placing(program, labels)
    collapse: Collapse | None = None
    certificate: Certificate | None = None
    stopped: str | None = None
    reached = len(steps)
    if deadline is not None and _time.perf_counter() >= deadline:
        proved, slack, reached = 0, 0.0, 0
        stopped = f"timeout after {float(f'{timeout:.3g}'):g} s at 0 of {len(steps)} placements"
    else:
        proved, slack = placing.proved_steps(boxes)  # every step at once, by fixed shares: most stacks end here
    if proved < len(steps) and stopped is None:  # from the first step they do not prove, one step at a time
        placing = _placing(program, labels)
        placing.put([b for step in boxes[:proved] for b in step])
        for i in range(proved, len(steps)):
            if deadline is not None and _time.perf_counter() >= deadline:
                stopped = f"timeout after {float(f'{timeout:.3g}'):g} s at {i} of {len(steps)} placements"
                reached = i
                break
            found = placing.place(boxes[i])
            if not found.stands:
                reached = i + 1
                placed = [a for step in steps[:reached] for a in step]
                collapse, certificate = _collapse(found, steps[i][-1], placed, labels)
                break
    placed = [a for step in steps[:reached] for a in step]
    events = [Event(time=a.time, kind="place", brick=a.id, level=a.level) for a in placed]
    if collapse is not None:
        now = collapse.time
        said = f"collapse level {collapse.level}; {certificate.detail if certificate else ''}"
        events.append(Event(time=now, kind="collapse", brick=collapse.brick, level=collapse.brick_level, detail=said))
    elif stopped is not None:
        now = placed[-1].time if placed else 0.0
    levels = {a.id: a.level for a in placed}
    certify_started = _time.perf_counter()
    if collapse is None and stopped is None:
        certificate = _stands(placing, slack if proved == len(steps) else None)
    certify_time = _time.perf_counter() - certify_started
    moving = frozenset(k for k, label in labels.items() if certificate is not None and label in certificate.bricks)
    graph = Graph.from_stability(placing.graph(labels, moving), levels, {a.id: 0.0 for a in placed})
    ids = {a.id for a in placed}
    return Outcome(
        scenario=program.name,
        mode=engine.mode,
        backend=engine.backend,
        collapse=collapse,
        events=tuple(events),
        final_graph=graph,
        collapse_graph=graph if collapse is not None else None,
        displacement={a.id: 0.0 for a in placed},
        drift=0.0,
        kinetic_energy=0.0,
        levels_placed=max((a.level for a in placed), default=0),
        bricks_placed=len(placed),
        unplaced=tuple(a.id for a in program.placements if a.id not in ids),
        simulated_time=now,
        wall_time=_time.perf_counter() - start,
        steps=0,
        steps_skipped=0,
        certificate=certificate,
        certificate_time=certify_time,
        stopped=stopped,
        collapse_threshold_mm=round(program.collapse_threshold * 1000, 3) + 0.0,
    )


def _steps(program: Program) -> Iterator[list[Place] | End]:
    """The program's placements, those of one step together, in order, then its end.

    Raises:
        ValueError: an action that needs motion (module docstring of :func:`run_placed`).
    """
    group: list[Place] = []
    for action in program.actions:
        if group and (not isinstance(action, Place) or action.step != group[0].step):
            yield group
            group = []
        if isinstance(action, End):
            yield action
            return
        if not isinstance(action, Place):
            raise ValueError(f"{action.kind} at {action.time:g} s needs motion: a backend without dynamics cannot run it")
        group.append(action)
    if group:
        yield group


def _placing(program: Program, labels: dict[int, str]) -> Placing:
    """A :class:`stability.Placing` on the program's ground, with its fixtures (keys from 1,
    labelled in ``labels``)."""
    placing = Placing(GROUND, program.ground_friction, gravity=program.engine.gravity)
    for key, f in enumerate(program.fixtures, start=1):
        pose = Pose.from_euler(f.position, f.yaw, f.pitch, f.roll)
        placing.add_fixed(PlacedBox(key, Box(np.array(f.brick.half_extents), f.brick.mass), pose, f.brick.friction))
        labels[key] = f.id
    return placing


def _collapse(found: Placed, action: Place, placed: list[Place], labels: dict[int, str]) -> tuple[Collapse, Certificate]:
    """The collapse once ``action``'s brick is placed and ``found`` says no forces balance the
    bricks: named after the lowest brick of the mechanism (then the first placed; the brick
    just placed when the program names none)."""
    answer = found.answer
    order = {a.id: i for i, a in enumerate(placed)}
    level_of = {a.id: a.level for a in placed}
    mechanism = sorted((labels[k] for k in (answer.moving() if answer is not None else ())), key=order.__getitem__)
    bricks = tuple(mechanism) or (action.id,)
    first = min(bricks, key=lambda b: (level_of[b], order[b]))
    tension = answer.tension if answer is not None else math.inf
    detail = f"no equilibrium once {action.id} is placed: {tension:.3g} N of tension needed"
    collapse = Collapse(
        level=action.level, time=action.time, brick=first, brick_level=level_of[first], displacement=0.0, decided=action.time
    )
    return collapse, Certificate(verdict="collapse", kind="no equilibrium", detail=detail, bricks=bricks)


def _stands(placing: Placing, slack: float | None) -> Certificate:
    """The certificate of bricks that all stand: their load paths (the margin their ``slack``,
    or :attr:`stability.Placing.slack` when None; no friction asked), or the equilibrium
    program's solution (its margin and friction share, :func:`stability.equilibrium_margin`,
    :func:`stability.friction_share`)."""
    n, contacts = len(placing.free), len(placing.polygons)
    if slack is not None or placing.proved:
        margin = slack if slack is not None else placing.slack
        proof = Equilibrium(True, 0.0, margin, (), n, (), contacts, method="load paths")
    else:
        blocks = {k: RigidBlock(placing.boxes[k].box.mass, placing.boxes[k].pose.position) for k in placing.free}
        margin = equilibrium_margin(blocks, placing.polygons, gravity=placing.gravity) or 0.0
        share = friction_share(blocks, placing.polygons, gravity=placing.gravity)
        proof = Equilibrium(True, 0.0, margin, (), n, (), contacts, method="program", friction=share)
    return Certificate(
        verdict="stands",
        kind="equilibrium",
        detail=stand_words(proof, {}),
        margin_mm=math.floor(round(proof.margin * 10_000, 6)) / 10 + 0.0,
        friction_share=math.ceil(round(proof.friction * 100, 6)) / 100,
    )
