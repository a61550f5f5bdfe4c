"""A throw at a level's side, aimed at its brick as it lies when the projectile is thrown.

The compiler aims a throw at ``{level, side}`` at the middle of a brick's face as the scenario
places it (:mod:`stackdsl.compile.aim`). Something may have moved that brick since: a push, a
pull that dragged it, a shake, a fall. When it is thrown, the projectile's whole flight is moved
by as much as that face's middle has moved, so that it keeps its speed, direction and flight time
and meets the face where it lies. A brick that has left its level (tipped past its edge, or its
centre fallen below where its bottom was placed) is not aimed at: the throw goes to the level's
outer face among its bricks still on it, and when none is, or when the moved start would be
inside a body or below the ground, the projectile is not thrown and its ``launch`` line says why.

Source: stackdsl's own (a push's path is moved the same way, :mod:`stackdsl.runtime.actions`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from stability import Box, Pose

from ..compile.aim import face_middle, outer_face
from ..compile.clearance import TOLERANCE, deepest
from ..compile.program import Fixture, Launch
from ..engines.protocol import World
from .bricks import BrickRecord, Structure

#: Metres the aimed face's middle must have moved since it was placed for the throw to move with
#: it (less is a brick settling on its supports).
SHIFTED = 0.0001


def aim(a: Launch, structure: Structure, world: World, fixtures: Sequence[Fixture]) -> tuple[Pose | None, str]:
    """Where projectile ``a`` starts (None: it is not thrown) in ``world`` as it is now, with the
    bricks of ``structure`` and the ``fixtures``, and what the run did to its aim, in words (""
    when nothing): which brick it was aimed at, how far that lies from where it was placed and
    how far the throw moved, or why it is not thrown."""
    pose = Pose.from_euler(a.position, a.yaw, a.pitch, 0.0)
    if not a.aim or a.face is None:
        return pose, ""
    outward = np.array(a.face)
    choice = _choose(a, structure, world, outward)
    if isinstance(choice, str):
        return None, choice
    chosen, off = choice
    now = face_middle(chosen.box, world.pose(chosen.body), outward)
    # the compiler aimed at the face as the scenario places it; a brick is placed a little lower (its
    # supports' sink, its engine's seat): that offset is left as the compiler left it
    target = now + face_middle(chosen.box, chosen.nominal, outward) - face_middle(chosen.box, chosen.pose, outward)
    shift = target - np.array(a.target)
    gone = "" if chosen.id == a.aim[0] else f"{a.aim[0]} {off.get(a.aim[0], 'is out of the scene')}; aimed at {chosen.id}"
    if float(np.linalg.norm(shift)) < SHIFTED and not gone:
        return pose, ""
    moved = Pose(pose.position + shift, pose.orientation)
    lies = gone or f"{chosen.id} lies {structure.displacement(chosen) * 1000:.3g} mm from where it was placed"
    blocked = _blocked(a, moved, structure, world, fixtures)
    if blocked is not None:
        return None, f"{lies}: not thrown: to meet its face as it lies, {blocked}"
    dx, dy, dz = (round(float(v) * 1000, 1) + 0.0 for v in shift)
    return moved, f"{lies}: thrown from ({dx:.1f}, {dy:.1f}, {dz:.1f}) mm off its aim as placed, to meet its face as it lies"


def _choose(a: Launch, structure: Structure, world: World, outward: np.ndarray) -> tuple[BrickRecord, dict[str, str]] | str:
    """The brick projectile ``a`` is aimed at as the run left its level, with why each brick of
    its level in the scene has left it (by id); or why it is not thrown, in words. The first
    brick the compiler aimed at when it is still on its level, else the one with the level's
    outer face along ``outward`` (a unit vector) among those still on it."""
    records = [structure.records.get(i) for i in a.aim]
    placed = set(map(id, structure.placed))
    there = [r for r in records if r is not None and id(r) in placed]
    if not there:
        return f"not thrown: no brick of its level is in the scene ({', '.join(a.aim)})"
    off = {r.id: why for r in there if (why := _off_level(world, r))}
    on = [r for r in there if r.id not in off]
    if not on:
        said = "; ".join(f"{k} {v}" for k, v in off.items())
        return f"not thrown: every brick of its level there has left it ({said}): nothing is left to aim at"
    if on[0].id == a.aim[0]:
        return on[0], off
    # the brick aimed at has left its level: the level's outer face among those still on it
    poses = [world.pose(r.body) for r in on]
    return on[outer_face([r.box for r in on], poses, outward)[0]], off


def _off_level(world: World, r: BrickRecord) -> str:
    """Why brick ``r`` is no longer on its level, in words, or "": tipped past its tipping angle
    (:meth:`~stackdsl.runtime.bricks.Structure.toppled`'s angle), or fallen, its centre lower than
    its bottom was placed."""
    now = world.pose(r.body)
    placed = r.pose.rotation
    half = np.abs(placed) @ np.array(r.box.half_extents)  # the placed box's half extents in the world
    tip = math.atan2(min(half[0], half[1]), half[2])
    up = placed.T @ np.array([0.0, 0.0, 1.0])  # the brick's own axis that was vertical
    tilt = math.acos(max(-1.0, min(1.0, float((now.rotation @ up)[2]))))
    if tilt > tip:
        return f"has tipped over ({math.degrees(tilt):.3g} deg)"
    bottom = float(r.corners[:, 2].min())
    if float(now.position[2]) < bottom:
        return f"has fallen {(float(r.pose.position[2]) - float(now.position[2])) * 1000:.3g} mm"
    return ""


def _blocked(a: Launch, pose: Pose, structure: Structure, world: World, fixtures: Sequence[Fixture]) -> str | None:
    """Why projectile ``a`` cannot start at ``pose``: its box there would reach below the ground
    or into a body in the world (deeper than :data:`~stackdsl.compile.clearance.TOLERANCE`), as
    the compiler refuses at its start as placed; None when it can."""
    box = Box(np.array(a.brick.half_extents), a.brick.mass)
    low = float(box.corners(pose)[:, 2].min())
    if low < -TOLERANCE:
        return f"the projectile would start {-low * 1000:.3g} mm below the ground"
    bodies = [(r.id, r.spec, world.pose(r.body)) for r in structure.records.values() if r.id != a.id]
    bodies += [(f.id, f.brick, Pose.from_euler(f.position, f.yaw, f.pitch, f.roll)) for f in fixtures]
    inside = deepest(box, pose, bodies)
    if inside is None:
        return None
    return f"the projectile would start {inside[1] * 1000:.3g} mm inside {inside[0]}"
