"""The bricks of the richer scenes' generators: a wall in running bond, a stepped pyramid and a
row of dominoes (:mod:`stackdsl.lang.schema_generators`), each in its own frame (its ``origin``
and ``yaw`` applied; a part's are :mod:`stackdsl.compile.parts`'), with levels and ids.

Geometry, for a brick of length L, width W and height H, ``joint`` j, pitch p = L + j along a
course:

* **wall**, n bricks a course: odd courses at (k - (n - 1) / 2) p, k = 0..n-1; even courses'
  whole bricks over the joints below, at (k - (n - 2) / 2) p, k = 0..n-2, and a half brick
  (L / 2) at each end, its outer face flush with the course below (the ends are straight; the
  joint beside it is j / 2). Every whole brick of an even course spans two below, its centre of
  mass over their joint; every brick of an odd course spans the joint of two above-course
  bricks or rests on a closer and a whole brick; a closer lies wholly on the end brick under it,
  its centre of mass L / 4 inside that brick's end.
* **pyramid**: course c has base - c + 1 bricks at (k - (m - 1) / 2) p: each over a joint of
  the course below.
* **dominoes**: brick k at arc length s = k x spacing from the first, along a line or a circle of
  signed radius R (heading θ(s) = θ0 + s / R, centre at the first domino plus R times the
  left normal), standing on end (pitch 90 deg: its length vertical, its height along the row).

Courses ``laid: flat`` are H high; ``laid: edge`` (the brick rolled 90 deg about its length)
W high.

Source: stackdsl's own; running bond, closers and racking are the bricklayer's (e.g. the Brick
Industry Association's Technical Note 30, "Bonds and Patterns in Brickwork"); the tipping angle
is textbook statics (:func:`tipping_angle`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from ..lang.errors import FieldPath
from ..lang.schema import Scenario
from ..lang.schema_generators import HALF, Dominoes, Pyramid, Wall
from .layouts import LaidBrick, wrap


def tipping_angle(thickness: float, height: float) -> float:
    """The angle from vertical (radians) at which a block standing on a face ``thickness`` deep
    (along the tilt) and ``height`` high, tilted about an edge of that face, has its centre of mass
    straight above the edge: atan(thickness / height). Tilted less, gravity turns it back onto its
    face; tilted more, it falls over (a domino's toppling angle, friction holding the edge).

    Source: the equilibrium of a rigid body on an edge (J. L. Meriam and L. G. Kraige,
    Engineering Mechanics: Statics, chapter 3, equilibrium; the tipping of a block): the
    weight's line of action passes the pivot when tan θ = (t / 2) / (h / 2).
    """
    return math.atan2(thickness, height)


def _course(scenario: Scenario, brick: str, laid: str) -> tuple[float, float, float]:
    """(length, course height, roll in degrees) of ``brick`` laid flat or on edge."""
    length, width, height = scenario.brick_type(brick).size
    return (length, height, 0.0) if laid == "flat" else (length, width, 90.0)


def _placed(origin: tuple[float, float], yaw: float, along: float, z: float) -> np.ndarray:
    """A point ``along`` the generator's own x, at height ``z``, in the generator's frame."""
    c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    return np.array([origin[0] + along * c, origin[1] + along * s, z])


def wall(scenario: Scenario, w: Wall, path: FieldPath) -> list[LaidBrick]:
    """A wall in running bond (see the module's docstring), course by course from ``-x`` to ``+x``."""
    length, high, roll = _course(scenario, w.brick, w.laid)
    p, n = length + w.joint, w.bricks_per_course
    bricks: list[LaidBrick] = []
    for c in range(1, w.courses + 1):
        z = (c - 0.5) * high
        if c % 2:
            row = [((k - (n - 1) / 2) * p, w.brick) for k in range(n)]
        else:
            end = (n - 1) * p / 2 + length / 4  # a closer's centre: its outer face flush with the course below
            half = w.brick + HALF
            row = [(-end, half), *(((k - (n - 2) / 2) * p, w.brick) for k in range(n - 1)), (end, half)]
        for k, (x, kind) in enumerate(row):
            position = _placed(w.origin, w.yaw, x, z)
            bricks.append(LaidBrick(f"L{c:02d}.{k + 1}", c, kind, position, wrap(w.yaw), roll=roll, source=path))
    return bricks


def pyramid(scenario: Scenario, pyr: Pyramid, path: FieldPath) -> list[LaidBrick]:
    """A stepped pyramid (see the module's docstring), course by course from ``-x`` to ``+x``."""
    length, high, roll = _course(scenario, pyr.brick, pyr.laid)
    p = length + pyr.joint
    bricks: list[LaidBrick] = []
    for c in range(1, pyr.courses + 1):
        m = pyr.base - c + 1
        for k in range(m):
            position = _placed(pyr.origin, pyr.yaw, (k - (m - 1) / 2) * p, (c - 0.5) * high)
            bricks.append(LaidBrick(f"L{c:02d}.{k + 1}", c, pyr.brick, position, wrap(pyr.yaw), roll=roll, source=path))
    return bricks


def domino_spacing(scenario: Scenario, d: Dominoes) -> float:
    """The row's spacing, m: as given, or half a brick's length."""
    return d.spacing if d.spacing is not None else scenario.brick_type(d.brick).size[0] / 2


def dominoes(scenario: Scenario, d: Dominoes, path: FieldPath) -> list[LaidBrick]:
    """A row of dominoes (see the module's docstring), from the first.

    Raises:
        ScenarioError: at ``spacing``, when neighbouring dominoes would overlap (a spacing not
            above the brick's height, its thickness along the row, on a line).
    """
    length, _, thick = scenario.brick_type(d.brick).size
    spacing = domino_spacing(scenario, d)
    if spacing <= thick:
        raise scenario.source.error(
            path + ("spacing",),
            f"dominoes {thick * 1000:g} mm thick along the row would overlap {spacing * 1000:g} mm apart: "
            f"use a spacing above {thick * 1000:g} mm (half a brick's length, {length * 500:g} mm, is the default)",
        )
    digits = max(2, len(str(d.count)))
    heading0 = math.radians(d.yaw)
    x0, y0 = d.origin
    bricks: list[LaidBrick] = []
    for k in range(d.count):
        s = k * spacing
        if d.radius is None:
            heading = heading0
            x, y = x0 + s * math.cos(heading0), y0 + s * math.sin(heading0)
        else:
            r = d.radius
            heading = heading0 + s / r
            cx, cy = x0 - r * math.sin(heading0), y0 + r * math.cos(heading0)  # the first plus R x left normal
            x, y = cx + r * math.sin(heading), cy - r * math.cos(heading)
        position = np.array([x, y, length / 2])
        bricks.append(LaidBrick(f"D{k + 1:0{digits}d}", 1, d.brick, position, wrap(math.degrees(heading)), 90.0, source=path))
    return bricks


def warn_wrapped_rows(scenario: Scenario, bricks: Sequence[LaidBrick]) -> None:
    """Warn, at its ``count``, of a row of dominoes on an arc that runs round past its start: a
    domino other than the second comes back nearer the first than the second stands (a new
    user's 22 slats 120 mm apart on a 400 mm radius: D22 stood 0.7 mm in front of D01, and the
    row ran into its own start). Asked once nothing refuses the file (one that overlaps the first
    is refused, as any overlap is)."""
    rows: dict[FieldPath, list[LaidBrick]] = {}
    for b in bricks:
        if b.source and b.source[-1] == "dominoes":
            rows.setdefault(b.source, []).append(b)
    for path, row in rows.items():
        if len(row) < 3:
            continue
        first = row[0].position[:2]
        spacing = float(np.linalg.norm(row[1].position[:2] - first))
        back = next((b for b in row[2:] if float(np.linalg.norm(b.position[:2] - first)) < 0.75 * spacing), None)
        if back is None:
            continue
        gap = float(np.linalg.norm(back.position[:2] - first))
        warnings.warn(
            scenario.source.warning(
                path + ("count",),
                f"the row runs round its arc past its start: {back.id} comes back to {row[0].id}, its centre "
                f"{gap * 1000:.1f} mm from {row[0].id}'s; give fewer dominoes or a larger radius",
            ),
            stacklevel=3,
        )
