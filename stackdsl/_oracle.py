"""The oracle: answers computed from the placed poses alone, without any simulation.

:func:`equilibrium_collapse` places the program's bricks one by one at their exact target
poses and asks rigid-block equilibrium (:func:`stability.solve_equilibrium`) after each
whether the structure stands; the first brick after which it does not gives the collapse
level (the highest level placed when the first collapse happens). Contacts
are the exact overlaps of touching faces, so the oracle takes bricks that lie flat (a
tower, a wall, an explicit stack; each with an axis vertical); others are refused.

Source: stackdsl's own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stability import Box, ContactArea, ContactPolygon, Plane, Pose, RigidBlock, face_overlap, pair_friction, solve_equilibrium

from ._program import Fixture, Place, Program

_GAP = 1e-4  # m: placed poses touch exactly; this only absorbs rounding


@dataclass(frozen=True)
class OracleResult:
    """What rigid-block equilibrium says of a program's structure.

    Attributes:
        collapse_level: the level of the first brick after which the structure cannot
            stand, or None when it stands to the end.
        brick: that brick's id, or None.
        bricks_standing: how many bricks stood before it (all of them when it stands).
    """

    collapse_level: int | None
    brick: str | None
    bricks_standing: int


def equilibrium_collapse(program: Program) -> OracleResult:
    """Place the bricks of ``program`` one at a time and find the first that cannot stand.

    Raises:
        ValueError: a brick or fixed body does not lie flat (thinnest side vertical).
    """
    places = program.placements
    fixtures = program.fixtures
    bodies: list[Place | Fixture] = [*places, *fixtures]
    for body in bodies:
        _flat(body)
    for k in range(1, len(places) + 1):
        blocks, contacts = structure(places[:k], fixtures, program.ground_friction)
        if not solve_equilibrium(blocks, contacts).stands:
            return OracleResult(places[k - 1].level, places[k - 1].id, k - 1)
    return OracleResult(None, None, len(places))


def structure(
    places: list[Place], fixtures: tuple[Fixture, ...], ground_friction: float
) -> tuple[dict[str, RigidBlock], list[ContactPolygon[str]]]:
    """Free blocks and contact polygons of flat bricks at their placed poses.

    Returns:
        (brick id -> :class:`stability.RigidBlock`, contacts with the ground, fixed
        bodies and each other, each pair once).
    """
    bodies = [(p.id, _box(p), _pose(p), p.brick.friction) for p in places]
    supports = [(f.id, _box(f), _pose(f), f.brick.friction) for f in fixtures]
    contacts: list[ContactPolygon[str]] = []
    for i, (name, box, pose, mu) in enumerate(bodies):
        ground = face_overlap(box, pose, Plane(0.0), None, _GAP)
        if ground is not None:
            contacts.append(_contact(name, "ground", ground, pair_friction(mu, ground_friction)))
        for other, obox, opose, omu in supports + bodies[:i] + bodies[i + 1 :]:
            area = face_overlap(box, pose, obox, opose, _GAP)
            if area is not None and area.area > 1e-9:
                contacts.append(_contact(name, other, area, pair_friction(mu, omu)))
    blocks = {name: RigidBlock(box.mass, pose.position) for name, box, pose, _ in bodies}
    return blocks, contacts


def _contact(body: str, other: str, area: ContactArea, friction: float) -> ContactPolygon[str]:
    ring = np.asarray(area.polygon.exterior.coords)[:-1]
    return ContactPolygon(body, other, np.column_stack([ring, np.full(len(ring), area.height)]), area.normal, friction)


def _box(p: Place | Fixture) -> Box:
    return Box(np.array(p.brick.half_extents), p.brick.mass)


def _pose(p: Place | Fixture) -> Pose:
    return Pose.from_euler(p.position, p.yaw, p.pitch, p.roll)


def _flat(p: Place | Fixture) -> None:
    """A body with one of its axes vertical (within 0.5 deg): its top and bottom are level."""
    if np.abs(_pose(p).rotation[2]).max() < np.cos(np.radians(0.5)):
        raise ValueError(f"the oracle needs bricks lying flat; {p.id} does not")
