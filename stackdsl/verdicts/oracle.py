"""The oracle: answers computed from the placed poses alone, without any simulation.

:func:`equilibrium_collapse` places the program's bricks one by one at their exact target
poses and asks rigid-block equilibrium (:func:`stability.solve_equilibrium`) after each
whether the structure stands; the first brick after which it does not gives the collapse
level (the highest level placed when the first collapse happens). Contacts between bricks
that lie flat (an axis vertical) are the exact overlaps of touching faces; a tilted brick (one
leaning on a wall) touches with its corners, each corner within 0.1 mm of a flat body's face or
the ground a contact point. Two tilted bricks that touch each other (a card house) are refused.

Source: stackdsl's own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stability import Box, ContactArea, ContactPolygon, Plane, Pose, RigidBlock, face_overlap, pair_friction, solve_equilibrium

from ..compile.program import Fixture, Place, Program

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
        ValueError: two tilted bricks or fixed bodies touch.
    """
    places = program.placements
    fixtures = program.fixtures
    bodies: list[Place | Fixture] = [*places, *fixtures]
    _apart([b for b in bodies if not _flat(b)])
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
    everything: list[Place | Fixture] = [*places, *fixtures]
    flat = {p.id for p in everything if _flat(p)}
    contacts: list[ContactPolygon[str]] = []
    for i, (name, box, pose, mu) in enumerate(bodies):
        if name not in flat:
            others = [o for o in supports + bodies[:i] + bodies[i + 1 :] if o[0] in flat]
            contacts += _corner_contacts(name, box, pose, mu, others, ground_friction)
            continue
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
    return ContactPolygon(body, other, area.corners(), area.normal, friction)


def _box(p: Place | Fixture) -> Box:
    return Box(np.array(p.brick.half_extents), p.brick.mass)


def _pose(p: Place | Fixture) -> Pose:
    return Pose.from_euler(p.position, p.yaw, p.pitch, p.roll)


def _flat(p: Place | Fixture) -> bool:
    """A body with one of its axes vertical (within 0.5 deg): its top and bottom are level."""
    return bool(np.abs(_pose(p).rotation[2]).max() >= np.cos(np.radians(0.5)))


def _apart(tilted: list[Place | Fixture]) -> None:
    """Raise ValueError when two tilted bodies come within 0.1 mm of each other (their
    axis-aligned bounds overlap: a conservative test)."""
    bounds = [(p.id, _box(p).corners(_pose(p))) for p in tilted]
    for i, (a, ca) in enumerate(bounds):
        for b, cb in bounds[i + 1 :]:
            if np.all(ca.min(axis=0) - _GAP <= cb.max(axis=0)) and np.all(cb.min(axis=0) - _GAP <= ca.max(axis=0)):
                raise ValueError(
                    f"the oracle takes tilted bricks only where they touch bricks lying flat; {a} and {b} are tilted and touch"
                )


def _corner_contacts(
    name: str,
    box: Box,
    pose: Pose,
    mu: float,
    others: list[tuple[str, Box, Pose, float]],
    ground_friction: float,
) -> list[ContactPolygon[str]]:
    """The contacts of a tilted brick: its corners within 0.1 mm of the ground, and of each
    face of a flat body (inside the face), one contact per body touched."""
    corners = box.corners(pose)
    out = []
    low = corners[corners[:, 2] < _GAP]
    if len(low):
        out.append(ContactPolygon(name, "ground", low, np.array([0.0, 0.0, 1.0]), pair_friction(mu, ground_friction)))
    for other, obox, opose, omu in others:
        local = (corners - opose.position) @ opose.rotation  # the corners in the other body's frame
        half = obox.half_extents
        inside = np.abs(local) <= half + _GAP
        for axis in range(3):
            for sign in (1.0, -1.0):
                on = (np.abs(local[:, axis] - sign * half[axis]) < _GAP) & inside.all(axis=1)
                if on.any():
                    normal = sign * opose.rotation[:, axis]
                    out.append(ContactPolygon(name, other, corners[on], normal, pair_friction(mu, omu)))
    return out
