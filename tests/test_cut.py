"""The turning-part proof of a collapse: never wrong when it says 'falls', and it finds the
mechanisms of slanted single files and log cabins."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from stability import ContactPolygon, RigidBlock, solve_equilibrium
from stability._cut import falling_part

MASS = 0.0106
UP = np.array([0.0, 0.0, 1.0])


def _footprint(centre: np.ndarray, along_x: bool) -> tuple[float, float, float, float]:
    half = (0.06, 0.012) if along_x else (0.012, 0.06)
    return centre[0] - half[0], centre[0] + half[0], centre[1] - half[1], centre[1] + half[1]


def _contact(upper: tuple[np.ndarray, bool], lower: tuple[np.ndarray, bool] | None, z: float) -> np.ndarray | None:
    """Corners (4, 3) of the overlap of two footprints at height z (the ground when lower is None)."""
    a = _footprint(*upper)
    b = _footprint(*lower) if lower is not None else (-1.0, 1.0, -1.0, 1.0)
    x0, x1, y0, y1 = max(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), min(a[3], b[3])
    if x1 - x0 < 1e-6 or y1 - y0 < 1e-6:
        return None
    return np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])


def _random_stack(rng: np.random.Generator, levels: int, tilt: float) -> tuple[dict[int, RigidBlock], list[ContactPolygon[int]]]:
    """A log cabin or a single file, each level turned or not, shifted at random; every contact
    normal tilted up to ``tilt`` rad and every contact point moved up to 0.2 mm in height."""
    blocks: dict[int, RigidBlock] = {}
    contacts: list[ContactPolygon[int]] = []
    below: list[tuple[int, np.ndarray, bool]] = []
    cabin = bool(rng.integers(2))
    drift = rng.uniform(-0.012, 0.012, size=2)
    for level in range(levels):
        along_x = level % 2 == 0 if cabin else True
        z = 0.004 + 0.008 * level
        offsets = [(0.0, -0.048), (0.0, 0.048)] if cabin else [(0.0, 0.0)]
        here = []
        for dx, dy in offsets:
            if not along_x:
                dx, dy = dy, dx
            centre = np.array([dx + level * drift[0], dy + level * drift[1], z]) + [*rng.uniform(-0.004, 0.004, 2), 0]
            key = len(blocks)
            blocks[key] = RigidBlock(MASS * rng.uniform(0.5, 3.0), centre)
            here.append((key, centre, along_x))
            for other, lower in [(-1, None)] if not below else [(k, (c, x)) for k, c, x in below]:
                points = _contact((centre, along_x), lower, z - 0.004)
                if points is None:
                    continue
                points[:, 2] += rng.uniform(-2e-4, 2e-4, len(points))
                normal = Rotation.from_rotvec(rng.normal(size=3) * tilt / np.sqrt(3)).apply(UP)
                contacts.append(ContactPolygon(key, other, points, normal, float(rng.uniform(0.3, 0.7))))
        below = here
    return blocks, contacts


@pytest.mark.slow
@pytest.mark.parametrize("tilt", [0.0, 0.02])
def test_a_part_said_to_fall_cannot_stand_by_the_equilibrium_program(tilt: float) -> None:
    rng = np.random.default_rng(3)
    falls, proven = 0, 0
    for _ in range(300):
        blocks, contacts = _random_stack(rng, int(rng.integers(2, 9)), tilt)
        part = falling_part(blocks, contacts)
        stands = solve_equilibrium(blocks, contacts).stands
        falls += not stands
        if part is not None:
            proven += 1
            assert not stands, "a part that turns out with its contacts opening is a collapse mechanism"
            alone = {k: b for k, b in blocks.items() if k in part}  # the rest held fixed
            assert not solve_equilibrium(alone, contacts).stands, "the part falls even on a stack that stays"
    assert falls > 50 and proven > 0.5 * falls  # it proves most of the collapses drawn


def test_a_single_file_shifted_13_mm_a_level_falls_above_its_first_brick_at_ten_bricks() -> None:
    """The bricks above brick 0 have their centre of mass n x 6.5 mm from its centre, inside
    its top face (60 mm) for n <= 9: nine stand, and at ten the nine above the first turn out."""
    for count, part in ((9, None), (10, frozenset(range(1, 10)))):
        centres = [np.array([0.013 * k, 0.0, 0.004 + 0.008 * k]) for k in range(count)]
        blocks = {k: RigidBlock(MASS, c) for k, c in enumerate(centres)}
        contacts = [ContactPolygon(0, -1, _contact((centres[0], True), None, 0.0), UP, 0.5)]  # type: ignore[arg-type]
        contacts += [
            ContactPolygon(k, k - 1, _contact((centres[k], True), (centres[k - 1], True), 0.008 * k), UP, 0.5)  # type: ignore[arg-type]
            for k in range(1, count)
        ]
        assert falling_part(blocks, contacts) == part


def test_one_brick_of_a_level_turns_out_from_under_the_levels_above_while_its_sibling_stays() -> None:
    """A log cabin's second level: bricks 2 and 3 across bricks 0 and 1, and a heavy block on
    them with its centre of mass beyond the edge of brick 2's supports (x = 60 mm). The whole
    upper part has its centre of mass inside its footing; brick 2 with the block does not."""
    low = [np.array([0.0, y, 0.004]) for y in (-0.048, 0.048)]
    mid = [np.array([x, 0.0, 0.012]) for x in (0.050, -0.046)]
    top = np.array([0.061, 0.0, 0.020])
    blocks = {0: RigidBlock(MASS, low[0]), 1: RigidBlock(MASS, low[1]), 2: RigidBlock(MASS, mid[0])}
    blocks |= {3: RigidBlock(MASS, mid[1]), 4: RigidBlock(20 * MASS, top)}
    contacts = [ContactPolygon(k, -1, _contact((low[k], True), None, 0.0), UP, 0.5) for k in (0, 1)]  # type: ignore[arg-type]
    contacts += [
        ContactPolygon(2 + m, k, _contact((mid[m], False), (low[k], True), 0.008), UP, 0.5)  # type: ignore[arg-type]
        for m in (0, 1)
        for k in (0, 1)
    ]
    ledge = np.array([[x, y, 0.016] for x, y in ((0.038, -0.01), (0.062, -0.01), (0.062, 0.01), (0.038, 0.01))])
    contacts += [ContactPolygon(4, 2, ledge, UP, 0.5), ContactPolygon(4, 3, ledge - [0.096, 0, 0], UP, 0.5)]
    result = solve_equilibrium(blocks, contacts)
    assert falling_part(blocks, contacts) == frozenset({2, 4}) == {k for k, v in result.mechanism.items() if v > 1e-4}


@pytest.mark.slow
@pytest.mark.parametrize("tilt", [0.05, 1.0])
def test_near_its_edge_a_brick_is_said_to_fall_only_where_the_program_agrees(tilt: float) -> None:
    """A brick on a brick, its centre of mass within 3 mm of the lower one's end, with contact
    points up to 1 mm apart in height and normals tilted up to 0.05 rad (or 1 rad, steep as a
    leaning brick's): the turning axis's offset (friction times the spread of heights) and the
    check of every point against the friction cone must keep every 'falls' right."""
    rng = np.random.default_rng(5)
    agreed = 0
    for _ in range(400):
        centres = [np.array([0.0, 0.0, 0.004]), np.array([0.06 + rng.uniform(-0.003, 0.003), 0.0, 0.012])]
        blocks = {1: RigidBlock(MASS, centres[1])}
        points = _contact((centres[1], True), (centres[0], True), 0.008)
        assert points is not None
        points[:, 2] += rng.uniform(-5e-4, 5e-4, len(points))
        normal = Rotation.from_rotvec([*rng.uniform(-tilt, tilt, 2), 0.0]).apply(UP)
        contacts = [ContactPolygon(1, 0, points, normal, float(rng.uniform(0.2, 0.9)))]
        stands = solve_equilibrium(blocks, contacts).stands
        if falling_part(blocks, contacts) is not None:
            assert not stands
            agreed += 1
    assert agreed > 100


@pytest.mark.slow
def test_a_block_on_steep_contacts_is_said_to_fall_only_where_the_program_agrees() -> None:
    """A block on a small pad and a ledge whose normals are tilted up to 1.2 rad (a leaning
    brick's contacts), its centre of mass beyond the pad: turning out may close a steep contact,
    and then it is no mechanism (each point's velocity is checked against the friction cone)."""
    rng = np.random.default_rng(2)
    said = 0
    for _ in range(1000):
        pad = np.array([[0.0, -0.012, 0], [0.02, -0.012, 0], [0.02, 0.012, 0], [0.0, 0.012, 0]])
        pad[:, 2] += rng.uniform(-0.003, 0.003, 4)
        ledge = np.array([[-0.05, -0.012, 0.0], [-0.05, 0.012, 0.0]]) + [0, 0, rng.uniform(-0.01, 0.01)]
        normals = [Rotation.from_rotvec([*rng.uniform(-1.2, 1.2, 2), 0]).apply(UP) for _ in range(2)]
        centre = np.array([rng.uniform(0.015, 0.03), 0, rng.uniform(0.0, 0.03)])
        contacts = [
            ContactPolygon(1, 0, pad, normals[0], float(rng.uniform(0.1, 1.0))),
            ContactPolygon(1, 2, ledge, normals[1], float(rng.uniform(0.1, 1.0))),
        ]
        blocks = {1: RigidBlock(MASS, centre)}
        if falling_part(blocks, contacts) is not None:
            assert not solve_equilibrium(blocks, contacts).stands
            said += 1
    assert said > 100


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_a_block_on_a_slanting_knife_edge_falls_to_the_side_of_its_centre_of_mass(side: float) -> None:
    """A line contact running down to the right in plan (collinear points: no hull, its two sides
    instead), the centre of mass 5 mm off it on either side: the block turns about the line."""
    line = np.array([[-0.03, 0.03, 0.0], [0.0, 0.0, 0.0], [0.03, -0.03, 0.0]])
    off = side * 0.005 * np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    blocks = {1: RigidBlock(MASS, np.array([0.0, 0.0, 0.01]) + off)}
    contacts = [ContactPolygon(1, 0, line, UP, 0.5)]
    assert not solve_equilibrium(blocks, contacts).stands
    assert falling_part(blocks, contacts) == frozenset({1})
