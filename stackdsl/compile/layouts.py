"""The structure's bricks where a scenario puts them: its layout generators (the tower, the
card house, bricks placed by hand), each brick with its level, and the placement error.

Source: stackdsl's own; the tower generator builds the report's 4 stack and slant tower
(chapter 4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from stability import Box, Pose

from ..engines.protocol import BrickSpec
from ..lang.errors import FieldPath
from ..lang.schema import Scenario
from ..lang.schema_layouts import BrickPlacement, CardHouse, Tower

_LEVEL_TOLERANCE = 0.001  # m: bricks whose bottoms are this close share a level


@dataclass(frozen=True)
class LaidBrick:
    """One brick of a layout: its id, level, brick type, centre (m, shape (3,)) and yaw,
    pitch, roll (degrees); ``together``: placed with the brick before it; ``fixed``: a fixture;
    ``source``: the field that made it (``("structure", "tower")``, ``("structure", "bricks", 3)``)."""

    id: str
    level: int
    type: str
    position: np.ndarray
    yaw: float
    pitch: float = 0.0
    roll: float = 0.0
    together: bool = False
    fixed: bool = False
    source: FieldPath = ()  # the field that made it: a generator's, or a brick's in a list

    def pose(self) -> Pose:
        """Its pose."""
        return Pose.from_euler(self.position, self.yaw, self.pitch, self.roll)

    def corners(self, spec: BrickSpec) -> np.ndarray:
        """Its box's eight corners where it is laid, shape (8, 3), m (``spec``: its brick type's body)."""
        corners: np.ndarray = Box(np.array(spec.half_extents), spec.mass).corners(self.pose())
        return corners


def layout(scenario: Scenario) -> list[LaidBrick]:
    """The single layout's bricks (fixtures included) in placement order, with levels, as written or
    generated: a tower, a card house or bricks by hand (the other layouts and composed structures are
    :func:`stackdsl.compile.parts.arrange`'s)."""
    structure = scenario.structure
    if structure.tower:
        return tower(scenario, structure.tower)
    if structure.card_house:
        return card_house(scenario, structure.card_house, ("structure", "card_house"))
    return by_hand(scenario, structure.bricks or [], ("structure", "bricks"))


def with_placement_error(scenario: Scenario, bricks: list[LaidBrick]) -> list[LaidBrick]:
    """The bricks where the program puts them: moved by the placement error (drawn from the seed)."""
    error = scenario.timing.placement_error
    if error > 0:
        rng = np.random.default_rng(np.random.SeedSequence(scenario.seed))
        offsets = rng.uniform(-error, error, size=(len(bricks), 2))
        bricks = [b if b.fixed else replace(b, position=b.position + [dx, dy, 0.0]) for b, (dx, dy) in zip(bricks, offsets)]
    return bricks


def tower(scenario: Scenario, t: Tower, path: FieldPath = ("structure", "tower")) -> list[LaidBrick]:
    """The tower generator: layer L turned (L-1) x turn, centred at origin plus the shifts of
    the layers below it ((L-1) x shift, or the sum of ``shifts``); each brick turned by its
    ``yaw_jitter`` more, about its own centre; ``path``: the tower's field (each brick's source)."""
    height = scenario.brick_type(t.brick).size[2]
    bricks: list[LaidBrick] = []
    shifts = t.layer_shifts()
    origin = np.array(t.origin)
    for level in range(1, t.levels + 1):
        yaw = t.yaw + (level - 1) * t.turn
        across = np.array([-math.sin(math.radians(yaw)), math.cos(math.radians(yaw))])
        centre = origin + np.array(shifts[level - 1])
        for k in range(t.bricks_per_layer):
            xy = centre + (k - (t.bricks_per_layer - 1) / 2) * t.spacing * across
            position = np.array([xy[0], xy[1], (level - 0.5) * height])
            jitter = t.jitter(len(bricks))
            bricks.append(LaidBrick(f"L{level:02d}.{k + 1}", level, t.brick, position, wrap(yaw + jitter), source=path))
    return bricks


def by_hand(scenario: Scenario, placed: list[BrickPlacement], path: FieldPath) -> list[LaidBrick]:
    """Bricks placed by hand (the list at ``path``); a missing level is the rank of the brick's
    bottom height among the list's bricks (fixed ones have none)."""
    bottoms = [
        float(
            Box(np.array(scenario.brick_type(b.brick).size) / 2, 1.0)
            .corners(Pose.from_euler(b.at, b.yaw, b.pitch, b.roll))[:, 2]
            .min()
        )
        for b in placed
    ]
    heights: list[float] = []
    for z in sorted(z for z, b in zip(bottoms, placed) if not b.fixed):
        if not heights or z - heights[-1] > _LEVEL_TOLERANCE:
            heights.append(z)
    return [
        LaidBrick(
            b.id or (f"fixed{i + 1}" if b.fixed else f"b{i + 1:03d}"),
            0 if b.fixed else b.level or 1 + sum(h < z - _LEVEL_TOLERANCE for h in heights),
            b.brick,
            np.array(b.at, dtype=float),
            b.yaw,
            b.pitch,
            b.roll,
            together=b.together,
            fixed=b.fixed,
            source=path + (i,),
        )
        for i, (b, z) in enumerate(zip(placed, bottoms))
    ]


def card_house(scenario: Scenario, c: CardHouse, path: FieldPath) -> list[LaidBrick]:
    """Rows of inverted V's with flat bricks across neighbouring peaks, up to one V.

    In the x-z plane a brick of length L and thickness t leaning at angle a from vertical
    spans a half-width L sin a + t cos a at the base of its V and reaches L cos a + t sin a,
    its top corners t cos a either side of the peak. V row r (0-based, level 2r + 1) has
    ``levels - r`` V's; the flat row above it (level 2r + 2) one fewer. Neighbouring flats
    must not touch (spacing > L) yet each must reach a top corner of both V's under it
    (spacing < L + 2 t cos a): the default spacing is L + 2 mm.

    Raises:
        ScenarioError: the spacing lets V's or flats collide, or flats miss the peaks.
    """
    length, _, thick = scenario.brick_type(c.brick).size
    a = math.radians(c.angle)
    half = length * math.sin(a) + thick * math.cos(a)
    height = length * math.cos(a) + thick * math.sin(a)
    spacing = c.spacing or length + 0.002
    where = path + ("spacing" if c.spacing else "angle",)
    if c.levels > 1 and spacing <= 2 * half:
        raise scenario.source.error(
            where, f"V's {2 * half * 1000:.1f} mm wide at the base would collide {spacing * 1000:.1f} mm apart"
        )
    if c.levels > 1 and not length < spacing < length + 2 * thick * math.cos(a):
        raise scenario.source.error(
            where,
            f"flats {length * 1000:.0f} mm long need peaks between {length * 1000:.0f} and "
            f"{(length + 2 * thick * math.cos(a)) * 1000:.1f} mm apart, got {spacing * 1000:.1f} mm",
        )
    x0, y0 = c.origin
    dx = length / 2 * math.sin(a) + thick / 2 * math.cos(a)
    dz = length / 2 * math.cos(a) + thick / 2 * math.sin(a)
    bricks = []
    for row in range(c.levels):
        base = row * (height + thick)
        peaks = [x0 + (k - (c.levels - row - 1) / 2) * spacing for k in range(c.levels - row)]
        for k, x in enumerate(peaks):
            for side, yaw in ((1, 0.0), (2, 180.0)):
                position = np.array([x - dx if side == 1 else x + dx, y0, base + dz])
                bricks.append(
                    LaidBrick(
                        f"V{2 * row + 1}.{k + 1}{'ab'[side - 1]}",
                        2 * row + 1,
                        c.brick,
                        position,
                        yaw,
                        c.angle - 90.0,
                        together=side == 2,
                        source=path,
                    )
                )
        for k in range(len(peaks) - 1):
            position = np.array([(peaks[k] + peaks[k + 1]) / 2, y0, base + height + thick / 2])
            bricks.append(LaidBrick(f"F{2 * row + 2}.{k + 1}", 2 * row + 2, c.brick, position, 0.0, source=path))
    return bricks


def lie_flat(bricks: list[LaidBrick]) -> np.ndarray:
    """For each brick, whether its own z axis (its height) is vertical within 1 deg; shape (n,).
    One rotation for all bricks (as :meth:`stability.Pose.from_euler`): a 5000-brick tower
    would spend 0.2 s in one call per brick."""
    if not bricks:
        return np.zeros(0, dtype=bool)
    angles = [[b.yaw, b.pitch, b.roll] for b in bricks]
    up = Rotation.from_euler("ZYX", angles, degrees=True).as_matrix()[:, 2, 2]
    return np.asarray(np.abs(up) > math.cos(math.radians(1.0)))


def on_a_face(bricks: list[LaidBrick]) -> np.ndarray:
    """For each brick, whether one of its own axes is vertical within 1 deg (it lies flat, on an
    edge or on an end, face down either way), shape (n,); False: tilted, no face down."""
    if not bricks:
        return np.zeros(0, dtype=bool)
    angles = [[b.yaw, b.pitch, b.roll] for b in bricks]
    up = Rotation.from_euler("ZYX", angles, degrees=True).as_matrix()[:, 2, :]
    return np.asarray((np.abs(up) > math.cos(math.radians(1.0))).any(axis=1))


def wrap(angle: float) -> float:
    """An angle in degrees wrapped to (-180, 180]."""
    wrapped = math.fmod(angle + 180.0, 360.0)
    return (wrapped + 360.0 if wrapped <= 0 else wrapped) - 180.0
